"""When the robot acts: a rule that commits to the recognised primitive.

The method publishes the probability of every primitive at each update of a movement (30 to
100 times a second live, every 2 % of the movement in the evaluation's ``--decide``). The
robot finishes the movement the partner intended, so at some update it must commit to one
primitive and start moving. :class:`CommitRule` commits once the recognised primitive's
probability has stayed at or above ``threshold`` for ``window`` seconds: the updates from the
first one of the run to the current one are all at or above it, for the same primitive, and
the current one is at least ``window`` seconds after the first. A drop below the threshold, or
another primitive taking the lead, starts the run again (a flicker never commits). An update
without a prediction (the method could not run) breaks the run too.

**The window is in seconds of the movement, not in updates.** The same rule runs on the
evaluation's observed steps and on a live stream of predictions that arrive at irregular
times: counted in updates, a window of 5 would wait 50 ms at 100 Hz, 170 ms at 30 Hz and, in
the evaluation, 10 % of the movement (2 s for a 20 s one). Counted on the movement's own clock
(the time of the latest observed sample, from the movement's start: what
:attr:`promp.pipeline.Inference.observed_until` and the live predictor's ``elapsed`` give), it
asks the same of the evidence however often it is looked at. On a discrete stream it commits at
the first update at least ``window`` seconds after the run began: it can wait up to one
update longer than the window, never less. ``window = 0`` commits at the first update at or
above the threshold.

Once committed, a state stays committed: the decision is returned once, by the update that
makes it, and kept in :attr:`DecisionState.decision`; a new movement starts from
:meth:`CommitRule.start`.

The form is pure: a :class:`DecisionState` is immutable, and ``update`` returns the next state
and the decision (or None)::

    rule = CommitRule(threshold=0.9, window=0.1)
    state = rule.start()
    for time, probabilities in predictions:  # seconds of the movement, shape (n_primitives,)
        state, decision = state.update(time, probabilities)
        if decision is not None:
            act(decision.primitive)

:func:`commit_steps` applies the rule at many thresholds to a whole sequence at once (the
evaluation's nested choice of the threshold, :mod:`promp.evaluate.decisions`): the same rule,
vectorised over thresholds (the tests compare the two).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

__all__ = [
    "check_probabilities", "CommitRule", "commit_steps", "Decision", "DecisionState",
    "TIME_TOLERANCE_S", "WINDOW_S",
]  # fmt: skip

WINDOW_S = 0.1  # s: 3 updates at 30 Hz, 10 at 100 Hz; short beside a movement of 0.5-4 s
TIME_TOLERANCE_S = 1e-9  # sample times summed in floating point: 5 x 0.02 s is 0.1 s


@dataclass(frozen=True)
class Decision:
    """A commitment to one primitive.

    Attributes
    ----------
    primitive : int
        Its index (into the model's primitives, the probabilities' order).
    probability : float
        Its probability at the update that committed.
    time : float
        That update's time, seconds of the movement.
    since : float
        When its run above the threshold began, seconds of the movement
        (``time - since >= window``).
    """

    primitive: int
    probability: float
    time: float
    since: float


@dataclass(frozen=True)
class CommitRule:
    """Commit once the leading primitive's probability has stayed at or above ``threshold``
    for ``window`` seconds of the movement (module docstring).

    Parameters
    ----------
    threshold : float
        In (0, 1]. A threshold at or below ``1 / n_primitives`` is met by every update (the
        leading probability is never lower): the rule then commits ``window`` seconds into
        the movement to whatever leads.
    window : float
        Seconds of the movement, at least 0.

    Raises
    ------
    ValueError
        A threshold outside (0, 1] or a window that is negative or not finite.
    """

    threshold: float
    window: float = WINDOW_S

    def __post_init__(self) -> None:
        threshold, window = float(self.threshold), float(self.window)
        if not 0.0 < threshold <= 1.0:
            raise ValueError(f"the threshold is a probability in (0, 1], got {self.threshold!r}")
        if not math.isfinite(window) or window < 0.0:
            raise ValueError(f"the window is seconds of the movement, at least 0, got "
                             f"{self.window!r}")  # fmt: skip
        object.__setattr__(self, "threshold", threshold)
        object.__setattr__(self, "window", window)

    def start(self) -> DecisionState:
        """The state before a movement's first update."""
        return DecisionState(self)


