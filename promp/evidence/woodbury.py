"""The likelihood of Eq. 6 through Woodbury's identity, and the posterior of Eq. 8 from the same
terms.

``log N(y_o | Phi_o mu_k, Phi_o Sigma_k Phi_o^T + Sigma_noise)`` for many candidate time
modulations at once. The prior covariance is ``Sigma_w = diag(t) + U U^T`` (``t`` constant
within each dimension's block, ``U`` of rank r = the number of training demonstrations), and the
noise of each dimension is an Ornstein-Uhlenbeck process whose precision is tridiagonal. The
diagonal part keeps the dimensions independent, so with the determinant lemma and Woodbury's
identity a score needs M x M work per dimension, diagonal in one eigenbasis per noise group, and
one r x r factorisation; never the n_o x n_o observation covariance. The same terms give the
posterior (Eq. 8, :func:`posterior`).

Everything is read from the whitened sums (:mod:`promp.evidence.sums`); the terms that do not
depend on the noise level (their eigendecompositions, the rotated prior) are computed once
(:func:`rotate`), so the likelihood at several noise levels costs little more than at one
(:func:`log_likelihoods`, which the automatic choice of the noise scale uses). When ``U`` is
square the weight-space form costs less (:mod:`promp.evidence.weight_space`); both are checked
against the dense formula.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve, solve_triangular

from promp.evidence.sums import WhitenedSums
from promp.inference import per_dimension
from promp.model import Primitive

__all__ = [
    "LOG_2PI", "Rotated", "Woodbury", "log_likelihoods", "posterior", "rotate", "woodbury"
]  # fmt: skip

LOG_2PI = math.log(2.0 * math.pi)


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
    sums: WhitenedSums, primitive: Primitive, dims: np.ndarray, compress: bool = True
) -> Rotated:
    """The terms of :class:`Rotated` from the whitened ``sums`` of the observed ``dims``: the
    eigendecomposition of each noise group's ``Psi^T K^-1 Psi`` and the rotations into its
    eigenbasis.

    ``compress``: use the observed rows of ``U`` with at most as many columns as rows
    (:meth:`promp.model.Primitive.observed_factor`; enough for the likelihood); off, the
    columns of ``U`` itself (the posterior of the unobserved weights needs them).
    """
    n_dims, m = primitive.noise_var.shape[0], sums.gram.shape[-1]
    t = per_dimension(primitive.cov_diag, n_dims)[dims, 0]  # (Do,)
    if compress:
        u = primitive.observed_factor(dims)  # (Do, M, r)
    else:
        u = primitive.cov_factor.reshape(n_dims, m, -1)[dims]
    eigval, eigvec = np.linalg.eigh(sums.gram)  # (A, n_groups, M), (A, n_groups, M, M)
    eigval = np.maximum(eigval, 0.0)
    group, proj = sums.group, sums.proj
    n_cand, r = proj.shape[0], u.shape[-1]
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
        eigval[:, group], eigvec, group, vt_proj, u_hat.reshape(n_cand, -1, r), sums.rr,
        sums.logdet_k, t, sums.n,
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


def log_likelihoods(
    sums: WhitenedSums, primitive: Primitive, dims: np.ndarray, noise_var: np.ndarray
) -> np.ndarray:
    """``log N(y | A mu, S)`` per noise level and candidate, shape (L, A), from the whitened
    ``sums`` of the observed ``dims`` and their noise variance at each level ``noise_var``
    (L, Do)."""
    rot = rotate(sums, primitive, dims)
    out = np.empty((noise_var.shape[0], sums.proj.shape[0]))
    for level in range(noise_var.shape[0]):  # (one level at a time: smaller batches run faster)
        w = woodbury(rot, noise_var[level : level + 1])
        out[level] = _log_likelihood(w, sums.n * dims.shape[0])[0]
    return out


def posterior(
    sums: WhitenedSums, primitive: Primitive, dims: np.ndarray, alpha: float
) -> tuple[np.ndarray, np.ndarray]:
    """The posterior of the weights given the observation whose whitened ``sums`` at the one
    speed ``alpha`` (A = 1) are given (Eq. 8): its mean (n_weights,) and the covariance of
    each dimension's weights (n_dims, M, M), from the terms of the likelihood (Woodbury's
    identity on ``Sigma_w = T + U U^T``): O(D M^2 r) (:meth:`promp.evidence.Evidence.condition`)."""
    rot = rotate(sums, primitive, dims, compress=False)
    w = woodbury(rot, primitive.noise_var[dims][None, :])
    n_dims, m = primitive.noise_var.shape[0], sums.gram.shape[-1]
    u_all = primitive.cov_factor.reshape(n_dims, m, -1)  # (D, M, r)
    t_all = per_dimension(primitive.cov_diag, n_dims)[:, 0]  # (D,)
    u_o, t_o = u_all[dims], w.t
    vec = w.eigvec[0][w.group]  # (Do, M, M)
    # one noise level, one alpha: index [0, 0]
    big_h = vec @ (w.h_diag[0, 0][..., None] * vec.transpose(0, 2, 1))  # H = Psi^T B^-1 Psi
    small_h = (vec @ w.h_hat[0, 0][..., None])[..., 0]  # h = Psi^T B^-1 r
    hu = big_h @ u_o  # (Do, M, r)
    utu = w.utu[0, 0]
    chol_q = np.linalg.cholesky(utu + np.eye(utu.shape[0]))
    # Sigma A^T S^-1 r with S^-1 = B^-1 - B^-1 V Q^-1 V^T B^-1:  A^T S^-1 r = h - H U Q^-1 v.
    kappa = small_h - hu @ cho_solve((chol_q, True), w.v[0, 0], check_finite=False)
    shift = u_all @ np.einsum("dmr,dm->r", u_o, kappa)  # U U_O^T kappa
    mean = per_dimension(primitive.mean_at(alpha), n_dims) + shift
    mean[dims] += t_o[:, None] * kappa
    # Diagonal blocks of Sigma - Sigma A^T S^-1 A Sigma, with Sigma_de = t_d I [d = e] + U_d U_e^T.
    wg = u_all @ utu  # Sigma_(d,O) A^T B^-1 V
    wg[dims] += t_o[:, None, None] * hu
    # Sigma_(d,O) H Sigma_(O,d) = U_d (Q - I) U_d^T + t_d H_d U_d U_d^T (from wg)
    #                            + t_d^2 H_d + t_d U_d U_d^T H_d          (observed d only)
    correction = wg @ u_all.transpose(0, 2, 1)
    t3 = t_o[:, None, None]
    correction[dims] += t3**2 * big_h + t3 * (u_o @ hu.transpose(0, 2, 1))
    # L_q^-1 (W G)^T, (D, r, M): one triangular solve with every dimension's right-hand sides
    r = chol_q.shape[0]
    rhs = np.ascontiguousarray(wg.transpose(2, 0, 1).reshape(r, -1))  # (r, D M)
    z = solve_triangular(chol_q, rhs, lower=True, check_finite=False)
    z = z.reshape(r, n_dims, m).transpose(1, 0, 2)
    prior_blocks = t_all[:, None, None] * np.eye(m) + u_all @ u_all.transpose(0, 2, 1)
    blocks = prior_blocks - correction + z.transpose(0, 2, 1) @ z
    blocks = 0.5 * (blocks + blocks.transpose(0, 2, 1))
    return mean.reshape(-1), blocks

