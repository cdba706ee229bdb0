"""Learning multi-modal ProMPs from demonstrations (paper Eqs. 1-4).

Per demonstration, the weights of every dimension are fitted by ridge regression on the phase
basis (Eq. 2); per primitive, their mean and covariance define the prior over trajectories
(Eqs. 3-4). With fewer demonstrations than weights the sample covariance is singular, so by
default every primitive's covariance is estimated under a prior pooled across the primitives of
the dataset, whose strength is chosen by marginal likelihood (:mod:`promp.covariance`): a
primitive with few demonstrations borrows the shape the others share, one with many keeps its
own. ``Settings(shrinkage=lambda)`` instead shrinks each primitive's sample covariance alone
towards ``F = blockdiag(tau_d I_M)`` with a fixed intensity: ``(1 - lambda) S + lambda F``.
Either way the result is stored as a diagonal plus a low-rank factor,
``Sigma_w = diag(cov_diag) + cov_factor @ cov_factor.T``, and inference exploits that structure
(determinant lemma / Woodbury); the diagonal is constant within each dimension's block, which
lets likelihoods share one eigendecomposition per dimension.

Observation noise is a property of the sensor, not of a primitive: per modality, it is the mean
squared fit residual of its dimensions over the demonstrations of all primitives, with the
degrees of freedom of the regression removed, unless overridden in :class:`Settings`. (Per-
primitive noise levels would bias recognition towards the primitive fitted most tightly: the
normalising term ``n_o log sigma^2`` of the likelihood then outweighs the data.)
"""

from __future__ import annotations

import copy
import dataclasses
import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from promp._recent import cached_on, recent
from promp.alpha_model import AlphaModel, resample_uniform
from promp.basis import PhaseBasisCache, RBFBasis
from promp.covariance import (
    MIN_SHRINKAGE,
    PooledPrior,
    compress_factor,
    fixed_shrinkage,
    pooled_covariances,
)
from promp.data import Demonstration, Layout
from promp.quality import winsorized
from promp.scale import RELATIVE_FLOOR
from promp.timing import alpha_from_duration
from promp.weights import WeightFits, fit_all_weights, fit_weights  # noqa: F401

# The reference settings: what a fit uses when it cannot choose (see promp.selection).
FALLBACK = {"n_basis": 7, "width": 1.0, "noise_scale": 1.5}
# How the others are chosen (promp.selection): closed-form leave-one-out, or inner folds.
SELECT_RULES = ("loo", "cv")


