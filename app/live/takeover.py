"""The robot takes over: when a live movement commits, the simulated iCub finishes it.

A pure controller (no viser, no clock): fed the live source's latest prediction at every frame,
:meth:`TakeOver.decide` says when the arm starts to follow a predicted remainder. It starts
once per movement, on the first prediction it sees that carries the movement's commitment
(:attr:`promp.live.predictor.LivePrediction.committed`; the studio's loop may skip the very
prediction that committed, so the first one it sees after is taken); later predictions of the
same movement start nothing. A movement is known by the session's number and its own
(:attr:`app.panels.infer.lsl_view.LslObserved.movement`), so a new session's movement 1 may
start again. Where the model has no robot hand (the layout's ``hand``, the hand the arm
follows) or the session runs no commit rule, it never starts, and :func:`unavailable` says why.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from promp.live.commitment import Commitment
from promp.live.predictor import LivePrediction
from robots.icub.layout import HAND

__all__ = ["NO_HAND", "NO_RULE", "TakeOver", "TakeOverStart", "unavailable"]

NO_HAND = (f"the model has no '{HAND.name}' modality (the robot's hand): there is no predicted "
           "path for the arm to follow")  # fmt: skip
NO_RULE = "the session runs no commit rule: tick Commit to a primitive, then Start"


def unavailable(modalities: tuple[str, ...] | list[str], commits: bool = True) -> str:
    """Why the robot cannot take over ('' when it can).

    Parameters
    ----------
    modalities : sequence of str
        The model's modalities (its layout's names).
    commits : bool
        Whether the session runs the commit rule.
    """
    if HAND.name not in modalities:
        return NO_HAND
    return "" if commits else NO_RULE


@dataclass(frozen=True)
class TakeOverStart:
    """The arm starts to follow ``prediction``'s remainder of the robot's hand.

    Attributes
    ----------
    movement : tuple
        The movement taken over (the session's number, the movement's).
    prediction : LivePrediction
        The prediction whose remainder the arm follows (the first seen carrying the
        commitment).
    """

    movement: tuple
    prediction: LivePrediction

    @property
    def commitment(self) -> Commitment:
        return self.prediction.committed

    @property
    def text(self) -> str:
        """``the robot takes over (committed to 'top' at 0.42 s, 35 % observed)``."""
        c = self.commitment
        return (f"the robot takes over (committed to {c.primitive!r} at {c.time:.2f} s, "
                f"{100.0 * c.phase:.0f} % observed, p {c.probability:.2f})")  # fmt: skip


@dataclass(frozen=True)
class TakeOver:
    """Which movement the robot took over last (immutable; see the module docstring).

    Attributes
    ----------
    started : TakeOverStart or None
        The latest take-over.
    """

    started: TakeOverStart | None = None

    def decide(self, prediction: LivePrediction | None, movement: tuple, enabled: bool,
               reason: str = "") -> tuple[TakeOver, TakeOverStart | None]:  # fmt: skip
        """The state after seeing ``prediction`` and the take-over it starts, if any.

        Parameters
        ----------
        prediction : LivePrediction or None
            The live source's latest.
        movement : tuple
            Which movement it is of (the session's number, the movement's).
        enabled : bool
            The user's choice (*Robot takes over*).
        reason : str
            Why the robot cannot take over (:func:`unavailable`; '' when it can).
        """
        if (not enabled or reason or prediction is None or prediction.committed is None
                or prediction.committed.movement != prediction.movement):  # fmt: skip
            return self, None
        if self.started is not None and self.started.movement == movement:
            return self, None  # once per movement: a later prediction does not restart it
        start = TakeOverStart(tuple(movement), prediction)
        return dataclasses.replace(self, started=start), start
