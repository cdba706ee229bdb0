"""Learning in the background: the workspace's model, the takes' typicality, held-out models.

One :class:`Learner` per studio, with one worker thread, so that nothing slow runs on the
studio's loop. It follows the store (:meth:`Learner.follow`, a listener of
:class:`app.core.store.Store`): a change of what is learned from asks for a refit, a new take
asks for its typicality, and so do an import's demonstrations (pending in the workspace). The
scores are published in the learner's state (:attr:`LearnerState.scores`, by the demonstration
scored), then handed to whoever listens (:meth:`Learner.on_scored`: the session's store keeps
them in the workspace). The worker takes the most urgent job
first: the refit of the latest change (a newer request supersedes one in flight, whose result
is then dropped), then the takes' scores, then the held-out model the Infer tab inspects,
fitted with the settings the refit resolved, then the pending demonstrations' scores, a
primitive at a time (both queued by :class:`app.core.scorings.Scorings`).
Each outcome is published as a new :class:`app.core.learner_state.LearnerState` (readers take
:attr:`Learner.state`, lock-free), stamped with the
store's ``learn_version`` it answers: meanwhile the previous model stays in use (and drawn),
and :meth:`Learner.wait` waits for the current one.

Every fit goes through the injected :class:`app.core.fits.FitCache`: a refit of what was
learned a moment ago (Undo delete, a setting put back) reuses that model. A refit starts from
the last model's choice of the automatic settings, which it keeps unless the demonstrations
now say otherwise (:func:`promp.selection.choose_settings`).
"""

from __future__ import annotations

import threading
import traceback
from collections.abc import Callable
from dataclasses import replace
from types import MappingProxyType

from app.core.fits import FitCache, Fitted, Training, held_out_training
from app.core.groups import group_members
from app.core.learner_state import HeldOutKey, LearnerState, resolved_settings
from app.core.scorings import Scorings
from app.core.store_state import StoreState
from app.core.take_scores import Scored
from promp.model import Settings

REFIT_TIMEOUT_S = 120.0
HELD_OUT_KEPT = 8  # held-out models kept in the state (the fit cache keeps more)

def held_out_key(
    store: StoreState, primitive: str, demo: str, settings: Settings, group: str | None = None
) -> HeldOutKey:
    return (store.learn_version, primitive, demo, repr(settings), group)


