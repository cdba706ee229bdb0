"""The learned model: the settings it was fitted with, and one distribution over trajectories
per primitive (paper Eqs. 1-4).

:class:`Settings` are the choices a fit is made with: the basis (Eq. 1), the ridge of the
weights (Eq. 2), the covariance estimate, the observation noise and how the speed couples with
the shape; a setting left None is chosen from the training demonstrations
(:mod:`promp.selection`). A :class:`Primitive` is one movement's learned distribution over the
weights (Eqs. 3-4), stored as a diagonal plus a low-rank factor,
``Sigma_w = diag(cov_diag) + cov_factor @ cov_factor.T``; inference exploits that structure
(determinant lemma / Woodbury), and the diagonal is constant within each dimension's block,
which lets likelihoods share one eigendecomposition per dimension. A :class:`ProMPModel` holds
the primitives of one layout of modalities with their shared settings and sample period: what
:mod:`promp.io` saves and loads. They are learned by :func:`promp.learn.fit` (the settings
left open chosen first) over :mod:`promp.fitting` (every setting given).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from promp._recent import cached_on
from promp.alpha_model import AlphaModel
from promp.basis import PhaseBasisCache, RBFBasis
from promp.covariance import compress_factor
from promp.data import Layout
from promp.stillness import pause_bound

__all__ = [
    "FALLBACK", "SELECT_RULES", "Primitive", "ProMPModel", "Settings", "STILL_PARTS",
    "recognition_bandwidth",
]  # fmt: skip

# The reference settings: what a fit uses when it cannot choose (see promp.selection).
FALLBACK = {"n_basis": 7, "width": 1.0, "noise_scale": 1.5}
# How the others are chosen (promp.selection): closed-form leave-one-out, or inner folds.
SELECT_RULES = ("loo", "cv")


def recognition_bandwidth(name: str | None) -> float:
    """The bandwidth ``H`` of a recognition variant's name (:attr:`Settings.recognition`):
    ``"promp"`` is 1 (the primitive's one Gaussian), ``"mixture:H"`` the mixture over the
    training demonstrations at ``0 < H <= 1`` (:mod:`promp.evidence.mixture`).

    Raises
    ------
    ValueError
        Any other name.
    """
    if name is None:  # not chosen (a fit with every setting given): the ProMP
        return 1.0
    kind, colon, value = str(name).partition(":")
    if kind == "promp" and not colon:
        return 1.0
    try:
        bandwidth = float(value) if kind == "mixture" else float("nan")
    except ValueError:
        bandwidth = float("nan")
    if not 0.0 < bandwidth <= 1.0:  # (False for NaN)
        raise ValueError(f"recognition must be 'promp' or 'mixture:H' with 0 < H <= 1, got "
                         f"{name!r}")  # fmt: skip
    return bandwidth


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
    recognition : str or None
        How a primitive's evidence is scored (:func:`recognition_bandwidth`): ``"promp"``,
        its one Gaussian over the weights and the speed; ``"mixture:H"``, the mixture over its
        training demonstrations, each a kernel of bandwidth ``H`` around the demonstration
        (:mod:`promp.evidence.mixture`). None (the default): chosen from the training
        demonstrations with the other automatic settings
        (:mod:`promp.selection.recognition_choice`); a model whose settings still say None
        (fitted with every setting given) recognises with the ProMP. The conditioning is the
        ProMP's either way.
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
    recognition: str | None = None

    def __post_init__(self) -> None:
        if self.recognition is not None:
            recognition_bandwidth(self.recognition)  # validates it
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

    @property
    def chosen_by_fit(self) -> tuple[str, ...]:
        """Every setting a fit chooses from the data (None): the :attr:`automatic` ones, then
        the duration's temperature and the recognition variant (:func:`promp.learn.fit`,
        :func:`promp.learn.choose`)."""
        later = ("duration_temperature", "recognition")
        return self.automatic + tuple(name for name in later if getattr(self, name) is None)

    @property
    def to_choose(self) -> bool:
        """Whether a fit chooses anything from the data (:attr:`chosen_by_fit`)."""
        return bool(self.chosen_by_fit)

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


STILL_PARTS = ("lead", "pause", "trail")  # how a demonstration is still (Primitive.stillness)


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
    stillness : mapping of str to mapping of str to array, shape (n_demos,)
        Per modality in metres or radians, how each training demonstration is still (s):
        ``lead`` before its first moving sample, the longest ``pause`` inside it, ``trail``
        after its last moving sample (:func:`promp.stillness.still_parts`). Empty for a model
        whose file predates them: it is taken never to pause, its still ends unknown.
    region_scale : mapping of str to float
        Per modality, the factor on the radius of the predictive region of a new movement
        (:mod:`promp.region`) that makes it hold its stated share of the primitive's own
        demonstrations, each left out in turn (:mod:`promp.region_calibration`). A modality
        not listed (every one of a model whose file predates them) keeps the radius of the
        Gaussian, 1.
    residuals : array, shape (n_demos, n_weights), optional
        Each training demonstration's weights less the prior mean at its own speed (the
        regression on log alpha): the components of the mixture recognition
        (:mod:`promp.evidence.mixture`). None for a model whose file predates them (it
        recognises with the ProMP alone).
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
    stillness: Mapping[str, Mapping[str, np.ndarray]] = field(default_factory=dict)
    region_scale: Mapping[str, float] = field(default_factory=dict)
    residuals: np.ndarray | None = None

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
        shape = (np.shape(self.alphas)[0], np.shape(self.mean)[0])  # (n_demos, n_weights)
        if self.residuals is not None and np.shape(self.residuals) != shape:
            raise ValueError(f"primitive {self.name!r}: residuals must be (n_demos, n_weights) "
                             f"= {shape}, got {np.shape(self.residuals)}")  # fmt: skip

    def still(self, part: str, modalities: Sequence[str]) -> np.ndarray | None:
        """``part`` ("lead", "pause" or "trail") of each training demonstration when
        ``modalities`` are watched (s, shape (n_demos,)): the shortest of theirs (the inputs
        are still together only while each is: an upper bound of that demonstration's); None
        when none of them was learned."""
        learned = [np.asarray(self.stillness[m][part], dtype=float) for m in modalities
                   if m in self.stillness]  # fmt: skip
        return np.min(np.vstack(learned), axis=0) if learned else None

    def pause(self, modalities: Sequence[str]) -> float:
        """The longest pause this primitive is taken to make when ``modalities`` are watched
        (s): the robust upper bound (:func:`promp.stillness.pause_bound`) of its demonstrations'
        (:meth:`still`); 0 when none was learned."""
        pauses = self.still("pause", modalities)
        return 0.0 if pauses is None else pause_bound(pauses.tolist())

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
    """Primitives learned over one layout of modalities, with their shared settings: what
    :func:`promp.learn.fit` returns and :mod:`promp.io` saves and loads.

    Attributes
    ----------
    layout : Layout
        The modalities, ``n_dims`` columns in all.
    settings : Settings
        The settings the primitives were fitted with (every automatic one chosen).
    sample_period : float
        The recording period (s) that converts alpha to durations.
    primitives : tuple of Primitive
        One per movement, in the order of the dataset's primitives.
    report : mapping
        What the fit chose from the data and by which rule (JSON-ready).
    """

    layout: Layout
    settings: Settings
    sample_period: float
    primitives: tuple[Primitive, ...]
    report: Mapping = field(default_factory=dict)

    def __post_init__(self) -> None:
        if recognition_bandwidth(self.settings.recognition) < 1.0:
            lacking = [p.name for p in self.primitives if p.residuals is None]
            if lacking:
                raise ValueError(
                    f"recognition {self.settings.recognition!r} needs every primitive's "
                    f"training residuals; {lacking} have none (a model file before version 5)"
                )

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
