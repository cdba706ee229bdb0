"""What the tubes show, as the studio draws them (no viser, and no method of its own): a
primitive's prior in Teach and the inference's posterior in Infer, each shaped by its
primitive's via-points, and the region of every position in space
(:func:`robots.icub.layout.position_modalities`) they give.

Teach (:func:`prior_shape`): the studio's via-points of the primitive put on the layout's hand,
and the method's :func:`promp.region.shaped_prior` (a new movement whatever its speed,
conditioned on them, at its typical speed); its regions are
:func:`promp.region.modality_region`. Infer (:func:`positions`): each position's region and
future path of the inference (:attr:`promp.evidence.Inference.positions`), with what was
observed of it and the truth. A region is where a share of the movements' samples are at each
moment (:mod:`promp.region`: the weights through the basis, plus the samples' noise); the tubes
draw it at the probability of the tube style. Teach's is
calibrated: its radius times the primitive's factor (:func:`promp.region.region_scale`, chosen
by the fit so that it holds its stated share of held-out demonstrations); Infer's posterior
keeps the Gaussian's (the factor is learned of a new movement, not of one observed in part).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from app.core.via_state import StudioViaPoint, of_primitive
from promp.evidence import Inference
from promp.evidence.inference import PATH_POINTS  # noqa: F401 (a path's samples: the method's)
from promp.inference import Gaussian, Observation, Posterior, Prediction, predict
from promp.model import ProMPModel
from promp.region import (
    Coverage,
    SampleDistribution,
    coverage,
    modality_region,
    region_scale,
    shaped_prior,
)
from robots.icub.layout import HAND, position_modalities

TUBE_POINTS = 100  # rings of a tube (fixed mesh topology)


@dataclass(frozen=True, eq=False)
class PriorShape:
    """A primitive as Teach draws it.

    Attributes
    ----------
    name : str
    alpha : float
        Its typical speed (exp of its training demonstrations' mean log alpha).
    weights : Gaussian
        A new movement's weights, conditioned on ``via_points``.
    via_points : tuple of StudioViaPoint
    """

    name: str
    alpha: float
    weights: Gaussian | Posterior
    via_points: tuple[StudioViaPoint, ...]

    def prediction(self, model: ProMPModel, n_points: int) -> Prediction:
        """Every dimension's mean and standard deviation (the movement, without noise)."""
        return predict(model, self.weights, self.alpha, n_points)

    def region(
        self, model: ProMPModel, modality: str, n_points: int = TUBE_POINTS
    ) -> SampleDistribution:
        """Where ``modality``'s samples lie (:func:`promp.region.modality_region`),
        calibrated: its radius times the primitive's factor (:func:`promp.region.region_scale`)."""
        primitive = model.primitive(self.name)
        scale = region_scale(primitive, modality)
        return modality_region(model, self.weights, modality, n_points, scale=scale)


def prior_shape(
    model: ProMPModel, name: str, via_points: Sequence[StudioViaPoint] = ()
) -> PriorShape:
    """Primitive ``name`` with its via-points (those of ``via_points`` that are its)."""
    mine = of_primitive(via_points, name)
    points = [v.for_model(model.layout) for v in mine] if mine else []
    alpha, weights = shaped_prior(model, name, points)
    return PriorShape(name, alpha, weights, mine)


# ---------------------------------------------------------------------- Infer


@dataclass(frozen=True, eq=False)
class PositionView:
    """One position modality of an inference, as the 3D view draws it.

    Attributes
    ----------
    modality : str
    region : SampleDistribution
        On :data:`TUBE_POINTS` phases over the predicted duration: means (n, 3), covariances
        (n, 3, 3), metres.
    times : array, shape (PATH_POINTS,)
        Seconds from the start of the movement, from the last observed sample to the end.
    future : array, shape (PATH_POINTS, 3)
        The predicted mean at ``times``.
    observed : array, shape (n_observed, 3), or None
        What was observed of it (None: not observed).
    truth : array, shape (m, 3), or None
        The rest of the whole movement, from the last observed sample (a test demonstration).
    """

    modality: str
    region: SampleDistribution
    times: np.ndarray
    future: np.ndarray
    observed: np.ndarray | None
    truth: np.ndarray | None


def positions(
    model: ProMPModel,
    inference: Inference,
    observation: Observation,
    truth: np.ndarray | None = None,
) -> tuple[PositionView, ...]:
    """Every position modality of ``inference`` (the hand first,
    :func:`robots.icub.layout.position_modalities`) with what was observed of it.

    Parameters
    ----------
    truth : array, shape (n_samples, n_dims), optional
        The whole test demonstration's values (``model.layout.extract``).
    """
    layout = model.layout
    found = {p.modality: p for p in inference.positions}
    views = []
    for modality in position_modalities(layout):
        dims, position = layout.dims([modality.name]), found[modality.name]
        observed = None
        if modality.name in observation.modalities:
            cols = np.flatnonzero(np.isin(layout.dims(observation.modalities), dims))
            observed = observation.values[:, cols]
        rest = None
        if truth is not None:
            rest = truth[max(observation.n_observed - 1, 0) :, dims]
        views.append(PositionView(modality.name, position.region, position.times,
                                  position.future, observed, rest))  # fmt: skip
    return tuple(views)


def measured_shares(
    model: ProMPModel, learned: dict, probability: float
) -> dict[str, Coverage]:
    """Each primitive's share of its demonstrations' hand samples inside its region of
    ``probability`` (:func:`promp.region.coverage`), for the primitives ``model`` and
    ``learned`` ({primitive: demonstrations learned from}) both have."""
    return {
        name: coverage(model, name, learned[name], HAND.name, probability)
        for name in model.names
        if learned.get(name)
    }
