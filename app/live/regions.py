"""What the tubes show, computed (no viser): a primitive's prior in Teach and the inference's
posterior in Infer, each shaped by its primitive's via-points, and the region of every position
in space (:func:`robots.icub.layout.position_modalities`) they give.

Teach (:func:`prior_shape`): the weights of a new movement of the primitive, whatever its speed
(:func:`promp.region.new_movement`), conditioned on its via-points
(:func:`promp.via_points.condition_on_via_points`), drawn at its typical speed. Infer
(:func:`shaped_posterior`): the posterior of the recognised primitive given the observation
(Eq. 8), conditioned on that primitive's via-points as well. A region is where a share of the
movements' samples are at each moment (:mod:`promp.region`: the weights through the basis, plus
the samples' noise); the tubes draw it at the probability of the tube style. Teach's is
calibrated: its radius times the primitive's factor (:func:`promp.region.region_scale`, chosen
by the fit so that it holds its stated share of held-out demonstrations); Infer's posterior
keeps the Gaussian's (the factor is learned of a new movement, not of one observed in part).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from app.core.via_state import StudioViaPoint, of_primitive
from promp.inference import Gaussian, Observation, Posterior, Prediction, predict
from promp.model import ProMPModel
from promp.region import (
    Coverage,
    SampleDistribution,
    coverage,
    new_movement,
    region_scale,
    sample_distribution,
    sample_noise_var,
)
from promp.via_points import condition_on_via_points
from robots.icub.layout import HAND, position_modalities

TUBE_POINTS = 100  # rings of a tube (fixed mesh topology)
PATH_POINTS = 60  # samples of a predicted path


def region_of(
    model: ProMPModel,
    weights: Gaussian | Posterior,
    modality: str,
    n_points: int = TUBE_POINTS,
    scale: float = 1.0,
) -> SampleDistribution:
    """The region of ``modality``'s samples on ``n_points`` phases over [0, 1], for the
    weights ``weights`` (with the samples' noise), its radius times ``scale``."""
    noise = sample_noise_var(model, model.primitives[0])  # shared by the primitives
    phases = np.linspace(0.0, 1.0, n_points)
    dims = model.layout.dims([modality])
    return sample_distribution(model, weights, dims, phases, noise, scale)


def shaped(
    model: ProMPModel,
    weights: Gaussian | Posterior,
    via_points: Sequence[StudioViaPoint],
    alpha: float,
) -> Gaussian | Posterior:
    """``weights`` conditioned on ``via_points`` (none: ``weights`` itself)."""
    if not via_points:
        return weights
    points = [v.for_model(model.layout) for v in via_points]
    return condition_on_via_points(model, weights, points, alpha)


def mean_position(
    model: ProMPModel, weights: Gaussian | Posterior, modality: str, phase: float
) -> np.ndarray:
    """The mean of ``modality`` at ``phase`` (in [0, 1]) under ``weights``, shape (k,)."""
    mean = np.asarray(weights.mean).reshape(model.n_dims, -1)[model.layout.dims([modality])]
    return mean @ model.basis(np.array([phase]))[0]


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

    def region(self, model: ProMPModel, modality: str, n_points: int = TUBE_POINTS):
        """The region of a new movement in ``modality``, calibrated (its radius times the
        primitive's factor, :func:`promp.region.region_scale`)."""
        scale = region_scale(model.primitive(self.name), modality)
        return region_of(model, self.weights, modality, n_points, scale)


def prior_shape(
    model: ProMPModel, name: str, via_points: Sequence[StudioViaPoint] = ()
) -> PriorShape:
    """Primitive ``name`` with its via-points (those of ``via_points`` that are its)."""
    primitive = model.primitive(name)
    alpha = float(math.exp(primitive.log_alpha_mean))
    mine = of_primitive(via_points, name)
    return PriorShape(name, alpha, shaped(model, new_movement(primitive), mine, alpha), mine)


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
    future : array, shape (PATH_POINTS, 3)
        The predicted mean from the last observed sample to the end.
    observed : array, shape (n_observed, 3), or None
        What was observed of it (None: not observed).
    truth : array, shape (m, 3), or None
        The rest of the whole movement, from the last observed sample (a test demonstration).
    """

    modality: str
    region: SampleDistribution
    future: np.ndarray
    observed: np.ndarray | None
    truth: np.ndarray | None


def positions(
    model: ProMPModel,
    weights: Gaussian | Posterior,
    observation: Observation,
    observed_phase: float,
    truth: np.ndarray | None = None,
) -> tuple[PositionView, ...]:
    """Every position modality of ``model`` (the hand first) from the posterior ``weights``.

    Parameters
    ----------
    observed_phase : float
        The share of the predicted duration observed (where the future paths start).
    truth : array, shape (n_samples, n_dims), optional
        The whole test demonstration's values (``model.layout.extract``).
    """
    layout = model.layout
    start = min(max(observed_phase, 0.0), 1.0)
    phases = np.linspace(start, 1.0, PATH_POINTS)
    mean = np.asarray(weights.mean).reshape(model.n_dims, -1)
    views = []
    for modality in position_modalities(layout):
        dims = layout.dims([modality.name])
        observed = None
        if modality.name in observation.modalities:
            cols = np.flatnonzero(np.isin(layout.dims(observation.modalities), dims))
            observed = observation.values[:, cols]
        rest = None
        if truth is not None:
            rest = truth[max(observation.n_observed - 1, 0) :, dims]
        views.append(PositionView(
            modality.name, region_of(model, weights, modality.name),
            model.basis(phases) @ mean[dims].T, observed, rest,
        ))  # fmt: skip
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
