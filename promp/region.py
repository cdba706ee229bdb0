"""Where a new movement's samples lie: the predictive region of a primitive, a 3-D region (or
k-D: any modality's columns) with a stated probability at each phase.

A sample of a new demonstration at phase ``z``, in the columns ``d`` of one modality, is
``y = Phi_d(z) w + eps`` with ``w ~ N(mu, Sigma)`` (the weights, Eqs. 3-4) and ``eps`` the
sensor's noise. Its distribution is Gaussian:

    m(z) = Phi_d(z) mu_d,    S(z) = Phi_d(z) Sigma_dd Phi_d(z)^T + diag(sigma_d^2)

(``Phi_d(z)``: the block-diagonal basis of the k columns, k x kM). The region of probability
``P`` at phase ``z`` is the ellipsoid ``{y : (y - m)^T S^-1 (y - m) <= chi2_k(P)}``; swept
along the phases it is the tube the studio draws.

Which ``mu, Sigma`` (:func:`new_movement`): a new demonstration's speed is not known, and the
model's ``Sigma_w`` is the covariance of the weights *at a given speed* (the regression of the
weights on log alpha, :class:`promp.model.Primitive`); over the speeds of the training
demonstrations, ``w = mu + s (log alpha - a_bar) + e``, so

    mu = mu_w (the mean at the typical speed, a_bar),    Sigma = Sigma_w + v_a s s^T

with ``v_a`` the variance of the (winsorised) training log alphas. Which ``sigma^2``
(:func:`sample_noise_var`): the fit residuals' variance, the noise samples carry about their
movement; the model's ``noise_var`` is that times ``noise_scale^2``, a factor chosen to temper
the likelihood for recognition, not a property of where samples lie (on the default workspace
it is 4: a region with it covered 99 % of the samples where it said 90 %).

The covariance is the model's, pooled across primitives (:mod:`promp.covariance`): a primitive
with few demonstrations borrows the others' shape, so its region may be wider (or narrower)
than its own demonstrations' spread. And one Gaussian over the weights holds demonstrations
that differ in shape and overall speed, not in their timing within the movement (one that
lingers where another hurries lies outside the Gaussian at the same phase). So the fit
calibrates the region of each primitive and modality (:mod:`promp.region_calibration`): a
factor ``c`` on its radius (``S`` times ``c^2``, :func:`region_scale`), the one whose region,
learned without each of the primitive's demonstrations in turn, holds the stated share of the
one left out. :func:`coverage` measures the share of a primitive's samples inside its region.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from promp.data import Demonstration
from promp.inference import Gaussian, Posterior
from promp.model import Primitive, ProMPModel
from promp.quality import winsorized
from promp.timing import demo_phases
from promp.via_points import ViaPoint, condition_on_via_points

__all__ = [
    "DEFAULT_PROBABILITY",
    "Coverage",
    "SampleDistribution",
    "check_probability",
    "coverage",
    "mean_position",
    "modality_region",
    "new_movement",
    "region_radius",
    "region_scale",
    "sample_distribution",
    "sample_noise_var",
    "shaped_prior",
    "speed_variance",
]

DEFAULT_PROBABILITY = 0.9


@dataclass(frozen=True, eq=False)
class SampleDistribution:
    """The Gaussian of a new sample at each phase, in some columns.

    Attributes
    ----------
    phases : array, shape (n,)
    mean : array, shape (n, k)
    cov : array, shape (n, k, k)
    """

    phases: np.ndarray
    mean: np.ndarray
    cov: np.ndarray

    def squared_distances(self, points: np.ndarray) -> np.ndarray:
        """``(y - m)^T S^-1 (y - m)`` of ``points`` (n, k), one per phase, shape (n,)."""
        points = np.asarray(points, dtype=float)
        if points.shape != self.mean.shape:
            raise ValueError(f"points must have shape {self.mean.shape}, got {points.shape}")
        r = points - self.mean
        return np.einsum("ni,ni->n", r, np.linalg.solve(self.cov, r[..., None])[..., 0])


def check_probability(probability: float) -> float:
    """``probability`` as a float in (0, 1); ValueError otherwise."""
    p = float(probability)
    if not np.isfinite(p) or not 0.0 < p < 1.0:
        raise ValueError(f"the region's probability must be in (0, 1), got {probability}")
    return p


def region_radius(probability: float, k: int) -> float:
    """``sqrt(chi2_k^-1(P))``: the Mahalanobis radius of the ellipsoid that holds ``P`` of a
    k-dimensional Gaussian (2.50 for 90 % in 3-D, where +-2 sigma per axis holds 74 %)."""
    if int(k) != k or k < 1:
        raise ValueError(f"k must be a positive integer, got {k}")
    return float(np.sqrt(chi2.ppf(check_probability(probability), int(k))))


def region_scale(primitive: Primitive, modality: str) -> float:
    """The calibrated factor on the radius of ``primitive``'s region in ``modality``
    (:attr:`promp.model.Primitive.region_scale`; 1 when it has none)."""
    return float(primitive.region_scale.get(modality, 1.0))


def speed_variance(primitive: Primitive) -> float:
    """The variance of the (winsorised) log alphas of the primitive's training
    demonstrations, ``v_a``; 0 with fewer than two."""
    logs = winsorized(np.log(np.asarray(primitive.alphas, dtype=float)))
    return float(np.var(logs, ddof=1)) if logs.shape[0] >= 2 else 0.0


def new_movement(primitive: Primitive) -> Gaussian:
    """The weights of a new demonstration of ``primitive`` whatever its speed (see the module
    docstring): mean ``mu_w`` (n_weights,), covariance ``Sigma_w + v_a s s^T``. A new object."""
    slope = np.asarray(primitive.alpha_slope, dtype=float)
    cov = primitive.cov + speed_variance(primitive) * np.outer(slope, slope)
    return Gaussian(np.array(primitive.mean, dtype=float), cov)


def sample_noise_var(model: ProMPModel, primitive: Primitive) -> np.ndarray:
    """The noise variance of the samples about their movement, shape (n_dims,): the model's
    ``noise_var`` without the recognition's ``noise_scale`` (a modality whose noise the
    settings give keeps it)."""
    settings = model.settings
    scale = settings.noise_scale or 1.0
    var = np.array(primitive.noise_var, dtype=float)
    for modality in model.layout.modalities:
        if modality.name not in settings.noise_std:
            var[model.layout.dims([modality.name])] /= scale**2
    return var


def sample_distribution(
    model: ProMPModel,
    dist: Gaussian | Posterior,
    dims: np.ndarray | Sequence[int],
    phases: np.ndarray,
    noise_var: np.ndarray | None = None,
    scale: float = 1.0,
) -> SampleDistribution:
    """The Gaussian of a sample in columns ``dims`` at each of ``phases``.

    Parameters
    ----------
    dist : Gaussian or Posterior
        The weights, mean (n_weights,), covariance (n_weights, n_weights).
    dims : array of int, shape (k,)
        Model dimensions (e.g. ``model.layout.dims(["hand"])``).
    phases : array, shape (n,)
        In [0, 1].
    noise_var : array, shape (n_dims,), optional
        The samples' noise variance (:func:`sample_noise_var`); None: the movement itself,
        without noise.
    scale : float
        The factor on the region's radius (:func:`region_scale`): the covariance is multiplied
        by its square.
    """
    dims = np.asarray(dims, dtype=int).reshape(-1)
    if dims.size == 0 or dims.min() < 0 or dims.max() >= model.n_dims:
        raise ValueError(
            f"dims must be dimensions of the model (0..{model.n_dims - 1}), got {dims}"
        )
    phases = np.asarray(phases, dtype=float).reshape(-1)
    m = model.basis.n_basis
    phi = model.basis(phases)  # (n, M)
    idx = (dims[:, None] * m + np.arange(m)[None, :]).reshape(-1)
    mean = phi @ np.asarray(dist.mean)[idx].reshape(dims.size, m).T  # (n, k)
    blocks = np.asarray(dist.cov)[np.ix_(idx, idx)].reshape(dims.size, m, dims.size, m)
    cov = np.einsum("nm,dmek,nk->nde", phi, blocks, phi)
    if noise_var is not None:
        cov = cov + np.diag(np.asarray(noise_var, dtype=float)[dims])[None]
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError(f"the region's scale must be positive, got {scale}")
    cov = 0.5 * (cov + cov.transpose(0, 2, 1)) * float(scale) ** 2
    return SampleDistribution(phases, mean, cov)


def modality_region(
    model: ProMPModel,
    weights: Gaussian | Posterior,
    modality: str,
    n_points: int,
    primitive: Primitive | None = None,
    scale: float = 1.0,
) -> SampleDistribution:
    """Where ``modality``'s samples lie under ``weights``: :func:`sample_distribution` on
    ``n_points`` phases over [0, 1], with the samples' noise of ``primitive`` (default the
    model's first: the primitives share it), its radius times ``scale`` (a calibrated
    factor, :func:`region_scale`)."""
    noise = sample_noise_var(model, primitive or model.primitives[0])
    phases = np.linspace(0.0, 1.0, n_points)
    dims = model.layout.dims([modality])
    return sample_distribution(model, weights, dims, phases, noise, scale)


def mean_position(
    model: ProMPModel, weights: Gaussian | Posterior, modality: str, phase: float
) -> np.ndarray:
    """The mean of ``modality`` at ``phase`` (in [0, 1]) under ``weights``, shape (k,)."""
    mean = np.asarray(weights.mean).reshape(model.n_dims, -1)[model.layout.dims([modality])]
    return mean @ model.basis(np.array([phase]))[0]


def shaped_prior(
    model: ProMPModel, name: str, via_points: Sequence[ViaPoint] = ()
) -> tuple[float, Gaussian | Posterior]:
    """Primitive ``name``'s typical speed (exp of its training demonstrations' mean log
    alpha) and the weights of a new movement of it (:func:`new_movement`) conditioned on
    ``via_points`` at that speed (:func:`promp.via_points.condition_on_via_points`; none: the
    new movement itself)."""
    primitive = model.primitive(name)
    alpha = float(math.exp(primitive.log_alpha_mean))
    weights = new_movement(primitive)
    if via_points:
        weights = condition_on_via_points(model, weights, via_points, alpha)
    return alpha, weights


@dataclass(frozen=True)
class Coverage:
    """How many samples of some demonstrations lie inside a region: ``inside`` of ``total``,
    at ``probability``, its radius times ``scale`` (:func:`region_scale`)."""

    inside: int
    total: int
    probability: float
    scale: float = 1.0

    @property
    def share(self) -> float:
        return self.inside / self.total if self.total else float("nan")


def coverage(
    model: ProMPModel,
    name: str,
    demos: Sequence[Demonstration],
    modality: str,
    probability: float = DEFAULT_PROBABILITY,
    calibrated: bool = True,
) -> Coverage:
    """The samples of ``demos`` in ``modality`` inside primitive ``name``'s region of
    ``probability``, each at its own phase ``t / T`` (its time over its demonstration's
    duration): the region of a new movement (:func:`new_movement`) with the samples' noise
    (:func:`sample_noise_var`), its radius times the primitive's calibrated factor
    (:func:`region_scale`; 1 without ``calibrated``).

    Raises
    ------
    ValueError
        An unknown primitive or modality, a probability outside (0, 1).
    """
    primitive = model.primitive(name)
    dims = model.layout.dims([modality])
    q = region_radius(probability, dims.size) ** 2
    scale = region_scale(primitive, modality) if calibrated else 1.0
    dist = new_movement(primitive)
    noise = sample_noise_var(model, primitive)
    inside = total = 0
    for demo in demos:
        phases = demo_phases(demo.times)
        region = sample_distribution(model, dist, dims, phases, noise, scale)
        d2 = region.squared_distances(model.layout.extract(demo)[:, dims])
        inside += int(np.count_nonzero(d2 <= q))
        total += int(d2.shape[0])
    return Coverage(inside, total, check_probability(probability), scale)
