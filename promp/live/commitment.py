"""The moment the robot acts, live: :class:`promp.decision.CommitRule` on a session's
predictions, one movement at a time.

With ``--decide`` (:attr:`promp.live.options.LiveOptions.decide`) the pipeline carries a
:class:`Committing`: the rule's state for the movement of the latest prediction (a new
movement starts from :meth:`promp.decision.CommitRule.start`), updated with each prediction at
its time on the movement's clock (:attr:`promp.live.predictor.LivePrediction.elapsed`, the
latest observed sample from the movement's start) and its probabilities. The prediction that
commits makes one :class:`Commitment`, said once as an event (``kind`` ``"decision"``) and
carried by every later prediction of that movement (the timing outlet's ``committed``
channel). A prediction that failed breaks the rule's run, as the rule says. A movement's
last prediction on rows cut back by a still end (:mod:`promp.live.pipeline`) is earlier on its
clock than the one before: the rule, which goes forward in time, does not take it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from promp.decision import CommitRule, DecisionState
from promp.live.status import LiveEvent

__all__ = ["Commitment", "Committing", "DECISION"]

DECISION = "decision"  # the kind of a commitment's event


@dataclass(frozen=True)
class Commitment:
    """A movement's commitment to one primitive.

    Attributes
    ----------
    movement : int
        The movement's number.
    index : int
        The primitive's index (the probabilities' order, the model's primitives).
    primitive : str
        Its name.
    time : float
        Seconds of the movement at the prediction that committed (its ``elapsed``).
    phase : float
        The share of the movement observed then (the prediction's phase), in [0, 1].
    probability : float
        The primitive's probability then.
    at : float
        That prediction's latest observed sample, seconds on the session's clock.
    """

    movement: int
    index: int
    primitive: str
    time: float
    phase: float
    probability: float
    at: float

    @property
    def text(self) -> str:
        """``movement 2 committed to 'reach' at 0.420 s (35 % observed, p 0.93)``."""
        return (f"movement {self.movement} committed to {self.primitive!r} at {self.time:.3f} s "
                f"({100.0 * self.phase:.0f} % observed, p {self.probability:.2f})")  # fmt: skip

    def event(self) -> LiveEvent:
        return LiveEvent(self.at, self.text, DECISION)


@dataclass(frozen=True)
class Committing:
    """The rule's state in the movement under way (immutable; see the module docstring).

    Attributes
    ----------
    rule : CommitRule
    names : tuple of str
        The model's primitives (the probabilities' order).
    movement : int
        The movement ``state`` belongs to (0: none yet).
    state : DecisionState or None
    commitment : Commitment or None
        That movement's, once made.
    """

    rule: CommitRule
    names: tuple[str, ...]
    movement: int = 0
    state: DecisionState | None = None
    commitment: Commitment | None = None

    def _of(self, movement: int) -> Committing:
        if movement == self.movement and self.state is not None:
            return self
        return Committing(self.rule, self.names, movement, self.rule.start())

    def update(self, movement: int, time: float, probabilities: np.ndarray, phase: float,
               at: float) -> tuple[Committing, Commitment | None]:  # fmt: skip
        """The state after a prediction and the commitment it makes, if any.

        Parameters
        ----------
        movement : int
            The prediction's movement.
        time : float
            Its seconds of the movement (``LivePrediction.elapsed``).
        probabilities : array, shape (n_primitives,)
        phase : float
            The share of the movement observed (its phase's point estimate).
        at : float
            Its latest observed sample, seconds on the session's clock.
        """
        now = self._of(movement)
        if time < now.state.time:  # a still end's rows, cut back: not the rule's to take
            return now, None
        state, decision = now.state.update(time, probabilities)
        if decision is None:
            return dataclasses.replace(now, state=state), None
        made = Commitment(movement, decision.primitive, self.names[decision.primitive],
                          decision.time, float(phase), decision.probability, float(at))
        return dataclasses.replace(now, state=state, commitment=made), made

    def missed(self, movement: int, time: float) -> Committing:
        """The state after a prediction of ``movement`` that failed at ``time`` (seconds of
        the movement): the rule's run starts again."""
        now = self._of(movement)
        if time < now.state.time:
            return now
        return dataclasses.replace(now, state=now.state.update(time, None)[0])
