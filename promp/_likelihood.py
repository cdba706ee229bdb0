"""The likelihood of an observation under a primitive (paper Eq. 6), exploiting the structure.

``log N(y_o | Phi_o mu_k, Phi_o Sigma_k Phi_o^T + Sigma_noise)`` for many candidate time
modulations at once. The prior covariance is ``Sigma_w = diag(t) + U U^T`` (``t`` constant
within each dimension's block, ``U`` of rank r = the number of training demonstrations), and the
noise of each dimension is an Ornstein-Uhlenbeck process whose precision is tridiagonal. The
diagonal part keeps the dimensions independent, so with the determinant lemma and Woodbury's
identity a score needs M x M work per dimension, diagonal in one eigenbasis per noise group, and
one r x r factorisation; never the n_o x n_o observation covariance. The same terms give the
posterior (Eq. 8, :func:`promp.inference.condition`).

The terms that do not depend on the noise level (the basis at the observed phases, the
whitened statistics and their eigendecompositions, the rotated prior) are computed once
(:func:`rotate`), so the likelihood at several noise levels costs little more than at one
(:func:`log_likelihoods_scaled`, which the automatic choice of the noise scale uses).

When ``U`` is square (a primitive with as many demonstrations as observed weights), the same
likelihood is cheaper in weight space (:mod:`promp._weight_space`: one bordered Cholesky
factorisation per candidate, no eigendecomposition); :func:`log_likelihoods_scaled` takes the
cheaper form by their operation counts. Both are checked against the dense formula.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from promp import _weight_space
from promp.incremental import IncrementalStatistics, whitened_sums
from promp.model import Primitive, ProMPModel
from promp.noise import noise_groups, whiten  # noqa: F401  (re-exported)
from promp.observation import Observation, check_observation
from promp.timing import check_alpha, duration_from_alpha

LOG_2PI = math.log(2.0 * math.pi)


def logsumexp(values: np.ndarray) -> float:
    """``log(sum(exp(values)))`` over every entry, stable; ``-inf`` for an empty or all
    ``-inf`` input: :func:`logsumexp_rows` of one row."""
    return float(logsumexp_rows(np.ravel(values)))


def logsumexp_rows(values: np.ndarray) -> np.ndarray:
    """``log(sum(exp(values)))`` along the last axis, stable: shape (...,) for ``values`` of
    shape (..., n); ``-inf`` for an empty or all ``-inf`` row, the row's maximum for a row
    holding ``+inf`` or NaN.

    (scipy's version costs ~0.2 ms of checks per call, too much for a 60 Hz scrub loop.)
    """
    values = np.asarray(values, dtype=float)
    if values.shape[-1] == 0:
        return np.full(values.shape[:-1], -np.inf)
    top = values.max(axis=-1, keepdims=True)
    finite = np.isfinite(top)
    if finite.all():
        return (top + np.log(np.exp(values - top).sum(axis=-1, keepdims=True)))[..., 0]
    safe = np.where(finite, top, 0.0)  # rows without a finite maximum: their maximum
    with np.errstate(divide="ignore", invalid="ignore"):
        out = safe + np.log(np.exp(values - safe).sum(axis=-1, keepdims=True))
    return np.where(finite, out, top)[..., 0]


def per_dimension(vector: np.ndarray, n_dims: int) -> np.ndarray:
    """A dimension-major weight vector (n_dims * M,) as rows, shape (n_dims, M)."""
    return vector.reshape(n_dims, -1)


@dataclass(frozen=True)
class Rotated:
    """The noise-level-free terms of the likelihood for A candidate alphas.

    With ``Psi^T K^-1 Psi = vec diag(e) vec^T`` per noise group (``K``: the noise correlation,
    ``R = s2 K``), the projections ``Psi^T K^-1 r`` of the residual ``r = y - Psi mu`` and
    ``U`` are rotated into that eigenbasis.
    """

    eigval: np.ndarray  # (A, Do, M) e of each observed dimension's group
    eigvec: np.ndarray  # (A, n_groups, M, M) eigenvectors, per noise group
    group: np.ndarray  # (Do,) noise group of each observed dimension
    vt_proj: np.ndarray  # (A, Do, M) vec^T Psi^T K^-1 r
    u_hat: np.ndarray  # (A, Do * M, r) vec^T U, stacked over dimensions
    rr: np.ndarray  # (A, Do) r^T K^-1 r
    logdet_k: np.ndarray  # (Do,) log det K
    t: np.ndarray  # (Do,) the diagonal of Sigma_w in each observed dimension
    n_obs: int


@dataclass(frozen=True)
class Woodbury:
    """Terms of the marginal likelihood and the posterior for L noise levels x A candidate
    alphas (the leading axes of every array below but ``eigvec``, ``group`` and ``t``).

    With ``Sigma_w = T + U U^T`` (``T = t_d I`` within each dimension, see promp.model),
    ``R = s2 K`` the noise and ``B = Psi T Psi^T + R`` (block-diagonal over dimensions), the
    observation covariance is ``S = B + V V^T`` with ``V = A U``. Every per-dimension matrix is
    diagonal in the eigenbasis of ``Psi^T K^-1 Psi = vec diag(e) vec^T``; the low-rank part
    leaves one r x r matrix ``Q = I + V^T B^-1 V``.
    """

    eigvec: np.ndarray  # (A, n_groups, M, M) eigenvectors, per noise group
    group: np.ndarray  # (Do,) noise group of each observed dimension
    c: np.ndarray  # (L, A, Do, M) eigenvalues of C = I / t + Psi^T R^-1 Psi
    g_hat: np.ndarray  # (L, A, Do, M) vec^T Psi^T R^-1 r
    rr: np.ndarray  # (L, A, Do) r^T R^-1 r
    h_hat: np.ndarray  # (L, A, Do, M) vec^T Psi^T B^-1 r
    h_diag: np.ndarray  # (L, A, Do, M) eigenvalues of H = Psi^T B^-1 Psi
    utu: np.ndarray  # (L, A, r, r) U^T H U = Q - I
    v: np.ndarray  # (L, A, r) U^T Psi^T B^-1 r
    logdet_b: np.ndarray  # (L,) log det B without the C terms
    t: np.ndarray  # (Do,)


def rotate(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    dims: np.ndarray,
    alphas: np.ndarray,
    durations: np.ndarray,
    compress: bool = True,
    statistics: IncrementalStatistics | None = None,
) -> Rotated:
    """The terms of :class:`Rotated`: the whitened sums (:mod:`promp._statistics`, extended
    from ``statistics`` when given), the eigendecomposition of each noise group's
    ``Psi^T K^-1 Psi``, and the rotations into its eigenbasis.

    ``compress``: use the observed rows of ``U`` with at most as many columns as rows
    (:meth:`promp.model.Primitive.observed_factor`; enough for the likelihood); off, the
    columns of ``U`` itself (the posterior of the unobserved weights needs them).
    """
    m = model.basis.n_basis
    t = per_dimension(primitive.cov_diag, model.n_dims)[dims, 0]  # (Do,)
    if compress:
        u = primitive.observed_factor(dims)  # (Do, M, r)
    else:
        u = primitive.cov_factor.reshape(model.n_dims, m, -1)[dims]
    sums = whitened_sums(model, primitive, obs, dims, alphas, durations, statistics)
    eigval, eigvec = np.linalg.eigh(sums.gram)  # (A, n_groups, M), (A, n_groups, M, M)
    eigval = np.maximum(eigval, 0.0)
    group, proj, rr, logdet_k = sums.group, sums.proj, sums.rr, sums.logdet_k
    n_cand, r = alphas.shape[0], u.shape[-1]
    vt_proj = np.empty_like(proj)
    u_hat = np.empty((n_cand, dims.shape[0], m, r))
    for index in range(eigvec.shape[1]):
        cols = np.nonzero(group == index)[0]
        vec_t = eigvec[:, index].transpose(0, 2, 1)  # (A, M, M)
        vt_proj[:, cols] = (vec_t @ proj[:, cols].transpose(0, 2, 1)).transpose(0, 2, 1)
        # One (M x M)(M x Dg r) product per candidate rather than one per dimension.
        u_cols = u[cols].transpose(1, 0, 2).reshape(m, -1)
        u_hat[:, cols] = (vec_t @ u_cols).reshape(n_cand, m, cols.shape[0], r).transpose(0, 2, 1, 3)
    return Rotated(
        eigval[:, group], eigvec, group, vt_proj, u_hat.reshape(n_cand, -1, r), rr, logdet_k, t,
        obs.n_observed,
    )  # fmt: skip


def woodbury(rot: Rotated, s2: np.ndarray) -> Woodbury:
    """The terms of :class:`Woodbury` at the noise variances ``s2``, shape (L, Do): one row
    per noise level."""
    t = rot.t[None, None, :, None]
    vt_proj = rot.vt_proj[None]  # (1, A, Do, M)
    n_levels, n_cand, m = s2.shape[0], vt_proj.shape[1], vt_proj.shape[-1]
    s2_b = s2[:, None, :, None]
    lam = rot.eigval[None] / s2_b  # eigenvalues of Psi^T R^-1 Psi, (L, A, Do, M)
    c = 1.0 / t + lam
    g_hat = vt_proj / s2_b
    rr = rot.rr[None] / s2[:, None, :]
    # Woodbury: B^-1 = R^-1 - R^-1 Psi C^-1 Psi^T R^-1, so in the eigenbasis
    # Psi^T B^-1 r = g / (t c) and Psi^T B^-1 Psi = e / (s2 t c).
    h_hat = g_hat / (t * c)
    h_diag = lam / (t * c)
    u_hat = rot.u_hat[None]  # (1, A, Do M, r)
    # U^T H U as X^T X with X = H^1/2 U (h >= 0): one product of two equal stacks, which
    # numpy hands to BLAS faster than the broadcast one.
    x = u_hat * np.sqrt(h_diag.reshape(n_levels, n_cand, -1, 1))
    utu = x.swapaxes(-1, -2) @ x
    v = (u_hat.swapaxes(-1, -2) @ h_hat.reshape(n_levels, n_cand, -1, 1))[..., 0]
    logdet_b = (rot.n_obs * np.log(s2) + rot.logdet_k + m * np.log(rot.t)).sum(-1)
    return Woodbury(rot.eigvec, rot.group, c, g_hat, rr, h_hat, h_diag, utu, v, logdet_b, rot.t)


def _log_likelihood(w: Woodbury, n_values: int) -> np.ndarray:
    """``log N(y | A mu, S)`` per noise level and candidate, shape (L, A).

    ``log det Q`` and ``v^T Q^-1 v`` come from one Cholesky factorisation of the bordered
    matrix ``[[Q, v], [v^T, d]]``: its last row is ``[(L_q^-1 v)^T, sqrt(d - v^T Q^-1 v)]``;
    ``d = v^T v + 1`` exceeds ``v^T Q^-1 v`` (``Q >= I``), so it stays positive definite.
    """
    r = w.utu.shape[-1]
    vv = (w.v**2).sum(-1)
    bordered = np.empty(w.utu.shape[:-2] + (r + 1, r + 1))
    bordered[..., :r, :r] = w.utu + np.eye(r)
    bordered[..., :r, r] = bordered[..., r, :r] = w.v
    bordered[..., r, r] = vv + 1.0
    chol = np.linalg.cholesky(bordered)
    diag = np.diagonal(chol, axis1=-2, axis2=-1)
    logdet_q = 2.0 * np.log(diag[..., :r]).sum(-1)
    v_q_v = (chol[..., r, :r] ** 2).sum(-1)  # |L_q^-1 v|^2
    quad = (w.rr - (w.g_hat**2 / w.c).sum(-1)).sum(-1) - v_q_v
    logdet = w.logdet_b[:, None] + np.log(w.c).sum(axis=(-1, -2)) + logdet_q
    return -0.5 * (quad + logdet + n_values * LOG_2PI)


def log_likelihoods_scaled(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    alphas: np.ndarray,
    noise_factors: np.ndarray,
    statistics: IncrementalStatistics | None = None,
) -> np.ndarray:
    """Log marginal likelihood of ``obs`` for each alpha and each noise level (Eq. 6).

    Parameters
    ----------
    alphas : array, shape (n_candidates,)
    noise_factors : array, shape (n_levels, n_dims)
        Each row multiplies the primitive's noise variance of every model dimension.
    statistics : IncrementalStatistics, optional
        What the likelihood kept of the observation's first samples, for an observation
        that grows (:class:`promp.incremental.IncrementalStatistics`): only the new samples'
        terms are computed. The same numbers to round-off.

    Returns
    -------
    array, shape (n_levels, n_candidates)
        ``-inf`` where the candidate's duration is shorter than the observation.

    In weight space (:mod:`promp._weight_space`) when that costs less than the Woodbury form
    (:func:`promp._weight_space.cheaper_than_woodbury`); the two agree to round-off.
    """
    alphas = np.atleast_1d(np.asarray(alphas, dtype=float))
    check_alpha(alphas)
    dims = check_observation(model, obs)
    durations = duration_from_alpha(alphas, model.sample_period, model.settings.s_bar)
    valid = obs.elapsed[-1] <= durations * (1.0 + 1e-9)
    factors = np.atleast_2d(np.asarray(noise_factors, dtype=float))
    out = np.full((factors.shape[0], alphas.shape[0]), -np.inf)
    if not valid.any():
        return out
    noise_var = primitive.noise_var[dims][None, :] * factors[:, dims]
    factor = primitive.observed_factor(dims)
    if _weight_space.cheaper_than_woodbury(factor.shape[0] * factor.shape[1], factor.shape[2]):
        out[:, valid] = _weight_space.log_likelihoods(
            model, primitive, obs, dims, alphas[valid], durations[valid], noise_var, statistics
        )
        return out
    rot = rotate(model, primitive, obs, dims, alphas[valid], durations[valid],
                 statistics=statistics)  # fmt: skip
    for level in range(noise_var.shape[0]):  # (one level at a time: smaller batches run faster)
        w = woodbury(rot, noise_var[level : level + 1])
        out[level, valid] = _log_likelihood(w, obs.values.size)[0]
    return out


def log_likelihoods(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    alphas: np.ndarray,
    statistics: IncrementalStatistics | None = None,
) -> np.ndarray:
    """Log marginal likelihood of ``obs`` under ``primitive`` for each alpha (Eq. 6).

    ``log N(y | A mu, S)`` with ``S = A Sigma_w A^T + R``, by the determinant lemma and
    Woodbury's identity on the structure of ``Sigma_w`` (see :class:`Woodbury`): M x M work per
    dimension, diagonal in a shared eigenbasis, plus one r x r Cholesky factorisation.
    Candidates whose predicted duration is shorter than the observation get ``-inf``.

    Parameters
    ----------
    alphas : array, shape (n_candidates,)
    statistics : IncrementalStatistics, optional
        For an observation that grows: see :func:`log_likelihoods_scaled`.

    Returns
    -------
    array, shape (n_candidates,)
    """
    ones = np.ones((1, model.n_dims))
    return log_likelihoods_scaled(model, primitive, obs, alphas, ones, statistics)[0]
