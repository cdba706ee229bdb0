"""Learning multi-modal ProMPs from demonstrations (paper Eqs. 1-4).

Per demonstration, the weights of every dimension are fitted by ridge regression on the phase
basis (Eq. 2); per primitive, their mean and covariance define the prior over trajectories
(Eqs. 3-4). With fewer demonstrations than weights the sample covariance is singular, so it is
shrunk towards its diagonal with the Schafer-Strimmer (2005) estimate of the optimal intensity
("target D": correlations are shrunk, variances kept). The result is stored as a diagonal plus
a low-rank factor, ``Sigma_w = diag(cov_diag) + cov_factor @ cov_factor.T``, which is always SPD
and which inference exploits (determinant lemma / Woodbury).

Observation noise is a property of the sensor, not of a primitive: per modality, it is the mean
squared fit residual of its dimensions over the demonstrations of all primitives, with the
degrees of freedom of the regression removed, unless overridden in :class:`Settings`. (Per-
primitive noise levels would bias recognition towards the primitive fitted most tightly: the
normalising term ``n_o log sigma^2`` of the likelihood then outweighs the data.)
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from promp.alpha_model import AlphaModel
from promp.basis import RBFBasis
from promp.data import Demonstration, Layout
from promp.timing import alpha_from_duration, demo_phases

# Relative floor on the variances of the diagonal part, so Sigma_w stays SPD when a weight never
# varies across demonstrations (e.g. every demonstration starts at the same point).
VARIANCE_FLOOR = 1e-10


@dataclass(frozen=True)
class Settings:
    """Learning settings (the documented defaults are the ones the evaluation uses).

    Parameters
    ----------
    n_basis : int
        M, basis functions per dimension.
    width : float
        RBF standard deviation as a multiple of the spacing of the centres.
    ridge : float
        Ridge strength of the per-demonstration weight regression, relative to the mean
        diagonal of ``Phi^T Phi``.
    s_bar : float
        Reference length of the time modulation (alpha = s_bar / n_samples).
    shrinkage : float or None
        Covariance shrinkage intensity in [0, 1]; None estimates it from the data.
    noise_std : mapping of str to float
        Observation noise standard deviation per modality, in the modality's unit; modalities
        not listed use the estimate from the fit residuals.
    noise_scale : float
        Multiplies every estimated noise standard deviation.
    alpha_coupling : bool
        Learn how the shape depends on the speed: the weights are regressed on log(alpha) and
        the prior at a candidate alpha is the conditional Gaussian (see :class:`Primitive`).
    """

    n_basis: int = 20
    width: float = 1.0
    ridge: float = 1e-6
    s_bar: float = 100.0
    shrinkage: float | None = None
    noise_std: Mapping[str, float] = field(default_factory=dict)
    noise_scale: float = 1.0
    alpha_coupling: bool = True

    def __post_init__(self) -> None:
        RBFBasis(self.n_basis, self.width)  # validates both
        if not np.isfinite(self.ridge) or self.ridge < 0:
            raise ValueError(f"ridge must be >= 0, got {self.ridge}")
        if not np.isfinite(self.s_bar) or self.s_bar <= 0:
            raise ValueError(f"s_bar must be positive, got {self.s_bar}")
        if self.shrinkage is not None and not 0.0 <= self.shrinkage <= 1.0:
            raise ValueError(f"shrinkage must be in [0, 1] or None, got {self.shrinkage}")
        for name, std in self.noise_std.items():
            if not np.isfinite(std) or std <= 0:
                raise ValueError(f"noise_std[{name!r}] must be positive, got {std}")
        if not np.isfinite(self.noise_scale) or self.noise_scale <= 0:
            raise ValueError(f"noise_scale must be positive, got {self.noise_scale}")
        object.__setattr__(self, "noise_std", dict(self.noise_std))

    @property
    def basis(self) -> RBFBasis:
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
    alphas : array, shape (n_demos,)
        Time modulation of each training demonstration.
    alpha_models : mapping of str to AlphaModel
        Eq. 7 model per modality.
    shrinkage : float
        The covariance shrinkage intensity used.
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
    shrinkage: float
    log_alpha_mean: float = 0.0
    alpha_slope: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.alpha_slope is None:
            object.__setattr__(self, "alpha_slope", np.zeros_like(self.mean))

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
    def cov_cholesky(self) -> np.ndarray:
        """Lower Cholesky factor of Sigma_w."""
        return np.linalg.cholesky(self.cov)


@dataclass(frozen=True, eq=False)
class ProMPModel:
    """Primitives learned over one layout of modalities, with their shared settings.

    ``sample_period`` is the recording period (s) that converts alpha to durations.
    """

    layout: Layout
    settings: Settings
    sample_period: float
    primitives: tuple[Primitive, ...]

    @property
    def basis(self) -> RBFBasis:
        return self.settings.basis

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


def fit_weights(
    basis: RBFBasis, times: np.ndarray, values: np.ndarray, ridge: float
) -> tuple[np.ndarray, np.ndarray]:
    """Ridge regression of one demonstration on the basis (paper Eq. 2).

    Parameters
    ----------
    times : array, shape (n_samples,)
    values : array, shape (n_samples, n_dims)

    Returns
    -------
    weights : array, shape (n_dims * n_basis,)
        Dimension-major.
    sse : array, shape (n_dims,)
        Sum of squared residuals per dimension.
    """
    phi = basis(demo_phases(times))
    gram = phi.T @ phi
    lam = ridge * np.trace(gram) / gram.shape[0]
    chol = np.linalg.cholesky(gram + (lam + 1e-12) * np.eye(gram.shape[0]))
    w = np.linalg.solve(chol.T, np.linalg.solve(chol, phi.T @ values))  # (n_basis, n_dims)
    sse = ((values - phi @ w) ** 2).sum(axis=0)
    return w.T.reshape(-1), sse


def shrinkage_intensity(weights: np.ndarray) -> float:
    """Schafer-Strimmer optimal shrinkage of correlations towards zero (target D).

    Parameters
    ----------
    weights : array, shape (n_demos, n_weights)
    """
    n = weights.shape[0]
    centred = weights - weights.mean(axis=0)
    std = centred.std(axis=0, ddof=1)
    ok = std > 1e-12 * max(float(std.max()), 1e-300)
    x = centred[:, ok] / std[ok]
    if x.shape[1] < 2 or n < 3:
        return 1.0
    corr = x.T @ x / (n - 1)
    # Var of each sample correlation: n / (n - 1)^3 * sum_k (x_ki x_kj - mean_k x_ki x_kj)^2.
    second = (x**2).T @ (x**2)  # sum_k x_ki^2 x_kj^2
    mean_prod = corr * (n - 1) / n
    var_corr = n / (n - 1) ** 3 * (second - n * mean_prod**2)
    off = ~np.eye(corr.shape[0], dtype=bool)
    denom = float((corr[off] ** 2).sum())
    if denom <= 0:
        return 1.0
    return float(np.clip(var_corr[off].sum() / denom, 0.0, 1.0))


def _resample_uniform(demo: Demonstration, values: np.ndarray, dt: float) -> np.ndarray:
    """Values on a uniform grid of period ``dt`` from the first sample (for Eq. 7)."""
    n = int(round(demo.duration / dt)) + 1
    grid = demo.times[0] + dt * np.arange(n)
    grid[-1] = min(grid[-1], demo.times[-1])
    return np.column_stack([np.interp(grid, demo.times, v) for v in values.T])


def estimate_noise(
    demos: Sequence[Demonstration], layout: Layout, settings: Settings
) -> np.ndarray:
    """Observation noise variance per dimension, shape (n_dims,): one level per modality.

    The pooled residual variance of the per-demonstration fits (see the module docstring),
    scaled by ``settings.noise_scale``, or ``settings.noise_std`` where given.
    """
    basis = settings.basis
    sse = np.zeros(layout.n_dims)
    dof = 0.0
    for demo in demos:
        sse += fit_weights(basis, demo.times, layout.extract(demo), settings.ridge)[1]
        dof += max(demo.n_samples - basis.n_basis, 1)
    noise_var = sse / dof
    for modality in layout.modalities:
        dims = layout.dims([modality.name])
        if modality.name in settings.noise_std:
            noise_var[dims] = settings.noise_std[modality.name] ** 2
        else:
            noise_var[dims] = noise_var[dims].mean() * settings.noise_scale**2
    return np.maximum(noise_var, 1e-20)


def fit_primitive(
    name: str,
    demos: Sequence[Demonstration],
    layout: Layout,
    settings: Settings,
    sample_period: float,
    noise_var: np.ndarray,
) -> Primitive:
    """Learn one primitive from its demonstrations (>= 2), given the observation noise."""
    if len(demos) < 2:
        raise ValueError(
            f"primitive {name!r} has {len(demos)} demonstration(s); at least 2 are needed "
            "to learn a distribution"
        )
    basis = settings.basis
    n_dims = layout.n_dims
    weights = np.empty((len(demos), n_dims * basis.n_basis))
    alphas = np.empty(len(demos))
    trajectories = []
    for j, demo in enumerate(demos):
        values = layout.extract(demo)
        weights[j] = fit_weights(basis, demo.times, values, settings.ridge)[0]
        alphas[j] = alpha_from_duration(demo.duration, sample_period, settings.s_bar)
        trajectories.append(_resample_uniform(demo, values, sample_period))

    mean = weights.mean(axis=0)
    centred = weights - mean
    log_alphas = np.log(alphas)
    log_alpha_mean = float(log_alphas.mean())
    a_c = log_alphas - log_alpha_mean
    dof = len(demos) - 1
    slope = np.zeros_like(mean)
    if settings.alpha_coupling and len(demos) >= 3 and float(a_c @ a_c) > 1e-12:
        slope = centred.T @ a_c / float(a_c @ a_c)
        centred = centred - np.outer(a_c, slope)
        dof = len(demos) - 2
    variances = (centred**2).sum(axis=0) / dof
    lam = shrinkage_intensity(centred) if settings.shrinkage is None else settings.shrinkage
    # Floor per dimension block, relative to that dimension's typical weight variance.
    block = variances.reshape(n_dims, basis.n_basis)
    floor = VARIANCE_FLOOR * np.maximum(block.mean(axis=1, keepdims=True), 1e-30)
    cov_diag = lam * variances + np.broadcast_to(floor, block.shape).reshape(-1)
    cov_factor = np.sqrt((1.0 - lam) / dof) * centred.T

    alpha_models = {
        m.name: AlphaModel.fit([t[:, layout.dims([m.name])] for t in trajectories], alphas)
        for m in layout.modalities
    }
    return Primitive(
        name=name,
        mean=mean,
        cov_diag=cov_diag,
        cov_factor=cov_factor,
        noise_var=np.array(noise_var, dtype=float),
        alphas=alphas,
        alpha_models=alpha_models,
        shrinkage=lam,
        log_alpha_mean=log_alpha_mean,
        alpha_slope=slope,
    )


def sample_period_of(demos: Sequence[Demonstration]) -> float:
    """The recording period of a set of demonstrations: the median of their median steps."""
    return float(np.median([d.sample_period for d in demos]))


def fit(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings | None = None,
    sample_period: float | None = None,
) -> ProMPModel:
    """Learn one primitive per entry of ``dataset`` ({primitive name: demonstrations}).

    Raises
    ------
    ValueError
        No primitive, a primitive with fewer than 2 demonstrations, a demonstration without
        the layout's columns.
    """
    settings = settings or Settings()
    if not dataset:
        raise ValueError("no primitive to learn: the dataset is empty")
    all_demos = [d for demos in dataset.values() for d in demos]
    dt = sample_period if sample_period is not None else sample_period_of(all_demos)
    if not np.isfinite(dt) or dt <= 0:
        raise ValueError(f"sample_period must be positive, got {dt}")
    for name, demos in dataset.items():
        if len(demos) < 2:
            raise ValueError(
                f"primitive {name!r} has {len(demos)} demonstration(s); at least 2 are needed "
                "to learn a distribution"
            )
    noise_var = estimate_noise(all_demos, layout, settings)
    primitives = tuple(
        fit_primitive(name, demos, layout, settings, dt, noise_var)
        for name, demos in dataset.items()
    )
    return ProMPModel(layout=layout, settings=settings, sample_period=dt, primitives=primitives)
