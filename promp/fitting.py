"""Learning multi-modal ProMPs from demonstrations with every setting given (paper Eqs. 1-4).

Per demonstration, the weights of every dimension are fitted by ridge regression on the phase
basis (Eq. 2, :mod:`promp.weights`); per primitive, their mean and covariance define the prior
over trajectories (Eqs. 3-4). With fewer demonstrations than weights the sample covariance is
singular, so by default every primitive's covariance is estimated under a prior pooled across
the primitives of the dataset, whose strength is chosen by marginal likelihood
(:mod:`promp.covariance`): a primitive with few demonstrations borrows the shape the others
share, one with many keeps its own. ``Settings(shrinkage=lambda)`` instead shrinks each
primitive's sample covariance alone towards ``F = blockdiag(tau_d I_M)`` with a fixed
intensity: ``(1 - lambda) S + lambda F``. Either way the result is stored as
:class:`promp.model.Primitive` stores it. The weights are regressed on log alpha (the coupling
of shape and speed, :class:`promp.model.Primitive`), the observation noise is the sensor's,
pooled over the primitives (:func:`promp.noise.estimate_noise`), and every modality gets its
Eq. 7 model of the speed (:mod:`promp.alpha_model`).

:func:`fit_with` is the fit; :func:`fit_parts` also returns what the closed-form leave-one-out
score of :mod:`promp.selection` downdates (:class:`FitParts`). :func:`promp.learn.fit`, the
library's entry point, chooses the settings left open first.
"""

from __future__ import annotations

import copy
import functools
import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from promp._recent import per_object, recent
from promp.alpha_model import AlphaModel, resample_uniform
from promp.covariance import (
    MIN_SHRINKAGE,
    PooledPrior,
    fixed_shrinkage,
    pooled_covariances,
)
from promp.data import Demonstration, Layout
from promp.model import STILL_PARTS, Primitive, ProMPModel, Settings
from promp.noise import estimate_noise
from promp.quality import winsorized
from promp.region_calibration import calibrate
from promp.scale import RELATIVE_FLOOR
from promp.stillness import still_parts
from promp.timing import alpha_from_duration
from promp.weights import WeightFits, fit_all_weights

__all__ = ["FitParts", "fit_parts", "fit_with", "learned_stillness"]


@dataclass(frozen=True, eq=False)
class _Moments:
    """One primitive's weights summarised before its covariance is estimated."""

    mean: np.ndarray
    slope: np.ndarray
    residuals: np.ndarray  # weights - mean - slope * (log alpha - its mean), (n, P)
    centred_log_alphas: np.ndarray  # its regressor, (n,)
    slope_weight: float  # 1 / (its regressor's sum of squares); 0 without the regression
    dof: int
    alphas: np.ndarray
    log_alpha_mean: float


def _alphas(demos: Sequence[Demonstration], sample_period: float, s_bar: float) -> np.ndarray:
    return np.array([alpha_from_duration(d.duration, sample_period, s_bar) for d in demos])


def _moments(
    demos: Sequence[Demonstration],
    weights: np.ndarray,
    settings: Settings,
    sample_period: float,
) -> _Moments:
    alphas = _alphas(demos, sample_period, settings.s_bar)
    mean = weights.mean(axis=0)
    centred = weights - mean
    log_alphas = winsorized(np.log(alphas))  # a far-out speed has no undue leverage
    log_alpha_mean = float(log_alphas.mean())
    a_c = log_alphas - log_alpha_mean
    dof = len(demos) - 1
    slope = np.zeros_like(mean)
    slope_weight = 0.0
    if settings.alpha_coupling and len(demos) >= 3 and float(a_c @ a_c) > 1e-12:
        slope_weight = 1.0 / float(a_c @ a_c)
        slope = centred.T @ a_c / float(a_c @ a_c)
        centred = centred - np.outer(a_c, slope)
        dof = len(demos) - 2
    return _Moments(mean, slope, centred, a_c, slope_weight, dof, alphas, log_alpha_mean)


def _alpha_models(
    demos: Sequence[Demonstration], layout: Layout, settings: Settings, sample_period: float
) -> dict[str, AlphaModel]:
    """The Eq. 7 model of every modality of one primitive, kept for its last demonstration
    lists seen (a refit after a take learns anew only the primitive that changed)."""

    def make() -> dict[str, AlphaModel]:
        alphas = _alphas(demos, sample_period, settings.s_bar)
        trajectories = [resample_uniform(d, layout.extract(d), sample_period) for d in demos]
        return {
            m.name: AlphaModel.fit([t[:, layout.dims([m.name])] for t in trajectories], alphas)
            for m in layout.modalities
        }

    return recent(_ALPHA_MODELS, (layout, settings.s_bar, sample_period), demos, make)


_ALPHA_MODELS: list = []


