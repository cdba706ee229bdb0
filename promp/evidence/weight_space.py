"""The likelihood of Eq. 6 in weight space, for when the observed weights' covariance is dense.

:mod:`promp.evidence.woodbury` scores an observation through ``Sigma_w = T + U U^T`` with Woodbury's
identity: its work per candidate and noise level is an ``r x r`` factorisation and an
``(n_o_weights x r)`` product, cheap while the rank r of ``U`` is well below the number of
observed weights ``P_o = D_o M``. Once a primitive has as many demonstrations as that (the
usual case for a few observed dimensions), ``U`` is square and the same determinant and
quadratic form are cheaper from the ``P_o x P_o`` matrix of the weight-space posterior:

    log det S = log det R + log det Sigma_o + log det (Sigma_o^-1 + A^T R^-1 A)
    r^T S^-1 r = r^T R^-1 r - b^T (Sigma_o^-1 + A^T R^-1 A)^-1 b,    b = A^T R^-1 r

(the determinant lemma and Woodbury's identity on ``S = A Sigma_o A^T + R``, ``r = y - A mu``),
with ``Sigma_o^-1`` factorised once per primitive and observed set, ``A^T R^-1 A``
block-diagonal (one whitened Gram matrix per dimension) and no eigendecomposition at all: one
Cholesky factorisation of the bordered ``(P_o + 1)`` matrix per candidate and noise level gives
both terms. :meth:`promp.evidence.Evidence.log_likelihoods` picks the cheaper form
(:func:`cheaper_than_woodbury`); the leave-one-out scorer (:mod:`promp.selection.loo`) uses the
same factorisations in batch form.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

from promp._recent import cached_on
from promp.evidence.sums import WhitenedSums
from promp.evidence.woodbury import LOG_2PI
from promp.model import Primitive

__all__ = [
    "cheaper_than_woodbury", "cholesky_diagonals", "diagonal_blocks", "equilibrated_precision",
    "log_likelihoods", "observed_precision",
]  # fmt: skip

_CHUNK = 8  # candidates' matrices filled at once, then factorised one by one (in the cache)


def equilibrated_precision(sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(Sigma^-1, log det Sigma)`` of a covariance or a stack of them (..., P, P) whose units
    may be many orders of magnitude apart: each equilibrated first (unit diagonal), since the
    inverse's pivoting is not blind to scale like Cholesky is; the precision symmetric.

    Each matrix is equilibrated, factorised and inverted in place by LAPACK (``potrf`` then
    ``potri``, one call each), mirrored and scaled back one at a time, while it is in the
    processor's cache: numpy's stacked ``cholesky`` and ``inv`` copy every matrix in and out
    and invert the triangular factor as a general matrix, five times slower at P ~ 150, and a
    pass over the whole stack per step (as this function did before) spent more time moving
    the stack through memory than LAPACK did factorising it (2.4x LAPACK's time at P = 150;
    the same numbers to the last bit: each element sees the same operations). BLAS runs on
    one thread for the process (:mod:`promp._threads`).
    """
    sigma = np.asarray(sigma, dtype=float)
    shape = sigma.shape
    scale = np.sqrt(np.diagonal(sigma, axis1=-2, axis2=-1))
    flat_sigma = sigma.reshape((-1,) + shape[-2:])
    flat_scale = scale.reshape(-1, shape[-1])
    precision = np.empty(flat_sigma.shape)
    log_diag = np.empty(flat_sigma.shape[:2])
    lower = np.tril(np.ones(shape[-2:], dtype=bool), -1)  # (P, P) below the diagonal
    for index, (matrix, s) in enumerate(zip(flat_sigma, flat_scale, strict=True)):
        outer = s[:, None] * s[None, :]
        work = precision[index]
        np.divide(matrix, outer, out=work)
        # the C-ordered symmetric matrix is its own transpose in Fortran order: the lower
        # triangle LAPACK works on is the C array's upper one
        factor, info = lapack.dpotrf(work.T, lower=1, clean=0, overwrite_a=1)
        if info != 0:
            raise np.linalg.LinAlgError("Matrix is not positive definite")
        log_diag[index] = np.log(np.diagonal(factor))
        _, info = lapack.dpotri(factor, lower=1, overwrite_c=1)
        if info != 0:
            raise np.linalg.LinAlgError("Singular matrix")
        np.copyto(work, work.T, where=lower)  # the upper triangle mirrored
        np.divide(work, outer, out=work)
    logdet = 2.0 * (log_diag.sum(-1).reshape(shape[:-2]) + np.log(scale).sum(-1))
    return precision.reshape(shape), logdet