class Learner:
    """The background worker (see the module docstring).

    Parameters
    ----------
    fits : FitCache
        Where fits are kept and reused.
    """

    def __init__(self, fits: FitCache):
        self.fits = fits
        self._state = LearnerState()
        self._wake = threading.Condition()
        self._refit: tuple[int, int, Training, bool] | None = None  # (request, version, ...)
        self._scorings = Scorings()  # the takes' and pending demonstrations' scorings
        self._held_out: tuple[HeldOutKey, Training] | None = None  # asked for
        self._fitting: HeldOutKey | None = None  # the held-out model being fitted
        self._asked = (-1, 0)  # (learn_version, request) of the latest refit asked for
        self._closed = False
        self._running = False  # a job taken and not finished (its results not yet told)
        self._thread = threading.Thread(target=self._work, name="learner", daemon=True)
        self._thread.start()

    @property
    def state(self) -> LearnerState:
        """The latest state (lock-free: a reference to an immutable value)."""
        return self._state

    # ------------------------------------------------------------------ requests

    def follow(self, store: StoreState, reuse: bool = True) -> int:
        """``store`` changed: refit if what is learned from changed (or ``not reuse``: learn
        anew, never a reused model), score its unscored takes. Returns the refit request
        that answers ``store`` (see :meth:`wait`)."""
        with self._wake:
            version, request = self._asked
            if store.learn_version != version or not reuse:
                request += 1
                self._asked = (store.learn_version, request)
                model = self._state.model
                if model is not None and model.layout != store.layout:
                    self._publish(model=None, settings=None)  # another workspace's: nothing
                self._refit = (request, store.learn_version, self._training(store), reuse)
            self._scorings.ask(store, self._state.model, self._state.scores)
            held = {id(d) for items in store.demos.values() for d in items}
            if set(self._state.scores) - held:  # the scores of those no longer there go
                kept = {i: s for i, s in self._state.scores.items() if i in held}
                self._publish(scores=MappingProxyType(kept))
            self._wake.notify_all()
            return request

    def held_out(
        self, store: StoreState, primitive: str, demo: str, group: str | None = None
    ) -> Fitted | None:
        """The model learned from ``store``'s demonstrations without ``demo`` of
        ``primitive`` (with the settings the model of ``store`` chose), once learned; until
        then None, and it is asked for (the latest such request wins) once that model is
        learned (the worker refits first anyway: :attr:`LearnerState.settings` is then known).
        With ``group`` (a rule of :mod:`promp.evaluate.groups`: ``folder``, a level), without
        every demonstration of its group (:func:`app.core.groups.group_members`).

        Raises
        ------
        ValueError
            The demonstration is unknown, has no group under ``group``, or holding it (its
            group) out leaves a primitive with fewer than two demonstrations (see
            :func:`app.core.fits.held_out_training`).
        """
        members = None if group is None else group_members(store, primitive, demo, group)
        state = self._state
        if state.learn_version != store.learn_version or state.settings is None:
            return None  # the refit of this change comes first, and chooses the settings
        key = held_out_key(store, primitive, demo, state.settings, group)
        known = state.held_out.get(key)
        if known is not None:
            return known
        with self._wake:
            asked = self._held_out[0] if self._held_out is not None else self._fitting
            if asked != key:
                training = Training(
                    held_out_training(store.demos, primitive, demo, members), store.layout,
                    state.settings,
                )
                self._held_out = (key, training)
                self._wake.notify_all()
        return None

    def on_scored(self, callback: Callable[[Scored], None]) -> None:
        """Call ``callback(scored)`` with every typicality given, once published (from the
        worker, no lock held)."""
        self._scorings.on_scored(callback)

    def wait(self, request: int, timeout: float = REFIT_TIMEOUT_S) -> LearnerState:
        """The state once it answers refit ``request`` (or a later one).

        Raises
        ------
        TimeoutError
            If that takes longer than ``timeout`` seconds.
        """
        with self._wake:
            if not self._wake.wait_for(lambda: self._state.request >= request, timeout):
                raise TimeoutError(f"no model learned within {timeout:g} s")
            return self._state

    def close(self) -> None:
        """Stop the worker (a job under way finishes first)."""
        with self._wake:
            self._closed = True
            self._wake.notify_all()
        self._thread.join(timeout=REFIT_TIMEOUT_S)

    # ------------------------------------------------------------------ the worker

    def _training(self, store: StoreState) -> Training:
        """What a refit of ``store`` learns from: its primitives with at least two learned
        demonstrations, starting from the last model's choice of the automatic settings."""
        trainable = {n: list(d) for n, d in store.learned.items() if len(d) >= 2}
        model = self._state.model
        previous = None
        if model is not None and model.layout == store.layout:
            previous = model.report.get("settings")
        return Training(trainable, store.layout, store.learning_settings(), previous)

    def _work(self) -> None:
        scorings = self._scorings
        while True:
            with self._wake:
                self._wake.wait_for(lambda: self._closed or self._refit or scorings.takes
                                    or self._held_out or scorings.pending)  # fmt: skip
                if self._closed:
                    return
                if self._refit is not None:
                    run, job, self._refit = self._run_refit, self._refit, None
                elif scorings.takes:
                    run, job = self._run_scoring, (scorings.takes, scorings.takes.next())
                elif self._held_out is not None:
                    run, job, self._held_out = self._run_held_out, self._held_out, None
                    self._fitting = job[0]
                else:
                    run, job = self._run_scoring, (scorings.pending, scorings.pending.next())
                self._running = True
            try:
                run(*job)
            except Exception:  # a bug in one job must not end the worker
                traceback.print_exc()
            finally:
                with self._wake:
                    self._running = False

    @property
    def idle(self) -> bool:
        """Nothing asked for is left to do: no refit, scoring or held-out fit queued or
        running (what it writes, the scores in the workspace's index, is written)."""
        with self._wake:
            s = self._scorings
            return not (self._running or self._refit is not None or self._held_out is not None
                        or s.takes or s.pending)  # fmt: skip

    def _run_refit(self, request: int, version: int, training: Training, reuse: bool) -> None:
        fitted = self.fits.fit(training, reuse)
        with self._wake:
            if request != self._asked[1]:
                return  # superseded while it ran: the newer request's result will do
            self._publish(
                model=fitted.model, error=fitted.error, fit_ms=fitted.ms, reused=fitted.reused,
                learn_version=version, n_demos=training.n_demos, request=request,
                settings=resolved_settings(training.settings, training.layout, fitted.model),
            )  # fmt: skip

    def _run_scoring(self, queue, job) -> None:
        """Run a take's or a primitive's scoring (``job`` of ``queue``), with the latest model
        (the refit of a change comes first); publish, then tell the listeners."""
        scored = job.run(self._state.model)
        with self._wake:
            queue.done(job)
            scores = dict(self._state.scores)
            scores.update({id(demo): (demo, typicality) for _, demo, typicality in scored})
            self._publish(scores=MappingProxyType(scores))
        self._scorings.tell(scored)

    def _run_held_out(self, key: HeldOutKey, training: Training) -> None:
        fitted = self.fits.fit(training)
        with self._wake:
            self._fitting = None
            held_out = dict(self._state.held_out)
            held_out[key] = fitted
            while len(held_out) > HELD_OUT_KEPT:
                held_out.pop(next(iter(held_out)))
            self._publish(held_out=MappingProxyType(held_out))

    def _publish(self, **changes) -> None:
        """A new state (the lock held)."""
        self._state = replace(self._state, **changes)
        self._wake.notify_all()