@dataclass(frozen=True)
class DecisionState:
    """Where :class:`CommitRule` stands in one movement (immutable; :meth:`update` returns the
    next one).

    Attributes
    ----------
    rule : CommitRule
    leading : int
        The primitive whose run at or above the threshold is under way (-1: none).
    since : float
        When that run began, seconds of the movement (NaN: none).
    time : float
        The latest update's time (-inf before the first).
    n_primitives : int
        How many probabilities each update gives (0 before the first).
    decision : Decision or None
        The commitment, once made.
    """

    rule: CommitRule
    leading: int = -1
    since: float = math.nan
    time: float = -math.inf
    n_primitives: int = 0
    decision: Decision | None = None

    @property
    def committed(self) -> bool:
        return self.decision is not None

    def update(
        self, time: float, probabilities: np.ndarray | None
    ) -> tuple[DecisionState, Decision | None]:
        """The state after the prediction of ``time`` and the decision it makes, if any.

        Parameters
        ----------
        time : float
            Seconds of the movement at this update (its latest observed sample, from the
            movement's start); never earlier than the previous update's.
        probabilities : array, shape (n_primitives,), or None
            The primitives' probabilities at this update; None when the method gave none (it
            breaks the run).

        Returns
        -------
        state : DecisionState
        decision : Decision or None
            The commitment made by this update; None before it and after it.

        Raises
        ------
        ValueError
            A time that is not finite or earlier than the previous update's; probabilities that
            are not a 1-D array of finite values in [0, 1], or not as many as before.
        """
        time = float(time)
        if not math.isfinite(time):
            raise ValueError(f"an update's time must be finite seconds, got {time!r}")
        if time < self.time:
            raise ValueError(f"updates come in time order: {time:g} s after {self.time:g} s")
        n_primitives = self.n_primitives
        if probabilities is not None:
            p = check_probabilities(probabilities, self.n_primitives)
            n_primitives = p.shape[0]
        if self.decision is not None:
            return replace(self, time=time, n_primitives=n_primitives), None
        if probabilities is None:
            return replace(self, leading=-1, since=math.nan, time=time), None
        leading = int(np.argmax(p))
        if p[leading] < self.rule.threshold:
            return replace(self, leading=-1, since=math.nan, time=time,
                           n_primitives=n_primitives), None  # fmt: skip
        since = self.since if leading == self.leading else time
        state = replace(self, leading=leading, since=since, time=time, n_primitives=n_primitives)
        if time - since < self.rule.window - TIME_TOLERANCE_S:
            return state, None
        decision = Decision(leading, float(p[leading]), time, since)
        return replace(state, decision=decision), decision


def check_probabilities(probabilities: np.ndarray, n_primitives: int = 0) -> np.ndarray:
    """``probabilities`` as a float array, checked: 1-D, not empty, finite, in [0, 1] (and
    ``n_primitives`` of them when that is not 0).

    Raises
    ------
    ValueError
        Otherwise.
    """
    p = np.asarray(probabilities, dtype=float)
    if p.ndim != 1 or p.shape[0] == 0:
        raise ValueError(f"an update gives one probability per primitive, a 1-D array; got "
                         f"shape {p.shape}")  # fmt: skip
    if not np.all(np.isfinite(p)) or np.any(p < 0.0) or np.any(p > 1.0 + 1e-9):
        raise ValueError(f"probabilities must be finite and in [0, 1], got {p}")
    if n_primitives and p.shape[0] != n_primitives:
        raise ValueError(f"{p.shape[0]} probabilities after updates of {n_primitives}")
    return p


def commit_steps(
    times: np.ndarray, probabilities: np.ndarray, thresholds: np.ndarray, window: float
) -> tuple[np.ndarray, np.ndarray]:
    """Where :class:`CommitRule` commits on one movement's updates, at every threshold.

    Parameters
    ----------
    times : array, shape (n_updates,)
        Seconds of the movement, non-decreasing.
    probabilities : array, shape (n_updates, n_primitives)
        A row of NaN: no prediction at that update.
    thresholds : array, shape (n_thresholds,)
        Each in (0, 1].
    window : float
        Seconds, at least 0.

    Returns
    -------
    steps : int array, shape (n_thresholds,)
        The index of the update that commits (-1: none does).
    primitives : int array, shape (n_thresholds,)
        The primitive committed to (-1: none).

    Raises
    ------
    ValueError
        Times that decrease, or arrays of the wrong shapes.
    """
    times = np.asarray(times, dtype=float)
    p = np.asarray(probabilities, dtype=float)
    thresholds = np.asarray(thresholds, dtype=float)
    window = CommitRule(1.0, window).window  # checked as the rule checks it
    if np.any(~((thresholds > 0.0) & (thresholds <= 1.0))):
        raise ValueError(f"thresholds are probabilities in (0, 1], got {thresholds}")
    if p.ndim != 2 or times.shape != (p.shape[0],) or thresholds.ndim != 1:
        raise ValueError(f"times (n,), probabilities (n, n_primitives) and thresholds (m,) "
                         f"expected; got {times.shape}, {p.shape}, {thresholds.shape}")  # fmt: skip
    if np.any(np.diff(times) < 0) or not np.all(np.isfinite(times)):
        raise ValueError("the updates' times must be finite and in time order")
    given = np.all(np.isfinite(p), axis=1)
    leading = np.where(given, np.argmax(np.where(given[:, None], p, 0.0), axis=1), -1)
    top = np.where(given, np.max(np.where(given[:, None], p, -1.0), axis=1), -1.0)
    steps = np.full(thresholds.shape, -1)
    primitives = np.full(thresholds.shape, -1)
    since = np.full(thresholds.shape, np.nan)
    for i in range(times.shape[0]):
        above = (top[i] >= thresholds) & (steps < 0)
        same = i > 0 and leading[i] == leading[i - 1]
        running = above & np.isfinite(since) & same
        since = np.where(running, since, np.where(above, times[i], np.nan))
        done = above & (times[i] - since >= window - TIME_TOLERANCE_S)
        steps[done], primitives[done] = i, leading[i]
    return steps, primitives