@dataclass(frozen=True)
class Settings:
    """Learning settings; ``None`` (the default of ``n_basis``, ``width``, ``noise_scale``)
    means "chosen from the training demonstrations by every fit" (:mod:`promp.selection`).

    Parameters
    ----------
    n_basis : int or None
        M, basis functions per dimension.
    width : float or None
        RBF standard deviation as a multiple of the spacing of the centres.
    ridge : float or None
        Ridge strength of the per-demonstration weight regression, relative to the mean
        diagonal of ``Phi^T Phi``; None (the default) chooses it per modality by generalised
        cross-validation pooled over all demonstrations, so noisy modalities (a webcam's head
        angles) get smooth weights instead of fitted noise, and clean ones (the hand) keep
        their detail.
    s_bar : float
        Reference length of the time modulation (alpha = s_bar / n_samples).
    shrinkage : float or None
        None (the default): the hierarchical prior pooled across primitives, its strength by
        marginal likelihood (:mod:`promp.covariance`). A number in (0, 1]: each primitive's
        sample covariance shrunk by that fixed intensity towards the per-dimension scaled
        identity.
    noise_std : mapping of str to float
        Observation noise standard deviation per modality, in the modality's unit; modalities
        not listed use the estimate from the fit residuals.
    noise_scale : float or None
        Multiplies every estimated noise standard deviation.
    noise_correlation : bool
        Model the observation noise as an Ornstein-Uhlenbeck process whose correlation time is
        estimated from the fit residuals (they are strongly correlated from one sample to the
        next: a white-noise likelihood would count every densely sampled point as independent
        evidence); off: white noise.
    alpha_coupling : bool
        Learn how the shape depends on the speed: the weights are regressed on log(alpha) and
        the prior at a candidate alpha is the conditional Gaussian (see :class:`Primitive`).
    duration_temperature : float or None
        The power of the likelihood in the posterior over the speed, hence the predicted
        duration and its interval (:mod:`promp.duration`), in (0, 1]; None (the default)
        chooses it from held-out training demonstrations with the other automatic settings.
        1 is the plain Bayesian posterior. The class probabilities never use it.
    select : str
        How the automatic settings are chosen (:mod:`promp.selection`): ``"loo"`` (the
        default), the recognition log-loss of every training demonstration left out in closed
        form from one fit per candidate basis; ``"cv"``, the inner cross-validation that
        refits every fold (slower, for comparison).
    """

    n_basis: int | None = None
    width: float | None = None
    ridge: float | None = None
    s_bar: float = 100.0
    shrinkage: float | None = None
    noise_std: Mapping[str, float] = field(default_factory=dict)
    noise_scale: float | None = None
    alpha_coupling: bool = True
    noise_correlation: bool = True
    duration_temperature: float | None = None
    select: str = "loo"

    def __post_init__(self) -> None:
        if self.select not in SELECT_RULES:
            raise ValueError(f"select must be one of {list(SELECT_RULES)}, got {self.select!r}")
        RBFBasis(  # validates both
            FALLBACK["n_basis"] if self.n_basis is None else self.n_basis,
            FALLBACK["width"] if self.width is None else self.width,
        )
        if self.ridge is not None and (not np.isfinite(self.ridge) or self.ridge < 0):
            raise ValueError(f"ridge must be >= 0 or None, got {self.ridge}")
        if not np.isfinite(self.s_bar) or self.s_bar <= 0:
            raise ValueError(f"s_bar must be positive, got {self.s_bar}")
        if self.shrinkage is not None and not 0.0 < self.shrinkage <= 1.0:
            raise ValueError(f"shrinkage must be in (0, 1] or None, got {self.shrinkage}")
        for name, std in self.noise_std.items():
            if not np.isfinite(std) or std <= 0:
                raise ValueError(f"noise_std[{name!r}] must be positive, got {std}")
        if self.noise_scale is not None and (
            not np.isfinite(self.noise_scale) or self.noise_scale <= 0
        ):
            raise ValueError(f"noise_scale must be positive or None, got {self.noise_scale}")
        if self.duration_temperature is not None and not (
            np.isfinite(self.duration_temperature) and 0.0 < self.duration_temperature <= 1.0
        ):
            raise ValueError(
                "duration_temperature must be in (0, 1] or None, got "
                f"{self.duration_temperature}"
            )
        object.__setattr__(self, "noise_std", dict(self.noise_std))

    @property
    def automatic(self) -> tuple[str, ...]:
        """The settings left to the data (None), in the order of :data:`FALLBACK`."""
        return tuple(name for name in FALLBACK if getattr(self, name) is None)

    def with_fallback(self) -> Settings:
        """These settings with every automatic one at its fallback value."""
        return dataclasses.replace(self, **{name: FALLBACK[name] for name in self.automatic})

    @property
    def basis(self) -> RBFBasis:
        if self.n_basis is None or self.width is None:
            raise ValueError(
                "the basis is chosen by the fit (n_basis or width is None): use the fitted "
                "model's settings"
            )
        return RBFBasis(self.n_basis, self.width)