def observed_precision(primitive: Primitive, dims: np.ndarray) -> tuple[np.ndarray, float]:
    """``(Sigma_o^-1, log det Sigma_o)`` of the weights of ``dims``: the precision padded with
    a zero row and column, shape (P_o + 1, P_o + 1), and a float.

    Computed once per primitive and set of dimensions (cached on the primitive, like
    :meth:`promp.model.Primitive.observed_factor`), from the Cholesky factor of
    ``Sigma_o = diag(t) + U_o U_o^T``.
    """
    key = tuple(int(d) for d in dims)

    def make() -> tuple[np.ndarray, float]:
        u = primitive.observed_factor(dims)  # (Do, M, r)
        n_do, m = u.shape[:2]
        t = primitive.cov_diag.reshape(primitive.noise_var.shape[0], -1)[list(key), 0]
        u = u.reshape(n_do * m, -1)
        sigma = u @ u.T
        sigma[np.diag_indices_from(sigma)] += np.repeat(t, m)
        precision, logdet = equilibrated_precision(sigma)
        padded = np.zeros((sigma.shape[0] + 1,) * 2)  # bordered below and right (see below)
        padded[:-1, :-1] = precision
        padded.setflags(write=False)  # shared by threads: read, never written
        return padded, float(logdet)

    return cached_on(primitive, "_observed_precisions", key, make)


def cheaper_than_woodbury(n_weights: int, rank: int) -> bool:
    """Whether the weight-space form costs less than the Woodbury form for ``n_weights``
    observed weights and a factor of rank ``rank``: one ``(P_o + 1)`` Cholesky factorisation
    per candidate, against the Woodbury form's eigenbasis rotations, ``r x r`` product
    ``U^T H U`` and factorisation. Measured (``bench/likelihood_forms.py``: both forms on the
    same sums, P_o 21-144, r 12-80, 32 candidate speeds), the Woodbury form is the cheaper one
    only while the rank is under about a fifth of the observed weights (few demonstrations
    of many weights): its rotations and product cost more per candidate than a factorisation
    of the weights' size whenever the rank is larger (2.5-6x at r = P_o)."""
    return 5 * rank >= n_weights


def diagonal_blocks(matrices: np.ndarray, n_blocks: int, size: int) -> np.ndarray:
    """The ``n_blocks`` leading diagonal blocks of ``size x size`` of every matrix of a
    C-ordered stack (A, N, N): a writable view, shape (A, n_blocks, size, size)."""
    step, row, item = matrices.strides[1], matrices.strides[2], matrices.strides[0]
    return np.lib.stride_tricks.as_strided(
        matrices,
        shape=(matrices.shape[0], n_blocks, size, size),
        strides=(item, size * (step + row), step, row),
    )


def cholesky_diagonals(matrices: np.ndarray) -> np.ndarray:
    """The diagonal of the lower Cholesky factor of every symmetric positive definite matrix
    of a C-ordered stack (A, N, N), shape (A, N); the stack is overwritten.

    LAPACK factorises each matrix in place: the transpose of a C-ordered symmetric matrix is
    the same matrix in Fortran order, so nothing is copied (numpy's stacked ``cholesky`` copies
    every matrix in and out, and at N ~ 180 takes twice as long).

    Raises
    ------
    numpy.linalg.LinAlgError
        A matrix is not positive definite.
    """
    for matrix in matrices:
        _factorise(matrix)
    return np.diagonal(matrices, axis1=1, axis2=2).copy()  # (factorised in place)


