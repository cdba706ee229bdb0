"""Learning in the background: the workspace's model, the takes' typicality, held-out models.

One :class:`Learner` per studio, with one worker thread, so that nothing slow runs on the
studio's loop. It follows the store (:meth:`Learner.follow`, a listener of
:class:`app.core.store.Store`): a change of what is learned from asks for a refit, a new take
asks for its typicality. The scores are the learner's (:attr:`LearnerState.scores`, by the
demonstration scored): nothing goes back into the store. The worker takes the most urgent job
first: the refit of the latest
change (a newer request supersedes one in flight, whose result is then dropped), then the
takes' scores, then the held-out model the Infer tab inspects. Each outcome is published as a
new :class:`LearnerState` (readers take :attr:`Learner.state`, lock-free), stamped with the
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
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType

from app.core.fits import FitCache, Fitted, Training, held_out_training
from app.core.store_state import StoreState
from promp.data import Demonstration
from promp.model import ProMPModel, Settings
from promp.typicality import Typicality, typicality

REFIT_TIMEOUT_S = 120.0
HELD_OUT_KEPT = 8  # held-out models kept in the state (the fit cache keeps more)

HeldOutKey = tuple  # (learn_version, primitive, demo, repr(settings))
# A take's score, by the id of the demonstration scored (held: its id stays its own): the
# demonstration and its typicality (None: too few others to score it).
Scores = Mapping[int, tuple[Demonstration, Typicality | None]]


@dataclass(frozen=True, eq=False)
class LearnerState:
    """What the learner has published (see the module docstring).

    Attributes
    ----------
    model : ProMPModel or None
        The latest model (None when nothing can be learned: ``error`` says why).
    error : str or None
    fit_ms : float
        The time its fit took (a reused model: the time of the fit it reuses).
    reused : bool
        It came from a recent fit of the same training.
    learn_version : int
        The store's ``learn_version`` the model was learned from (-1: none yet).
    n_demos : int
        The demonstrations it was learned from.
    request : int
        The refit request it answers (:meth:`Learner.refit` waits for its own).
    held_out : mapping of HeldOutKey to Fitted
        Models learned without one demonstration, by :func:`held_out_key`.
    scores : mapping of int to (Demonstration, Typicality or None)
        The takes' typicality, by the id of the demonstration scored (a take of the same
        name recorded again is another demonstration, scored anew).
    """

    model: ProMPModel | None = None
    error: str | None = None
    fit_ms: float = 0.0
    reused: bool = False
    learn_version: int = -1
    n_demos: int = 0
    request: int = 0
    held_out: Mapping[HeldOutKey, Fitted] = field(default_factory=dict)
    scores: Scores = field(default_factory=dict)


def resolved_settings(store: StoreState, model: ProMPModel | None) -> Settings:
    """The store's settings with every automatic one at the value ``model`` chose (its
    fallback value without a model of this layout): what a fit of some demonstrations uses,
    e.g. for typicality or a held-out model, without choosing again."""
    settings = store.learning_settings()
    if model is None or model.layout != store.layout or not settings.automatic:
        return settings.with_fallback()
    return replace(settings, **{name: getattr(model.settings, name) for name in settings.automatic})


def held_out_key(store: StoreState, primitive: str, demo: str, settings: Settings) -> HeldOutKey:
    return (store.learn_version, primitive, demo, repr(settings))


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
        self._scores: deque[tuple[str, Demonstration, Callable[[], Typicality | None]]] = deque()
        self._held_out: tuple[HeldOutKey, Training] | None = None  # asked for
        self._fitting: HeldOutKey | None = None  # the held-out model being fitted
        self._asked = (-1, 0)  # (learn_version, request) of the latest refit asked for
        self._queued: set[int] = set()  # ids of the takes whose score is asked for
        self._closed = False
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
                    self._publish(model=None)  # another workspace's model: nothing meanwhile
                self._refit = (request, store.learn_version, self._training(store), reuse)
            takes = {}
            for key in sorted(store.takes):
                if (found := self._scoring(store, *key)) is None:
                    continue  # gone from the workspace (a state that kept its key)
                demo, scoring = found
                takes[id(demo)] = demo
                if id(demo) not in self._queued and id(demo) not in self._state.scores:
                    self._queued.add(id(demo))  # the same name may come back anew: by id
                    self._scores.append((key[0], demo, scoring))
            if set(self._state.scores) - set(takes):  # the scores of takes no longer there go
                kept = {i: s for i, s in self._state.scores.items() if i in takes}
                self._publish(scores=MappingProxyType(kept))
            self._wake.notify_all()
            return request

    def held_out(self, store: StoreState, primitive: str, demo: str) -> Fitted | None:
        """The model learned from ``store``'s demonstrations without ``demo`` of
        ``primitive`` (with the settings the current model chose), once learned; until then
        None, and it is asked for (the latest such request wins).

        Raises
        ------
        ValueError
            The demonstration is unknown, or holding it out leaves its primitive with fewer
            than two demonstrations (see :func:`app.core.fits.held_out_training`).
        """
        settings = resolved_settings(store, self._state.model)
        key = held_out_key(store, primitive, demo, settings)
        known = self._state.held_out.get(key)
        if known is not None:
            return known
        with self._wake:
            asked = self._held_out[0] if self._held_out is not None else self._fitting
            if asked != key:
                training = Training(
                    held_out_training(store.demos, primitive, demo), store.layout, settings
                )
                self._held_out = (key, training)
                self._wake.notify_all()
        return None

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

    def _scoring(self, store: StoreState, primitive: str, name: str):
        """(the take, its scoring), None if ``store`` no longer holds it: against its
        primitive's other demonstrations that learning uses, with the current model's choice
        of settings."""
        demo = next((d for d in store.demos.get(primitive, ()) if d.name == name), None)
        if demo is None:
            return None
        others = [d for d in store.learned.get(primitive, []) if d.name != name]
        settings = resolved_settings(store, self._state.model)
        return demo, lambda: typicality(demo, others, store.layout, settings)

    def _work(self) -> None:
        while True:
            with self._wake:
                self._wake.wait_for(
                    lambda: self._closed or self._refit or self._scores or self._held_out
                )
                if self._closed:
                    return
                if self._refit is not None:
                    run, job, self._refit = self._run_refit, self._refit, None
                elif self._scores:
                    run, job = self._run_score, self._scores.popleft()
                else:
                    run, job, self._held_out = self._run_held_out, self._held_out, None
                    self._fitting = job[0]
            try:
                run(*job)
            except Exception:  # a bug in one job must not end the worker
                traceback.print_exc()

    def _run_refit(self, request: int, version: int, training: Training, reuse: bool) -> None:
        fitted = self.fits.fit(training, reuse)
        with self._wake:
            if request != self._asked[1]:
                return  # superseded while it ran: the newer request's result will do
            self._publish(
                model=fitted.model, error=fitted.error, fit_ms=fitted.ms, reused=fitted.reused,
                learn_version=version, n_demos=training.n_demos, request=request,
            )  # fmt: skip

    def _run_score(self, primitive: str, demo: Demonstration, score) -> None:
        typicality = score()
        with self._wake:
            self._queued.discard(id(demo))
            scores = dict(self._state.scores)
            scores[id(demo)] = (demo, typicality)
            self._publish(scores=MappingProxyType(scores))

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