@dataclass(frozen=True, eq=False)
class Primitive:
    """The learned distribution of one movement primitive.

    Attributes
    ----------
    name : str
    mean : array, shape (n_weights,)
        mu_w, dimension-major (``n_weights = n_dims * n_basis``).
    cov_diag : array, shape (n_weights,)
    cov_factor : array, shape (n_weights, rank)
        ``Sigma_w = diag(cov_diag) + cov_factor @ cov_factor.T``.
    noise_var : array, shape (n_dims,)
        Observation noise variance of every dimension.
    noise_tau : array, shape (n_dims,)
        Correlation time (s) of the observation noise of every dimension: the noise is an
        Ornstein-Uhlenbeck process, ``cov = noise_var * exp(-|t_i - t_j| / noise_tau)``; 0 for
        white noise.
    alphas : array, shape (n_demos,)
        Time modulation of each training demonstration.
    alpha_models : mapping of str to AlphaModel
        Eq. 7 model per modality.
    shrinkage : array, shape (n_dims,)
        Share of the covariance that comes from the target ``F`` in each dimension (one per
        modality): the fixed intensity, or with the pooled prior ``beta c / (c + dof)``.
    log_alpha_mean : float
        Mean of log(alpha) over the training demonstrations.
    alpha_slope : array, shape (n_weights,)
        Regression of the weights on log(alpha): the prior mean at ``alpha`` is
        ``mean + alpha_slope * (log(alpha) - log_alpha_mean)`` and ``Sigma_w`` is the covariance
        of the regression residuals, i.e. the joint Gaussian of (w, log alpha) conditioned on
        alpha. Zero when the coupling is off.
    """

    name: str
    mean: np.ndarray
    cov_diag: np.ndarray
    cov_factor: np.ndarray
    noise_var: np.ndarray
    alphas: np.ndarray
    alpha_models: Mapping[str, AlphaModel]
    shrinkage: np.ndarray
    log_alpha_mean: float = 0.0
    alpha_slope: np.ndarray | None = None
    noise_tau: np.ndarray | None = None

    def __post_init__(self) -> None:
        blocks = np.asarray(self.cov_diag).reshape(np.asarray(self.noise_var).shape[0], -1)
        if np.any(blocks != blocks[:, :1]):
            raise ValueError(
                f"primitive {self.name!r}: cov_diag must be constant within each dimension's "
                "block of weights (the shrinkage target is one scaled identity per dimension)"
            )
        if self.alpha_slope is None:
            object.__setattr__(self, "alpha_slope", np.zeros_like(self.mean))
        if self.noise_tau is None:
            object.__setattr__(self, "noise_tau", np.zeros_like(self.noise_var))

    def mean_at(self, alpha: float | np.ndarray) -> np.ndarray:
        """Prior mean of the weights at time modulation ``alpha``.

        Returns
        -------
        array, shape (n_weights,) for a scalar alpha, (n_alphas, n_weights) for an array.
        """
        shift = np.log(np.asarray(alpha, dtype=float)) - self.log_alpha_mean
        return self.mean + shift[..., None] * self.alpha_slope

    @property
    def n_demos(self) -> int:
        return int(self.alphas.shape[0])

    @functools.cached_property
    def cov(self) -> np.ndarray:
        """Dense Sigma_w, shape (n_weights, n_weights)."""
        return np.diag(self.cov_diag) + self.cov_factor @ self.cov_factor.T

    @functools.cached_property
    def cov_blocks(self) -> np.ndarray:
        """Covariance of each dimension's weights, shape (n_dims, n_basis, n_basis)."""
        n_dims = self.noise_var.shape[0]
        u = self.cov_factor.reshape(n_dims, -1, self.cov_factor.shape[1])
        t = self.cov_diag.reshape(n_dims, -1)[:, 0]
        return t[:, None, None] * np.eye(u.shape[1]) + u @ u.transpose(0, 2, 1)

    @functools.cached_property
    def cov_cholesky(self) -> np.ndarray:
        """Lower Cholesky factor of Sigma_w."""
        return np.linalg.cholesky(self.cov)

    def observed_factor(self, dims: np.ndarray) -> np.ndarray:
        """The rows of ``cov_factor`` of the weights of ``dims``, with no more columns than
        rows: shape (len(dims), n_basis, r') with ``U_o' U_o'^T = U_o U_o^T``.

        A likelihood only sees ``U_o U_o^T`` (the covariance of the observed weights), so
        observing 3 of 6 dimensions needs a factor of rank 3 M at most, whatever the rank of
        the whole factor; computed once per set of dimensions (a QR factorisation).
        """
        key = tuple(int(d) for d in dims)

        def make() -> np.ndarray:
            n_dims = self.noise_var.shape[0]
            u = self.cov_factor.reshape(n_dims, -1, self.cov_factor.shape[1])[list(key)]
            rows = u.reshape(-1, u.shape[-1])
            if rows.shape[1] > rows.shape[0]:
                rows = compress_factor(rows)  # row by row: the units may differ
            factor = rows.reshape(len(key), u.shape[1], -1)
            factor.setflags(write=False)  # shared by threads: read, never written
            return factor

        return cached_on(self, "_observed_factors", key, make)


