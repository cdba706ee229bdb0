"""Recognition, conditioning and prediction (paper Eqs. 5-8).

From the first samples of a movement, observed in any subset of the modalities:

* :func:`recognise` scores every primitive k and candidate time modulation alpha by the log
  marginal likelihood of the observation (Eq. 6),
  ``log N(y_o | Phi_o mu_k, Phi_o Sigma_k Phi_o^T + Sigma_noise)``, and returns the chosen
  primitive, its alpha, a posterior probability per primitive and the table of scores. Alpha is
  either the maximum-likelihood candidate among the primitive's training alphas ("ml", with an
  optional continuous refinement) or the Eq. 7 regression from the early displacement
  ("model").
* :func:`condition` updates the weight distribution on the observed samples (Eq. 8) with
  Cholesky solves, in weight space or observation space, whichever is smaller.
* :func:`predict` gives the mean and standard deviation over [0, t_f] of every modality,
  observed or not: the cross-covariance of the weights predicts the unobserved ones.

Likelihoods exploit the structure of the prior covariance, ``diag(t) + U U^T``: the diagonal
part keeps the dimensions independent, so with the determinant lemma and Woodbury's identity
each score only needs M x M factorisations per dimension and one r x r factorisation
(r = number of training demonstrations), never the n_o x n_o observation covariance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.linalg import cho_solve, solve_triangular
from scipy.optimize import minimize_scalar
from scipy.special import logsumexp

from promp import alpha_model
from promp.data import Demonstration
from promp.model import Primitive, ProMPModel
from promp.timing import check_alpha, duration_from_alpha, n_samples_from_alpha

AlphaMethod = Literal["ml", "model"]
LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True, eq=False)
class Observation:
    """The early part of a movement, in some of the model's modalities.

    Parameters
    ----------
    times : array, shape (n_observed,)
        Seconds; ``times[0]`` is the start of the movement.
    values : array, shape (n_observed, n_observed_dims)
        The columns of ``modalities``, in the layout's order (angles unwrapped).
    modalities : tuple of str
    """

    times: np.ndarray
    values: np.ndarray
    modalities: tuple[str, ...]

    def __post_init__(self) -> None:
        times = np.asarray(self.times, dtype=float)
        values = np.asarray(self.values, dtype=float)
        if times.ndim != 1 or times.shape[0] == 0:
            raise ValueError("the observation is empty: observe at least one sample")
        if values.ndim != 2 or values.shape[0] != times.shape[0]:
            raise ValueError(
                f"observation values must have shape ({times.shape[0]}, n_dims), got {values.shape}"
            )
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
            raise ValueError("the observation contains NaN or infinite values")
        if np.any(np.diff(times) <= 0):
            raise ValueError("observation times must be strictly increasing")
        if not self.modalities:
            raise ValueError("the observation names no modality")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "modalities", tuple(self.modalities))

    @property
    def n_observed(self) -> int:
        return int(self.times.shape[0])

    @property
    def elapsed(self) -> np.ndarray:
        """Seconds since the start of the movement, shape (n_observed,)."""
        return self.times - self.times[0]

    @classmethod
    def from_demo(
        cls, model: ProMPModel, demo: Demonstration, n_observed: int, modalities: Sequence[str]
    ) -> Observation:
        """The first ``n_observed`` samples of ``demo`` in ``modalities``."""
        if n_observed < 1:
            raise ValueError(f"n_observed must be >= 1, got {n_observed}")
        if n_observed > demo.n_samples:
            raise ValueError(
                f"cannot observe {n_observed} samples of a {demo.n_samples}-sample demonstration"
            )
        dims = observed_dims(model, modalities)
        values = model.layout.extract(demo)[:n_observed, dims]
        return cls(demo.times[:n_observed], values, tuple(modalities))


def observed_dims(model: ProMPModel, modalities: Sequence[str]) -> np.ndarray:
    """Model dimensions of ``modalities`` (raises ValueError on unknown names)."""
    return model.layout.dims(modalities)


def _check_observation(model: ProMPModel, obs: Observation) -> np.ndarray:
    dims = observed_dims(model, obs.modalities)
    if obs.values.shape[1] != dims.shape[0]:
        raise ValueError(
            f"the observation has {obs.values.shape[1]} columns but modalities "
            f"{list(obs.modalities)} have {dims.shape[0]}"
        )
    return dims


def _blocks(vector: np.ndarray, n_dims: int) -> np.ndarray:
    return vector.reshape(n_dims, -1)


def log_likelihoods(
    model: ProMPModel, primitive: Primitive, obs: Observation, alphas: np.ndarray
) -> np.ndarray:
    """Log marginal likelihood of ``obs`` under ``primitive`` for each alpha (Eq. 6).

    Candidates whose predicted duration is shorter than the observation get ``-inf``.

    Parameters
    ----------
    alphas : array, shape (n_candidates,)

    Returns
    -------
    array, shape (n_candidates,)
    """
    alphas = np.atleast_1d(np.asarray(alphas, dtype=float))
    check_alpha(alphas)
    dims = _check_observation(model, obs)
    m = model.basis.n_basis
    durations = duration_from_alpha(alphas, model.sample_period, model.settings.s_bar)
    valid = obs.elapsed[-1] <= durations * (1.0 + 1e-9)
    out = np.full(alphas.shape, -np.inf)
    if not valid.any():
        return out
    z = obs.elapsed[None, :] / durations[valid, None]  # (A, n)
    psi = model.basis(z.reshape(-1)).reshape(z.shape[0], z.shape[1], m)  # (A, n, M)
    y = obs.values  # (n, Do)
    n_obs, n_do = y.shape

    mu = primitive.mean_at(alphas[valid]).reshape(-1, model.n_dims, m)[:, dims]  # (A, Do, M)
    t = _blocks(primitive.cov_diag, model.n_dims)[dims]  # (Do, M)
    u = primitive.cov_factor.reshape(model.n_dims, m, -1)[dims]  # (Do, M, r)
    s2 = primitive.noise_var[dims]  # (Do,)

    gram = np.einsum("anm,anl->aml", psi, psi)  # (A, M, M)
    proj = np.einsum("anm,nd->adm", psi, y)  # (A, Do, M)
    g_mu = np.einsum("aml,adl->adm", gram, mu)  # (A, Do, M)
    g = (proj - g_mu) / s2[None, :, None]  # Psi^T r / s2
    rr = ((y**2).sum(axis=0)[None, :] - 2 * (proj * mu).sum(-1) + (g_mu * mu).sum(-1)) / s2
    gs = gram[:, None] / s2[None, :, None, None]  # (A, Do, M, M)
    c = gs + np.eye(m) / t[None, :, :, None]  # diag(1/t) + G / s2
    chol = np.linalg.cholesky(c)
    logdet_c = 2.0 * np.log(np.diagonal(chol, axis1=-2, axis2=-1)).sum(-1)  # (A, Do)
    gs_u = gs @ u[None]  # (A, Do, M, r)
    rhs = np.concatenate([g[..., None], gs_u], axis=-1)
    sol = np.linalg.solve(c, rhs)  # C^{-1} [g, Gs U]
    c_g, c_gsu = sol[..., 0], sol[..., 1:]
    h = g - np.einsum("admk,adk->adm", gs, c_g)  # Psi^T B^{-1} r
    hu = gs_u - gs @ c_gsu  # Psi^T B^{-1} Psi U
    utu = np.einsum("dmr,admq->arq", u, hu)  # (A, r, r)
    v = np.einsum("dmr,adm->ar", u, h)  # (A, r)
    r = u.shape[-1]
    q = np.eye(r) + utu
    chol_q = np.linalg.cholesky(q)
    logdet_q = 2.0 * np.log(np.diagonal(chol_q, axis1=-2, axis2=-1)).sum(-1)
    w = np.linalg.solve(q, v[..., None])[..., 0]
    quad = (rr - (g * c_g).sum(-1)).sum(-1) - (v * w).sum(-1)
    logdet_b = n_obs * np.log(s2)[None, :] + np.log(t).sum(-1)[None, :] + logdet_c
    logdet = logdet_b.sum(-1) + logdet_q
    out[valid] = -0.5 * (quad + logdet + n_obs * n_do * LOG_2PI)
    return out


@dataclass(frozen=True, eq=False)
class Recognition:
    """Which primitive the observation belongs to, and at which speed.

    Attributes
    ----------
    index : int
        Index of the recognised primitive in ``model.primitives``.
    primitive : str
    alpha : float
        Time modulation of the recognised primitive.
    probabilities : array, shape (n_primitives,)
        Posterior probability of each primitive (uniform prior over primitives; for "ml", each
        primitive's likelihood is averaged over its candidate alphas).
    candidates : tuple of arrays
        Per primitive, the candidate alphas scored.
    log_likelihoods : tuple of arrays
        Per primitive, the log-likelihood of each candidate (the table of Eq. 6).
    alpha_method : str
    """

    index: int
    primitive: str
    alpha: float
    probabilities: np.ndarray
    candidates: tuple[np.ndarray, ...]
    log_likelihoods: tuple[np.ndarray, ...]
    alpha_method: str


def model_alpha(model: ProMPModel, primitive: Primitive, obs: Observation) -> float:
    """Alpha from the early displacement of the observed modalities (Eq. 7), kept within the
    range where the observation fits in the predicted duration."""
    n_obs = int(round(obs.elapsed[-1] / model.sample_period)) + 1
    deltas = {}
    for name in obs.modalities:
        cols = _modality_columns(model, obs, name)
        deltas[name] = obs.values[-1, cols] - obs.values[0, cols]
    alpha = alpha_model.combine(primitive.alpha_models, deltas, n_obs)
    lo = 0.5 * float(primitive.alphas.min())
    hi = 2.0 * float(primitive.alphas.max())
    # The predicted movement must be at least as long as what has been observed.
    longest_fit = model.settings.s_bar / (obs.elapsed[-1] / model.sample_period + 1.0)
    return float(np.clip(alpha, lo, min(hi, longest_fit)))


def _modality_columns(model: ProMPModel, obs: Observation, name: str) -> np.ndarray:
    """Columns of ``obs.values`` that hold modality ``name``."""
    start = 0
    for observed in model.layout.modalities:
        if observed.name not in obs.modalities:
            continue
        width = len(observed.columns)
        if observed.name == name:
            return np.arange(start, start + width)
        start += width
    raise ValueError(f"modality {name!r} is not observed")


def _refine_alpha(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    alphas: np.ndarray,
    scores: np.ndarray,
) -> float:
    """Continuous maximum of the likelihood around the best candidate alpha."""
    best = int(np.argmax(scores))
    order = np.sort(alphas[np.isfinite(scores)])
    i = int(np.searchsorted(order, alphas[best]))
    lo = order[i - 1] if i > 0 else 0.9 * order[0]
    hi = order[i + 1] if i + 1 < len(order) else 1.1 * order[-1]
    longest_fit = model.settings.s_bar / (obs.elapsed[-1] / model.sample_period + 1.0)
    hi = min(hi, longest_fit)
    if hi <= lo:
        return float(alphas[best])
    result = minimize_scalar(
        lambda a: -log_likelihoods(model, primitive, obs, np.array([a]))[0],
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-3 * (hi - lo)},
    )
    if result.success and -result.fun > scores[best]:
        return float(result.x)
    return float(alphas[best])


def recognise(
    model: ProMPModel,
    obs: Observation,
    alpha_method: AlphaMethod = "ml",
    refine: bool = False,
    evidence: Literal["marginal", "max"] = "marginal",
) -> Recognition:
    """Recognise the primitive and its time modulation from an early observation (Eq. 6).

    Raises
    ------
    ValueError
        Unknown modality, empty observation, or an observation longer than every candidate
        duration of every primitive.
    """
    _check_observation(model, obs)
    if alpha_method not in ("ml", "model"):
        raise ValueError(f"alpha_method must be 'ml' or 'model', got {alpha_method!r}")
    candidates = []
    tables = []
    evidence_rule = evidence
    scores_k = np.empty(len(model.primitives))
    for k, prim in enumerate(model.primitives):
        if alpha_method == "ml":
            alphas = prim.alphas
        else:
            alphas = np.array([model_alpha(model, prim, obs)])
        scores = log_likelihoods(model, prim, obs, alphas)
        candidates.append(alphas)
        tables.append(scores)
        if evidence_rule == "max":
            scores_k[k] = float(np.max(scores))
        else:
            scores_k[k] = logsumexp(scores) - math.log(len(scores))
    evidence = scores_k
    if not np.isfinite(evidence).any():
        raise ValueError(
            "the observation lasts longer than every candidate duration of every primitive"
        )
    probabilities = np.exp(evidence - logsumexp(evidence))
    index = int(np.argmax(evidence))
    alphas, scores = candidates[index], tables[index]
    alpha = float(alphas[int(np.argmax(scores))])
    if refine and alpha_method == "ml" and np.isfinite(scores).sum() >= 1:
        alpha = _refine_alpha(model, model.primitives[index], obs, alphas, scores)
    return Recognition(
        index=index,
        primitive=model.primitives[index].name,
        alpha=alpha,
        probabilities=probabilities,
        candidates=tuple(candidates),
        log_likelihoods=tuple(tables),
        alpha_method=alpha_method,
    )


@dataclass(frozen=True, eq=False)
class Gaussian:
    """A distribution over weights: ``mean`` (n_weights,), ``cov`` (n_weights, n_weights)."""

    mean: np.ndarray
    cov: np.ndarray


def observation_basis(model: ProMPModel, obs: Observation, alpha: float) -> np.ndarray:
    """Basis at the observed phases for ``alpha``, shape (n_observed, n_basis).

    Raises
    ------
    ValueError
        If the observation lasts longer than the duration ``alpha`` predicts.
    """
    check_alpha(alpha)
    duration = float(duration_from_alpha(alpha, model.sample_period, model.settings.s_bar))
    if obs.elapsed[-1] > duration * (1.0 + 1e-9):
        raise ValueError(
            f"the observation ({obs.elapsed[-1]:.3f} s) is longer than the predicted duration "
            f"({duration:.3f} s) for alpha = {alpha:.4g}"
        )
    return model.basis(obs.elapsed / duration)


def condition(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    alpha: float,
    prior: Gaussian | None = None,
) -> Gaussian:
    """Posterior weight distribution given the observation (Eq. 8).

    Batch update on all observed samples of all observed modalities, with Cholesky solves:
    in observation space (n_observed * n_observed_dims unknowns) or weight space (n_weights),
    whichever is smaller. Returns a new :class:`Gaussian`; nothing is modified.
    """
    dims = _check_observation(model, obs)
    psi = observation_basis(model, obs, alpha)  # (n, M)
    m = model.basis.n_basis
    mean = primitive.mean_at(alpha) if prior is None else prior.mean
    cov = primitive.cov if prior is None else prior.cov
    n_dims = model.n_dims
    s2 = primitive.noise_var[dims]
    mu_blocks = _blocks(mean, n_dims)
    resid = obs.values - psi @ mu_blocks[dims].T  # (n, Do)
    w_idx = (dims[:, None] * m + np.arange(m)[None, :]).reshape(-1)  # observed weights
    n_obs, n_do = resid.shape
    if n_obs * n_do <= w_idx.shape[0] * 2 and n_obs * n_do < mean.shape[0]:
        # Observation space: S = A Sigma_OO A^T + R, A = blockdiag(psi) over observed dims.
        cov_ow = cov[w_idx]  # (Do*M, P)
        a_cov = np.einsum("nm,dmp->dnp", psi, cov_ow.reshape(n_do, m, -1))  # (Do, n, P)
        a_cov = a_cov.reshape(n_do * n_obs, -1)
        s = np.einsum("dnem,km->dnek", a_cov[:, w_idx].reshape(n_do, n_obs, n_do, m), psi)
        s = s.reshape(n_do * n_obs, n_do * n_obs)
        s[np.diag_indices_from(s)] += np.repeat(s2, n_obs)
        chol = np.linalg.cholesky(s)
        v = solve_triangular(chol, a_cov, lower=True, check_finite=False)  # L^-1 A Sigma
        e = solve_triangular(chol, resid.T.reshape(-1), lower=True, check_finite=False)
        new_mean = mean + v.T @ e
        new_cov = cov - v.T @ v
    else:
        # Weight space: Sigma' = L (I + L^T K L)^-1 L^T with K = A^T R^-1 A.
        chol = primitive.cov_cholesky if prior is None else np.linalg.cholesky(cov)
        gram = psi.T @ psi
        l_o = chol[w_idx].reshape(n_do, m, -1)  # rows of L for the observed weights
        kl = np.einsum("ml,dlp->dmp", gram, l_o) / s2[:, None, None]
        inner = np.eye(mean.shape[0]) + np.einsum("dmp,dmq->pq", l_o, kl)
        chol_inner = np.linalg.cholesky(inner)
        e = solve_triangular(chol_inner, chol.T, lower=True, check_finite=False)  # (P, P)
        b = np.einsum("nm,nd->dm", psi, resid) / s2[:, None]  # A^T R^-1 r, observed blocks
        lb = np.einsum("dmp,dm->p", l_o, b)  # L^T A^T R^-1 r
        new_cov = e.T @ e
        new_mean = mean + chol @ cho_solve((chol_inner, True), lb, check_finite=False)
    new_cov = 0.5 * (new_cov + new_cov.T)
    return Gaussian(mean=new_mean, cov=new_cov)


@dataclass(frozen=True, eq=False)
class Prediction:
    """Trajectory distribution over [0, t_f] of every dimension.

    Attributes
    ----------
    times : array, shape (n_points,)
        Seconds from the start of the movement; ``times[-1]`` is the predicted duration.
    mean, std : array, shape (n_points, n_dims)
    alpha : float
    """

    times: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    alpha: float

    @property
    def duration(self) -> float:
        return float(self.times[-1])


def predict(
    model: ProMPModel, dist: Gaussian | Primitive, alpha: float, n_points: int | None = None
) -> Prediction:
    """Mean and standard deviation of every dimension over the predicted duration.

    ``n_points`` defaults to the predicted number of samples, ``round(s_bar / alpha)``.
    The standard deviation is that of the trajectory distribution (observation noise
    excluded).
    """
    n_samples = float(n_samples_from_alpha(alpha, model.settings.s_bar))
    n = max(int(round(n_samples)), 2) if n_points is None else int(n_points)
    if n < 2:
        raise ValueError(f"n_points must be >= 2, got {n}")
    duration = float(duration_from_alpha(alpha, model.sample_period, model.settings.s_bar))
    z = np.linspace(0.0, 1.0, n)
    psi = model.basis(z)
    n_dims = model.n_dims
    m = model.basis.n_basis
    if isinstance(dist, Primitive):
        dist = Gaussian(mean=dist.mean_at(alpha), cov=dist.cov)
    mean_blocks = _blocks(dist.mean, n_dims)
    mean = psi @ mean_blocks.T
    cov = dist.cov
    var = np.empty((n, n_dims))
    for d in range(n_dims):
        block = cov[d * m : (d + 1) * m, d * m : (d + 1) * m]
        var[:, d] = np.einsum("nm,mk,nk->n", psi, block, psi)
    std = np.sqrt(np.maximum(var, 0.0))
    return Prediction(times=z * duration, mean=mean, std=std, alpha=float(alpha))
