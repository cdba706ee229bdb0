"""One inference as the studio draws it: a :class:`promp.evidence.Inference` with what only
the studio draws added (no viser, no method work of its own).

The method's work is one :class:`promp.evidence.Evidence` of the early observation (the first
samples of a held-out test demonstration, or of the live stream): it recognises the primitive
and its speed (Eq. 6), conditions the recognised primitive on the observation and on that
primitive's via-points (Eq. 8), predicts the prior and the posterior over the predicted
duration, gives every position's region and future path, and, given the whole movement,
measures the errors the evaluation reports (:meth:`promp.evidence.Evidence.infer`).
:func:`inferred` asks it and :func:`completed` adds what only the studio draws: the observed
and true parts of each position (:func:`app.live.regions.positions`) and the hand's future,
which the 3D view shows and the arm replays. The Infer tab's view model, which chooses the
model and the observation, is :mod:`app.panels.infer.view_model`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from app.core.via_state import StudioViaPoint, of_primitive
from app.live.regions import PATH_POINTS, TUBE_POINTS, PositionView, positions
from promp.data import Demonstration
from promp.evidence import Evidence, Inference
from promp.evidence.pipeline import relative_speed
from promp.inference import Gaussian, Observation, Posterior, Prediction
from promp.model import ProMPModel
from promp.timing import n_observed_for
from robots.icub.layout import HAND, hand_dims

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

    Attributes
    ----------
    model : ProMPModel
        The model inferred with (its primitives' names, its layout).
    observation : Observation
    inference : Inference
        The method's answer: recognition, timing (duration and observed share with their
        intervals), prior and posterior on ``TUBE_POINTS`` phases, and, with a truth, the
        natural-length prediction and the errors.
    truth : Demonstration or None
        The whole test demonstration (None for the live stream).
    future : FuturePath or None
        The hand's predicted path (None when the layout has no hand).
    via_points : tuple of StudioViaPoint
        The recognised primitive's via-points the prediction passes through (none: the
        method's posterior as it is).
    weights : Gaussian or Posterior
        The posterior, conditioned on ``via_points``.
    prediction : Prediction
        Every dimension over the predicted duration on ``TUBE_POINTS`` phases, from
        ``weights`` (the method's ``inference.prediction`` without via-points).
    positions : tuple of PositionView
        Every position in space of the layout (the hand first): its region, predicted and
        observed paths.
    """

    model: ProMPModel
    observation: Observation
    inference: Inference
    truth: Demonstration | None
    future: FuturePath | None
    via_points: tuple[StudioViaPoint, ...] = ()
    weights: Gaussian | Posterior | None = None
    prediction: Prediction | None = None
    positions: tuple[PositionView, ...] = ()

    @property
    def relative_speed(self) -> float:
        """The prediction's speed over the primitive's typical one (1: its usual speed)."""
        return relative_speed(self.model, self.inference)


def inferred(
    model: ProMPModel,
    observation: Observation,
    alpha_method: str,
    truth: Demonstration | None = None,
    via_points: tuple[StudioViaPoint, ...] = (),
) -> InferResult:
    """Infer from ``observation`` (:meth:`promp.evidence.Evidence.infer`, predictions on
    ``TUBE_POINTS`` phases), the posterior shaped by the recognised primitive's via-points (of
    ``via_points``, every primitive's), with what the 3D view draws (:func:`completed`).

    Parameters
    ----------
    model : ProMPModel
    observation : Observation
        Its times start at the start of the movement.
    alpha_method : {"ml", "model"}
    truth : Demonstration, optional
        The whole movement the observation was taken from (the errors are measured on it).

    Raises
    ------
    ValueError
        From the engine: an unknown modality, an unknown alpha method, or an observation longer
        than every candidate duration.
    """
    evidence = Evidence(model, observation, alpha_method)
    has_hand = hand_dims(model.layout) is not None
    vias = of_primitive(via_points, evidence.recognition.primitive) if has_hand else ()
    inference = evidence.infer([v.for_model(model.layout) for v in vias], n_points=TUBE_POINTS,
                               truth=truth, path_points=PATH_POINTS)  # fmt: skip
    return completed(model, observation, inference, truth, vias)


def completed(
    model: ProMPModel,
    observation: Observation,
    inference: Inference,
    truth: Demonstration | None = None,
    via_points: tuple[StudioViaPoint, ...] = (),
) -> InferResult:
    """What only the studio draws, added to ``inference`` of ``observation`` (on
    ``TUBE_POINTS`` phases, shaped by ``via_points``): every position's observed and true
    parts, and the future hand path; :func:`inferred`'s, and a live session's
    (:mod:`app.panels.infer.lsl_view`)."""
    whole = model.layout.extract(truth) if truth is not None else None
    views = positions(model, inference, observation, whole)
    hand = next((v for v in views if v.modality == HAND.name), None)
    future = FuturePath(hand.times, hand.future) if hand is not None else None
    return InferResult(
        model, observation, inference, truth, future, via_points, inference.weights,
        inference.prediction, views,
    )  # fmt: skip


def demo_observation(
    model: ProMPModel, demo: Demonstration, percent: float, modalities: Sequence[str]
) -> Observation:
    """The first ``ceil(percent / 100 * n)`` samples of ``demo`` in ``modalities``."""
    return Observation.from_demo(
        model, demo, n_observed_for(percent, demo.n_samples), tuple(modalities)
    )