@dataclass(frozen=True, eq=False)
class ProMPModel:
    """Primitives learned over one layout of modalities, with their shared settings.

    ``sample_period`` is the recording period (s) that converts alpha to durations;
    ``report`` says what the fit chose from the data and by which rule (JSON-ready).
    """

    layout: Layout
    settings: Settings
    sample_period: float
    primitives: tuple[Primitive, ...]
    report: Mapping = field(default_factory=dict)

    @functools.cached_property
    def basis(self) -> RBFBasis:
        return self.settings.basis

    @functools.cached_property
    def phase_basis(self) -> PhaseBasisCache:
        """Basis values at observed times, cached per duration (see :class:`PhaseBasisCache`)."""
        return PhaseBasisCache(self.basis)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.primitives)

    @property
    def n_dims(self) -> int:
        return self.layout.n_dims

    def primitive(self, name: str) -> Primitive:
        for p in self.primitives:
            if p.name == name:
                return p
        raise ValueError(f"unknown primitive {name!r}; the model has {list(self.names)}")


def estimate_noise(
    fits: WeightFits,
    times: Sequence[np.ndarray],
    layout: Layout,
    settings: Settings,
) -> tuple[np.ndarray, np.ndarray]:
    """Observation noise per dimension, one level per modality (see the module docstring).

    Parameters
    ----------
    fits : WeightFits
        Fits of every demonstration (of every primitive).
    times : list of arrays, shape (n_j,)
        Their sample times, in the same order.

    Returns
    -------
    noise_var : array, shape (n_dims,)
        Pooled residual variance of the per-demonstration fits, with the regression's degrees
        of freedom removed, scaled by ``settings.noise_scale``, or ``settings.noise_std``
        squared where given; never below :data:`promp.scale.RELATIVE_FLOOR` times the
        modality's squared scale (``fits.scale``: a floor in the data's unit, not an absolute
        one).
    noise_tau : array, shape (n_dims,)
        Correlation time (s) of an Ornstein-Uhlenbeck noise with the residuals' pooled lag-one
        autocorrelation ``rho`` at the mean sample step ``dt``: ``-dt / log(rho)``; 0 (white)
        when ``rho <= 0`` or ``settings.noise_correlation`` is off.
    """
    sse, lagged = fits.sse, fits.lagged  # sums of r_i^2 and of r_i r_(i-1)
    dof = np.maximum(sum(fits.dof), 1.0)
    # the residuals' step: a demonstration's duration over its steps (they are evenly spaced
    # in phase, :mod:`promp.weights`); the median over demonstrations, so one with a long
    # logging pause does not stretch the correlation time of them all
    dt = float(np.median([(t[-1] - t[0]) / (t.shape[0] - 1) for t in times]))
    noise_var = sse / dof
    noise_tau = np.zeros(layout.n_dims)
    for modality in layout.modalities:
        dims = layout.dims([modality.name])
        rho = float(lagged[dims].sum() / max(sse[dims].sum(), 1e-300))
        if settings.noise_correlation and 0.0 < rho < 1.0:
            noise_tau[dims] = -dt / np.log(rho)
        if modality.name in settings.noise_std:
            noise_var[dims] = settings.noise_std[modality.name] ** 2
        else:
            noise_var[dims] = noise_var[dims].mean() * settings.noise_scale**2
    return np.maximum(noise_var, RELATIVE_FLOOR * fits.scale), noise_tau


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


def sample_period_of(demos: Sequence[Demonstration]) -> float:
    """The recording period of a set of demonstrations: the median of their median steps."""
    return float(np.median([d.sample_period for d in demos]))


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


def fit_with(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
    alpha_models: bool = True,
) -> ProMPModel:
    """:func:`promp.learn.fit` with every setting given (no choice) and the sample period
    ``dt`` (s); without ``alpha_models`` the primitives have no Eq. 7 models (they are not
    needed to recognise with the "ml" alpha)."""
    return fit_parts(dataset, layout, settings, dt, alpha_models)[0]


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
