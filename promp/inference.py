"""Likelihood, conditioning and prediction (paper Eqs. 5-8).

From the first samples of a movement, observed in any subset of the modalities:

* :func:`log_likelihoods` scores a primitive at candidate time modulations alpha by the log
  marginal likelihood of the observation (Eq. 6),
  ``log N(y_o | Phi_o mu_k, Phi_o Sigma_k Phi_o^T + Sigma_noise)`` (recognition, which
  integrates it over alpha, is :mod:`promp.recognition`).
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

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve, solve_triangular

from promp.data import Demonstration, check_values
from promp.model import Primitive, ProMPModel
from promp.timing import check_alpha, duration_from_alpha, n_samples_from_alpha

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
        check_values(times, values, "the observation")
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


def check_observation(model: ProMPModel, obs: Observation) -> np.ndarray:
    dims = observed_dims(model, obs.modalities)
    if obs.values.shape[1] != dims.shape[0]:
        raise ValueError(
            f"the observation has {obs.values.shape[1]} columns but modalities "
            f"{list(obs.modalities)} have {dims.shape[0]}"
        )
    return dims


def logsumexp(values: np.ndarray) -> float:
    """``log(sum(exp(values)))``, stable, ``-inf`` for an empty or all ``-inf`` input.

    (scipy's version costs ~0.2 ms of checks per call, too much for a 60 Hz scrub loop.)
    """
    values = np.asarray(values, dtype=float)
    if values.size == 0:
        return -math.inf
    top = float(values.max())
    if not math.isfinite(top):
        return top
    return top + math.log(float(np.exp(values - top).sum()))


def _blocks(vector: np.ndarray, n_dims: int) -> np.ndarray:
    return vector.reshape(n_dims, -1)


def whiten(elapsed: np.ndarray, tau: float, x: np.ndarray) -> tuple[np.ndarray, float]:
    """Apply the whitening transform of an Ornstein-Uhlenbeck noise along axis -2.

    The noise of one dimension is ``sigma^2 K`` with ``K_ij = exp(-|t_i - t_j| / tau)``; its
    precision is tridiagonal, ``K^-1 = W^T W`` with ``(W x)_0 = x_0`` and
    ``(W x)_i = (x_i - rho_i x_(i-1)) / sqrt(1 - rho_i^2)``, ``rho_i = exp(-(t_i - t_(i-1)) /
    tau)``, so that ``x^T K^-1 x = |W x|^2``. ``tau = 0`` is white noise.

    Parameters
    ----------
    elapsed : array, shape (n,)
    x : array, shape (..., n, k)

    Returns
    -------
    (W x, log det K)
    """
    if tau <= 0 or x.shape[-2] < 2:
        return x, 0.0
    rho = np.exp(-np.diff(elapsed) / tau)
    scale = np.sqrt(1.0 - rho**2)
    out = np.array(x, dtype=float, copy=True)
    out[..., 1:, :] = (x[..., 1:, :] - rho[:, None] * x[..., :-1, :]) / scale[:, None]
    return out, float(2.0 * np.log(scale).sum())


def _noise_groups(primitive: Primitive, dims: np.ndarray) -> dict[float, np.ndarray]:
    """Observed dimensions grouped by noise correlation time: {tau: positions in dims}."""
    taus = primitive.noise_tau[dims]
    return {float(tau): np.nonzero(taus == tau)[0] for tau in np.unique(taus)}


def _group_statistics(
    primitive: Primitive, obs: Observation, dims: np.ndarray, psi: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Whitened sufficient statistics of the observation, per noise group.

    Parameters
    ----------
    psi : array, shape (A, n, M)
        Basis at the observed phases for each candidate alpha.

    Returns
    -------
    eigval : array, shape (A, n_groups, M)
    eigvec : array, shape (A, n_groups, M, M)
        Eigendecomposition of ``Psi^T K^-1 Psi`` per candidate and noise group.
    group : array, shape (Do,)
        Noise group of each observed dimension.
    proj : array, shape (A, Do, M)
        ``Psi^T K^-1 y`` per dimension.
    yy : array, shape (Do,)
        ``y^T K^-1 y``.
    logdet_k : array, shape (Do,)
        ``log det K``.
    """
    groups = _noise_groups(primitive, dims)
    n_cand, _, m = psi.shape
    n_do = dims.shape[0]
    eigval = np.empty((n_cand, len(groups), m))
    eigvec = np.empty((n_cand, len(groups), m, m))
    group = np.empty(n_do, dtype=int)
    proj = np.empty((n_cand, n_do, m))
    yy = np.empty(n_do)
    logdet_k = np.empty(n_do)
    for index, (tau, cols) in enumerate(groups.items()):
        psi_w, logdet = whiten(obs.elapsed, tau, psi)
        y_w, _ = whiten(obs.elapsed, tau, obs.values[:, cols])
        eigval[:, index], eigvec[:, index] = np.linalg.eigh(psi_w.transpose(0, 2, 1) @ psi_w)
        group[cols] = index
        proj[:, cols] = (psi_w.transpose(0, 2, 1) @ y_w).transpose(0, 2, 1)
        yy[cols] = (y_w**2).sum(axis=0)
        logdet_k[cols] = logdet
    return np.maximum(eigval, 0.0), eigvec, group, proj, yy, logdet_k


@dataclass(frozen=True)
class _Woodbury:
    """Terms of the marginal likelihood and the posterior for A candidate alphas.

    With ``Sigma_w = T + U U^T`` (``T = t_d I`` within each dimension, see promp.model),
    ``R = s2 K`` the noise and ``B = Psi T Psi^T + R`` (block-diagonal over dimensions), the
    observation covariance is ``S = B + V V^T`` with ``V = A U``. Every per-dimension matrix is
    diagonal in the eigenbasis of ``Psi^T K^-1 Psi = vec diag(e) vec^T``; the low-rank part
    leaves one r x r matrix ``Q = I + V^T B^-1 V``.
    """

    eigvec: np.ndarray  # (A, n_groups, M, M) eigenvectors, per noise group
    group: np.ndarray  # (Do,) noise group of each observed dimension
    c: np.ndarray  # (A, Do, M) eigenvalues of C = I / t + Psi^T R^-1 Psi
    g_hat: np.ndarray  # (A, Do, M) vec^T Psi^T R^-1 r
    rr: np.ndarray  # (A, Do) r^T R^-1 r
    h_hat: np.ndarray  # (A, Do, M) vec^T Psi^T B^-1 r
    h_diag: np.ndarray  # (A, Do, M) eigenvalues of H = Psi^T B^-1 Psi
    u_hat: np.ndarray  # (A, Do * M, r) vec^T U, stacked over dimensions
    utu: np.ndarray  # (A, r, r) U^T H U = Q - I
    v: np.ndarray  # (A, r) U^T Psi^T B^-1 r
    logdet_b: float  # log det B without the C terms
    t: np.ndarray  # (Do,)


def _woodbury(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    dims: np.ndarray,
    alphas: np.ndarray,
    durations: np.ndarray,
) -> _Woodbury:
    m = model.basis.n_basis
    psi = model.phase_basis(obs.elapsed, durations)  # (A, n, M)
    mu = primitive.mean_at(alphas).reshape(-1, model.n_dims, m)[:, dims]  # (A, Do, M)
    t = _blocks(primitive.cov_diag, model.n_dims)[dims, 0]  # (Do,)
    u = primitive.cov_factor.reshape(model.n_dims, m, -1)[dims]  # (Do, M, r)
    s2 = primitive.noise_var[dims]  # (Do,)
    eigval, eigvec, group, proj, yy, logdet_k = _group_statistics(primitive, obs, dims, psi)
    n_cand, r = psi.shape[0], u.shape[-1]
    lam = eigval[:, group] / s2[None, :, None]  # eigenvalues of Psi^T R^-1 Psi
    c = 1.0 / t[None, :, None] + lam
    # Rotate the prior mean, the projections and U into each group's eigenbasis.
    vt_mu = np.empty_like(mu)
    vt_proj = np.empty_like(proj)
    u_hat = np.empty((n_cand, dims.shape[0], m, r))
    for index in range(eigvec.shape[1]):
        cols = np.nonzero(group == index)[0]
        vec_t = eigvec[:, index].transpose(0, 2, 1)  # (A, M, M)
        vt_mu[:, cols] = (vec_t @ mu[:, cols].transpose(0, 2, 1)).transpose(0, 2, 1)
        vt_proj[:, cols] = (vec_t @ proj[:, cols].transpose(0, 2, 1)).transpose(0, 2, 1)
        # One (M x M)(M x Dg r) product per candidate rather than one per dimension.
        u_cols = u[cols].transpose(1, 0, 2).reshape(m, -1)
        u_hat[:, cols] = (vec_t @ u_cols).reshape(n_cand, m, cols.shape[0], r).transpose(0, 2, 1, 3)
    u_hat = u_hat.reshape(n_cand, -1, r)  # stacked over dimensions
    g_hat = vt_proj / s2[None, :, None] - lam * vt_mu
    rr = (yy[None, :] - 2.0 * (vt_proj * vt_mu).sum(-1)) / s2 + (lam * vt_mu**2).sum(-1)
    # Woodbury: B^-1 = R^-1 - R^-1 Psi C^-1 Psi^T R^-1, so in the eigenbasis
    # Psi^T B^-1 r = g / (t c) and Psi^T B^-1 Psi = e / (s2 t c).
    h_hat = g_hat / (t[None, :, None] * c)
    h_diag = lam / (t[None, :, None] * c)
    utu = (u_hat * h_diag.reshape(n_cand, -1, 1)).transpose(0, 2, 1) @ u_hat
    v = (u_hat.transpose(0, 2, 1) @ h_hat.reshape(n_cand, -1, 1))[..., 0]
    n_obs = obs.n_observed
    logdet_b = float((n_obs * np.log(s2) + logdet_k + m * np.log(t)).sum())
    return _Woodbury(eigvec, group, c, g_hat, rr, h_hat, h_diag, u_hat, utu, v, logdet_b, t)


def log_likelihoods(
    model: ProMPModel, primitive: Primitive, obs: Observation, alphas: np.ndarray
) -> np.ndarray:
    """Log marginal likelihood of ``obs`` under ``primitive`` for each alpha (Eq. 6).

    ``log N(y | A mu, S)`` with ``S = A Sigma_w A^T + R``, by the determinant lemma and
    Woodbury's identity on the structure of ``Sigma_w`` (see :class:`_Woodbury`): M x M work per
    dimension, diagonal in a shared eigenbasis, plus one r x r Cholesky factorisation.
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
    dims = check_observation(model, obs)
    durations = duration_from_alpha(alphas, model.sample_period, model.settings.s_bar)
    valid = obs.elapsed[-1] <= durations * (1.0 + 1e-9)
    out = np.full(alphas.shape, -np.inf)
    if not valid.any():
        return out
    w = _woodbury(model, primitive, obs, dims, alphas[valid], durations[valid])
    q = w.utu + np.eye(w.utu.shape[-1])
    chol_q = np.linalg.cholesky(q)
    logdet_q = 2.0 * np.log(np.diagonal(chol_q, axis1=-2, axis2=-1)).sum(-1)
    z = np.linalg.solve(chol_q, w.v[..., None])[..., 0]  # v^T Q^-1 v = |L_q^-1 v|^2
    quad = (w.rr - (w.g_hat**2 / w.c).sum(-1)).sum(-1) - (z**2).sum(-1)
    logdet = w.logdet_b + np.log(w.c).sum(axis=(-1, -2)) + logdet_q
    out[valid] = -0.5 * (quad + logdet + obs.values.size * LOG_2PI)
    return out


@dataclass(frozen=True, eq=False)
class Gaussian:
    """A distribution over weights: ``mean`` (n_weights,), ``cov`` (n_weights, n_weights)."""

    mean: np.ndarray
    cov: np.ndarray

    def blocks(self, n_dims: int) -> np.ndarray:
        """Covariance of each dimension's weights, shape (n_dims, n_basis, n_basis)."""
        m = self.mean.shape[0] // n_dims
        return np.stack([self.cov[d * m : (d + 1) * m, d * m : (d + 1) * m] for d in range(n_dims)])


class Posterior:
    """The weight distribution after conditioning (Eq. 8).

    Attributes
    ----------
    mean : array, shape (n_weights,)
    cov : array, shape (n_weights, n_weights)
        The full covariance, computed on first use (predictions only need the blocks).
    """

    def __init__(self, mean: np.ndarray, blocks: np.ndarray, full: Callable[[], np.ndarray]):
        self.mean = mean
        self._blocks = blocks
        self._full = full

    def blocks(self, n_dims: int) -> np.ndarray:
        """Covariance of each dimension's weights, shape (n_dims, n_basis, n_basis)."""
        if self._blocks.shape[0] != n_dims:
            raise ValueError(f"the posterior has {self._blocks.shape[0]} dimensions, not {n_dims}")
        return self._blocks

    @functools.cached_property
    def cov(self) -> np.ndarray:
        return self._full()


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
) -> Posterior:
    """Posterior weight distribution given the observation (Eq. 8).

    A batch update on all observed samples of all observed modalities. Without ``prior``, the
    primitive's prior at ``alpha`` is used and the update exploits its structure (Woodbury's
    identity on ``Sigma_w = T + U U^T``, see :class:`_Woodbury`): the mean and each
    dimension's covariance block cost O(D M^2 r); the full covariance is computed on demand
    with the dense update below. With an explicit ``prior`` (any Gaussian), the dense update
    runs directly: in observation space or weight space, whichever is smaller, with Cholesky
    solves. Returns a new object; nothing is modified.

    Raises
    ------
    ValueError
        Unknown modalities, alpha <= 0, or an observation longer than alpha's duration.
    """
    dims = check_observation(model, obs)
    observation_basis(model, obs, alpha)  # validates alpha against the observation
    if prior is not None:
        mean, cov = _condition_dense(model, primitive, obs, alpha, prior, None)
        return Posterior(mean, Gaussian(mean, cov).blocks(model.n_dims), lambda: cov)
    duration = float(duration_from_alpha(alpha, model.sample_period, model.settings.s_bar))
    w = _woodbury(model, primitive, obs, dims, np.array([alpha]), np.array([duration]))
    n_dims, m = model.n_dims, model.basis.n_basis
    u_all = primitive.cov_factor.reshape(n_dims, m, -1)  # (D, M, r)
    t_all = _blocks(primitive.cov_diag, n_dims)[:, 0]  # (D,)
    u_o, t_o = u_all[dims], w.t
    vec = w.eigvec[0][w.group]  # (Do, M, M)
    big_h = vec @ (w.h_diag[0][..., None] * vec.transpose(0, 2, 1))  # H = Psi^T B^-1 Psi
    small_h = (vec @ w.h_hat[0][..., None])[..., 0]  # h = Psi^T B^-1 r
    hu = big_h @ u_o  # (Do, M, r)
    utu = w.utu[0]
    chol_q = np.linalg.cholesky(utu + np.eye(utu.shape[0]))
    # Sigma A^T S^-1 r with S^-1 = B^-1 - B^-1 V Q^-1 V^T B^-1:  A^T S^-1 r = h - H U Q^-1 v.
    kappa = small_h - hu @ cho_solve((chol_q, True), w.v[0], check_finite=False)
    mean = _blocks(primitive.mean_at(alpha), n_dims) + u_all @ np.einsum("dmr,dm->r", u_o, kappa)
    mean[dims] += t_o[:, None] * kappa
    # Diagonal blocks of Sigma - Sigma A^T S^-1 A Sigma, with Sigma_de = t_d I [d = e] + U_d U_e^T.
    wg = u_all @ utu  # Sigma_(d,O) A^T B^-1 V
    wg[dims] += t_o[:, None, None] * hu
    # Sigma_(d,O) H Sigma_(O,d) = U_d (Q - I) U_d^T + t_d H_d U_d U_d^T (from wg)
    #                            + t_d^2 H_d + t_d U_d U_d^T H_d          (observed d only)
    correction = wg @ u_all.transpose(0, 2, 1)
    t3 = t_o[:, None, None]
    correction[dims] += t3**2 * big_h + t3 * (u_o @ hu.transpose(0, 2, 1))
    z = np.linalg.solve(chol_q[None], wg.transpose(0, 2, 1))  # L_q^-1 (W G)^T, (D, r, M)
    prior_blocks = t_all[:, None, None] * np.eye(m) + u_all @ u_all.transpose(0, 2, 1)
    blocks = prior_blocks - correction + z.transpose(0, 2, 1) @ z
    blocks = 0.5 * (blocks + blocks.transpose(0, 2, 1))
    flat_mean = mean.reshape(-1)

    def full() -> np.ndarray:
        prior_at = Gaussian(primitive.mean_at(alpha), primitive.cov)
        return _condition_dense(model, primitive, obs, alpha, prior_at, primitive.cov_cholesky)[1]

    return Posterior(flat_mean, blocks, full)


