"""One inference as the studio draws it: a :class:`promp.evidence.Inference` with what only
the studio draws added (no viser, no method work of its own).

The method's work is one :class:`promp.evidence.Evidence` of the early observation (the first
samples of a held-out test demonstration, or of the live stream): it recognises the primitive
and its speed (Eq. 6), conditions the recognised primitive on the observation and on that
primitive's via-points (Eq. 8), predicts the prior and the posterior over the predicted
duration, gives every position's region and future path, and, given the whole movement,
measures the errors the evaluation reports (:meth:`promp.evidence.Evidence.infer`).
:func:`inferred` asks it; its :class:`InferResult` derives what only the studio draws: the
observed and true parts of each position (:func:`app.live.regions.positions`) and the hand's
future, which the 3D view shows and the arm replays. The Infer tab's view model, which chooses the
model and the observation, is :mod:`app.panels.infer.view_model`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from app.core.via_state import NO_VIA_POINTS, LayoutViaPoints, StudioViaPoint
from app.live.regions import PATH_POINTS, TUBE_POINTS, PositionView, positions
from promp.data import Demonstration
from promp.evidence import Evidence, Inference
from promp.evidence.pipeline import relative_speed
from promp.inference import Gaussian, Observation, Posterior, Prediction, predict
from promp.metrics import Errors, measure
from promp.model import ProMPModel
from robots.icub.layout import HAND

# What is observed, as Infer's Source names it: a held-out demonstration; the studio's own
# iCub hand (dragged) and partner's head (Teach's head source), sampled at every frame
# (app.live.stream); a lab's sensors streamed over LSL (app.live.lsl_source).
TEST, LIVE, LSL = "Test demonstration", "Studio's hand + head (live)", "LSL streams (live)"
__all__ = ["PATH_POINTS", "TUBE_POINTS"]  # where the scene finds them (app.live.regions')


@dataclass(frozen=True, eq=False)
class FuturePath:
    """The posterior mean hand from the observation point to the predicted end.

    Attributes
    ----------
    times : array, shape (PATH_POINTS,)
        Seconds from the start of the movement, from the last observed sample to the end.
    hand : array, shape (PATH_POINTS, 3)
        Hand positions, metres.
    """

    times: np.ndarray
    hand: np.ndarray


@dataclass(frozen=True, eq=False)
class InferResult:
    """Everything the Infer tab shows of one observation.

    The method's answer as it is, with what only the studio draws derived from it once, when
    first read: every position's observed and true parts, and the hand's future path.

    Attributes
    ----------
    model : ProMPModel
        The model inferred with (its primitives' names, its layout).
    observation : Observation
    inference : Inference
        The method's answer: recognition, timing (duration and observed share with their
        intervals), prior and posterior on ``TUBE_POINTS`` phases (shaped by the recognised
        primitive's via-points), every position's region and future path, and, with a truth,
        the natural-length prediction and the errors.
    truth : Demonstration or None
        The whole test demonstration (None for the live stream).
    via_points : tuple of StudioViaPoint
        The recognised primitive's via-points the prediction passes through (none: the
        method's posterior as it is).

    ``errors`` are those of the prediction shown: through ``via_points`` when there are some.
    """

    model: ProMPModel
    observation: Observation
    inference: Inference
    truth: Demonstration | None = None
    via_points: tuple[StudioViaPoint, ...] = ()

    @property
    def weights(self) -> Gaussian | Posterior:
        """The posterior, conditioned on ``via_points``."""
        return self.inference.weights

    @property
    def prediction(self) -> Prediction:
        """Every dimension over the predicted duration on ``TUBE_POINTS`` phases, from
        ``weights``."""
        return self.inference.prediction

    @cached_property
    def positions(self) -> tuple[PositionView, ...]:
        """Every position in space of the layout (the hand first): its region, predicted and
        observed paths, and the truth's rest (:func:`app.live.regions.positions`)."""
        truth = self.truth
        whole = self.model.layout.extract(truth) if truth is not None else None
        return positions(self.model, self.inference, self.observation, whole)

    @cached_property
    def future(self) -> FuturePath | None:
        """The hand's predicted path (None when the layout has no hand)."""
        hand = next((v for v in self.positions if v.modality == HAND.name), None)
        return FuturePath(hand.times, hand.future) if hand is not None else None

    @cached_property
    def errors(self) -> Errors | None:
        """Against ``truth`` (None without one): of the prediction shown, measured as the
        method's are, on its natural samples; through ``via_points`` when there are some (the
        method's ``inference.errors`` otherwise)."""
        inference, truth = self.inference, self.truth
        if not self.via_points or truth is None:
            return inference.errors
        natural = predict(self.model, inference.weights, inference.alpha)
        return measure(self.model, natural, inference.timing, truth,
                       self.observation.n_observed)  # fmt: skip

    @property
    def relative_speed(self) -> float:
        """The prediction's speed over the primitive's typical one (1: its usual speed)."""
        return relative_speed(self.model, self.inference)


def inferred(
    model: ProMPModel,
    observation: Observation,
    alpha_method: str,
    truth: Demonstration | None = None,
    via_points: LayoutViaPoints = NO_VIA_POINTS,
) -> InferResult:
    """Infer from ``observation`` (:meth:`promp.evidence.Evidence.infer`, predictions on
    ``TUBE_POINTS`` phases), the posterior shaped by the recognised primitive's via-points (of
    ``via_points``, on the model's layout: :attr:`app.core.snapshot.Snapshot.via_points`).

    Parameters
    ----------
    model : ProMPModel
    observation : Observation
        Its times start at the start of the movement.
    alpha_method : {"ml", "model"}
    truth : Demonstration, optional
        The whole movement the observation was taken from (the errors are measured on it).
    via_points : LayoutViaPoints, optional

    Raises
    ------
    ValueError
        From the engine: an unknown modality, an unknown alpha method, or an observation longer
        than every candidate duration.
    """
    inference = Evidence(model, observation, alpha_method).infer(
        via_points.method, n_points=TUBE_POINTS, truth=truth, path_points=PATH_POINTS
    )
    shaping = via_points.studio.get(inference.recognition.primitive, ())
    return InferResult(model, observation, inference, truth, shaping)