def _factorise(matrix: np.ndarray) -> None:
    """The lower Cholesky factor of the C-ordered symmetric positive definite ``matrix`` (N,
    N) in place, by LAPACK (its transpose is the same matrix in Fortran order).

    Raises
    ------
    numpy.linalg.LinAlgError
        The matrix is not positive definite.
    """
    _, info = lapack.dpotrf(matrix.T, 1, 0, 1)  # lower, not cleaned, in place (positional:
    # keywords cost f2py ~1 us a call, and the likelihood factorises ~100 matrices an update)
    if info != 0:
        raise np.linalg.LinAlgError("Matrix is not positive definite")


def log_likelihoods(
    sums: WhitenedSums, primitive: Primitive, dims: np.ndarray, noise_var: np.ndarray
) -> np.ndarray:
    """``log N(y | A mu, A Sigma_o A^T + R)`` per noise level and candidate, shape (L, A),
    from the whitened ``sums`` of the observed ``dims`` (:mod:`promp.evidence.sums`) and their
    noise variance at each level ``noise_var`` (L, Do)."""
    m = sums.gram.shape[-1]
    n_do, n_cand, n_levels = dims.shape[0], sums.proj.shape[0], noise_var.shape[0]
    p = n_do * m
    gram = sums.gram[:, sums.group]  # Psi^T K^-1 Psi of each dimension's noise group
    proj, rr = sums.proj, sums.rr  # Psi^T K^-1 (y - Psi mu), (y - Psi mu)^T K^-1 (y - Psi mu)
    precision, logdet_sigma = observed_precision(primitive, dims)
    inv_s2 = 1.0 / noise_var  # (L, Do)
    # _CHUNK matrices at a time in one buffer, which stays in the cache: a stack of all of
    # them, filled at once then factorised, is ~25 % slower at P ~ 180 (each matrix leaves
    # the cache between its filling and its factorisation), and one at a time spends more
    # on numpy's calls than a few at once (~10 % at P ~ 85).
    # LAPACK reads and overwrites one triangle of each matrix (the C array's upper one, its
    # Fortran transpose's lower): the bordered matrix is written there alone.
    chunk = min(_CHUNK, n_cand)
    stack = np.empty((chunk, p + 1, p + 1))
    blocks = diagonal_blocks(stack, n_do, m)  # (chunk, Do, M, M), a view
    diag = np.empty((n_levels, n_cand, p + 1))
    for level in range(n_levels):
        # [[Sigma_o^-1 + A^T R^-1 A, b], [b^T, r^T R^-1 r + 1]]: the last diagonal of its
        # Cholesky factor squared is r^T S^-1 r + 1 (the Schur complement).
        scaled = inv_s2[level, None, :, None, None] * gram  # (A, Do, M, M)
        bordered = np.empty((n_cand, p + 1))  # each candidate's last column
        bordered[:, :p] = (inv_s2[level, :, None] * proj).reshape(n_cand, p)
        bordered[:, p] = rr @ inv_s2[level] + 1.0
        for first in range(0, n_cand, chunk):
            k = min(chunk, n_cand - first)
            stack[:k] = precision  # (whole rows: faster than filling the top-left block)
            blocks[:k] += scaled[first : first + k]
            stack[:k, :, p] = bordered[first : first + k]
            diag[level, first : first + k] = cholesky_diagonals(stack[:k])
    quad = diag[..., p] ** 2 - 1.0
    logdet = 2.0 * np.log(diag[..., :p]).sum(-1) + logdet_sigma
    logdet_r = (sums.n * np.log(noise_var) + sums.logdet_k).sum(-1)  # (L,)
    return -0.5 * (quad + logdet + logdet_r[:, None] + sums.n * n_do * LOG_2PI)