def _condition_dense(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    alpha: float,
    prior: Gaussian,
    cov_cholesky: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """The dense Kalman update of a Gaussian weight prior: (mean, covariance)."""
    dims = check_observation(model, obs)
    psi = observation_basis(model, obs, alpha)  # (n, M)
    m = model.basis.n_basis
    mean, cov = prior.mean, prior.cov
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
        lag = np.abs(obs.elapsed[:, None] - obs.elapsed[None, :])
        for i, (var, tau) in enumerate(zip(s2, primitive.noise_tau[dims], strict=True)):
            block = slice(i * n_obs, (i + 1) * n_obs)
            s[block, block] += var * (np.exp(-lag / tau) if tau > 0 else np.eye(n_obs))
        chol = np.linalg.cholesky(s)
        v = solve_triangular(chol, a_cov, lower=True, check_finite=False)  # L^-1 A Sigma
        e = solve_triangular(chol, resid.T.reshape(-1), lower=True, check_finite=False)
        new_mean = mean + v.T @ e
        new_cov = cov - v.T @ v
    else:
        # Weight space: Sigma' = L (I + L^T K L)^-1 L^T with K = A^T R^-1 A.
        chol = cov_cholesky if cov_cholesky is not None else np.linalg.cholesky(cov)
        gram = np.empty((n_do, m, m))
        b = np.empty((n_do, m))  # A^T R^-1 r, observed blocks
        for tau, cols in _noise_groups(primitive, dims).items():
            psi_w, _ = whiten(obs.elapsed, tau, psi)
            resid_w, _ = whiten(obs.elapsed, tau, resid[:, cols])
            gram[cols] = psi_w.T @ psi_w
            b[cols] = (psi_w.T @ resid_w).T / s2[cols, None]
        l_o = chol[w_idx].reshape(n_do, m, -1)  # rows of L for the observed weights
        kl = (gram @ l_o) / s2[:, None, None]
        n_w = mean.shape[0]
        inner = np.eye(n_w) + l_o.reshape(-1, n_w).T @ kl.reshape(-1, n_w)
        chol_inner = np.linalg.cholesky(inner)
        # (contiguous right-hand side: scipy is ten times slower on a transposed view)
        e = solve_triangular(
            chol_inner, np.ascontiguousarray(chol.T), lower=True, check_finite=False
        )
        lb = l_o.reshape(-1, n_w).T @ b.reshape(-1)  # L^T A^T R^-1 r
        new_cov = e.T @ e
        new_mean = mean + chol @ cho_solve((chol_inner, True), lb, check_finite=False)
    return new_mean, 0.5 * (new_cov + new_cov.T)


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
    model: ProMPModel,
    dist: Gaussian | Posterior | Primitive,
    alpha: float,
    n_points: int | None = None,
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
    if isinstance(dist, Primitive):
        mean_w, blocks = dist.mean_at(alpha), dist.cov_blocks
    else:
        mean_w, blocks = dist.mean, dist.blocks(n_dims)
    mean = psi @ _blocks(mean_w, n_dims).T
    var = (((psi[None] @ blocks) * psi[None]).sum(axis=-1)).T  # diag(psi Sigma_dd psi^T)
    std = np.sqrt(np.maximum(var, 0.0))
    return Prediction(times=z * duration, mean=mean, std=std, alpha=float(alpha))