@dataclass(frozen=True, eq=False)
class FitParts:
    """What a fit learned on the way to one primitive, for the closed-form leave-one-out
    score of :mod:`promp.selection` (never stored).

    With the pooled prior (``prior``: its parts, :class:`promp.covariance.PooledPrior`)
    ``Sigma_w = a(n, dof) Sigma_0 + b(n, dof) E^T E`` (:meth:`weights_of`), ``Sigma_0`` built
    from every primitive's residual rows; with a fixed shrinkage ``Sigma_w = lambda F +
    (1 - lambda) / dof E^T E``. ``E`` (n x P) are the primitive's residuals
    (:attr:`residuals`). Without demonstration ``j`` its residual scatter loses
    ``e_j e_j^T / (1 - h_j)`` (``h``: the leverage of each demonstration in the regression on
    log alpha), and so does the pooled one, and the held-out prediction of its weights is
    ``weights_j - e_j / (1 - h_j)`` (the regression's leave-one-out identity).
    """

    weights: np.ndarray  # (n, P)
    residuals: np.ndarray  # (n, P)
    centred_log_alphas: np.ndarray  # (n,) the regressor (winsorized, centred)
    slope_weight: float  # 1 / sum of its squares; 0 without the regression
    dof: int
    prior: PooledPrior | None  # None: a fixed shrinkage
    shrinkage: float | None

    @functools.cached_property
    def leverage(self) -> np.ndarray:
        """Each demonstration's leverage in the regression on log alpha, (n,):
        ``1 / n + a_j^2 / sum(a^2)`` (``1 / n`` without the regression)."""
        n = self.residuals.shape[0]
        return 1.0 / n + self.centred_log_alphas**2 * self.slope_weight

    def without(
        self, j: int, mean: np.ndarray, slope: np.ndarray, cols: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """The primitive refitted without demonstration ``j`` (``mean``, ``slope``: the
        primitive's): its mean and regression slope (P,), the loss of its residual scatter
        ``E^T E - E_(-j)^T E_(-j)`` in ``cols`` (len(cols) squared) and its degrees of
        freedom. Rank-one downdates; with three demonstrations, the two left have no
        regression (:func:`_moments`) and are summed directly."""
        n = self.residuals.shape[0]
        e, h = self.residuals[j], float(self.leverage[j])
        if self.slope_weight > 0.0 and n - 1 < 3:
            others = np.delete(self.weights, j, axis=0)
            centred = others - others.mean(axis=0)
            kept = self.residuals[:, cols].T @ self.residuals[:, cols]
            drop = kept - centred[:, cols].T @ centred[:, cols]
            return others.mean(axis=0), np.zeros_like(slope), drop, n - 2
        mean_j = mean - e / (n * (1.0 - h))
        slope_j = slope - self.slope_weight * self.centred_log_alphas[j] / (1.0 - h) * e
        return mean_j, slope_j, np.outer(e[cols], e[cols]) / (1.0 - h), self.dof - 1

    def weights_of(self, n: int, dof: int) -> tuple[float, float]:
        """``(a, b)``: the factors of ``Sigma_0`` and of ``E^T E`` in Sigma_w for a primitive
        of ``n`` demonstrations and ``dof`` residual degrees of freedom (``a`` is 0 with a
        fixed shrinkage, whose target part does not move)."""
        if self.prior is None:
            return 0.0, (1.0 - max(float(self.shrinkage), MIN_SHRINKAGE)) / dof
        inflate, c = 1.0 + 1.0 / n, self.prior.strength
        return inflate * c / (c + dof), inflate / (c + dof)


def learned_stillness(demos: Sequence[Demonstration], layout: Layout
                      ) -> dict[str, dict[str, np.ndarray]]:  # fmt: skip
    """Per modality of ``layout`` in metres or radians, how each of ``demos`` is still (s,
    each shape (n_demos,)): ``lead``, ``pause`` and ``trail`` of
    :func:`promp.stillness.still_parts`, the rule the live segmenter cuts movements by."""
    out = {}
    for modality in layout.modalities:
        if modality.unit in ("m", "rad"):
            dims = layout.dims([modality.name])
            parts = np.array([_still_parts_of(d, layout, modality.name, dims, modality.unit)
                              for d in demos]).reshape(len(demos), 3)  # fmt: skip
            out[modality.name] = dict(zip(STILL_PARTS, parts.T, strict=True))
    return out


def _still_parts_of(demo: Demonstration, layout: Layout, name: str, dims: np.ndarray,
                    unit: str) -> tuple[float, float, float]:  # fmt: skip
    """:func:`promp.stillness.still_parts` of one modality of ``demo``, computed once per
    demonstration and layout: every candidate basis of a choice, the final fit and every fold
    of an evaluation learn the same demonstrations' stillness (computed again each time, it
    was ~8 % of a fold's CPU on the 70 x 15 set)."""
    return per_object(
        _STILLNESS, demo, (layout, name),
        lambda: still_parts(demo.times, [(layout.extract(demo)[:, dims], unit)]),
    )  # fmt: skip


_STILLNESS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def fit_with(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
    alpha_models: bool = True,
    regions: bool = True,
) -> ProMPModel:
    """:func:`promp.learn.fit` with every setting given (no choice) and the sample period
    ``dt`` (s); without ``alpha_models`` the primitives have no Eq. 7 models (they are not
    needed to recognise with the "ml" alpha). With ``regions`` each primitive's region is
    calibrated on its own demonstrations left out in turn
    (:func:`promp.region_calibration.calibrate`); without, it keeps no factor (the drawn
    region's; nothing recognised or predicted reads it)."""
    model, parts = fit_parts(dataset, layout, settings, dt, alpha_models)
    return calibrate(model, parts, dataset) if regions else model


def fit_parts(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
    alpha_models: bool = True,
) -> tuple[ProMPModel, list[FitParts]]:
    """:func:`fit_with`, and each primitive's :class:`FitParts`."""
    all_demos = [d for demos in dataset.values() for d in demos]
    fits = fit_all_weights(settings.basis, all_demos, layout, settings.ridge)
    noise_var, noise_tau = estimate_noise(fits, [d.times for d in all_demos], layout, settings)
    # what the noise and the Eq. 7 models do not change: the candidates of a choice of
    # settings, the fit of the one chosen and a refit of the same training share it
    key = (
        settings.basis, layout, settings.ridge, settings.shrinkage, settings.alpha_coupling,
        settings.s_bar, dt, tuple((name, len(demos)) for name, demos in dataset.items()),
    )  # fmt: skip
    core = recent(_CORES, key, all_demos, lambda: _core(dataset, layout, settings, dt, fits))
    moments, covariances, shares, prior = core.moments, core.covariances, core.shares, core.prior
    report: dict = {"covariance": copy.deepcopy(core.report)}
    offsets = core.offsets
    primitives = tuple(
        Primitive(
            name=name,
            mean=m.mean,
            cov_diag=cov_diag,
            cov_factor=cov_factor,
            noise_var=np.array(noise_var, dtype=float),
            noise_tau=np.array(noise_tau, dtype=float),
            alphas=m.alphas,
            alpha_models=_alpha_models(demos, layout, settings, dt) if alpha_models else {},
            shrinkage=np.clip(share, MIN_SHRINKAGE, 1.0),
            log_alpha_mean=m.log_alpha_mean,
            alpha_slope=m.slope,
            stillness=learned_stillness(demos, layout),
            residuals=m.residuals,
        )
        for (name, demos), m, (cov_diag, cov_factor), share in zip(
            dataset.items(), moments, covariances, shares, strict=True
        )
    )
    model = ProMPModel(
        layout=layout, settings=settings, sample_period=dt, primitives=primitives, report=report
    )
    parts = [
        FitParts(
            weights=np.array(fits.weights[offsets[k] : offsets[k + 1]]),
            residuals=m.residuals,
            centred_log_alphas=m.centred_log_alphas,
            slope_weight=m.slope_weight,
            dof=m.dof,
            prior=prior,
            shrinkage=settings.shrinkage,
        )
        for k, m in enumerate(moments)
    ]
    return model, parts


@dataclass(frozen=True, eq=False)
class _Core:
    """What :func:`fit_parts` learns before the noise and the Eq. 7 models: each primitive's
    moments, covariance (diagonal, factor) and shrinkage share, the pooled prior (None with a
    fixed shrinkage) and its report, and where each primitive's demonstrations start."""

    moments: list[_Moments]
    covariances: list[tuple[np.ndarray, np.ndarray]]
    shares: list[np.ndarray]
    prior: PooledPrior | None
    report: dict
    offsets: np.ndarray


def _core(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
    fits: WeightFits,
) -> _Core:
    offsets = np.cumsum([0] + [len(demos) for demos in dataset.values()])
    moments = [
        _moments(demos, np.array(fits.weights[offsets[k] : offsets[k + 1]]), settings, dt)
        for k, demos in enumerate(dataset.values())
    ]
    for m in moments:  # shared by every model made from this core: read-only
        for array in (m.mean, m.slope, m.residuals, m.alphas):
            array.setflags(write=False)
    floor = RELATIVE_FLOOR * fits.scale  # no variance below a fraction of the data's own scale
    if settings.shrinkage is None:
        covariances, prior = pooled_covariances(
            [m.residuals for m in moments],
            [m.dof for m in moments],
            [layout.dims([mod.name]) for mod in layout.modalities],
            layout.n_dims,
            settings.basis,
            floor,
        )
        shares = [prior.target_weight * prior.strength / (prior.strength + m.dof) for m in moments]
        _read_only(covariances)
        return _Core(moments, covariances, shares, prior, prior.describe(), offsets)
    covariances = [
        fixed_shrinkage(m.residuals, m.dof, settings.basis, settings.shrinkage, floor)
        for m in moments
    ]
    shares = [np.full(layout.n_dims, settings.shrinkage) for _ in moments]
    _read_only(covariances)
    report = {
        "rule": "fixed shrinkage of each primitive's sample covariance (--shrinkage)",
        "shrinkage": float(settings.shrinkage),
    }
    return _Core(moments, covariances, shares, None, report, offsets)


def _read_only(covariances: list[tuple[np.ndarray, np.ndarray]]) -> None:
    for diag, factor in covariances:
        diag.setflags(write=False)
        factor.setflags(write=False)


_CORES: list = []
