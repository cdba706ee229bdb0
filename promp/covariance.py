"""The weight covariance of every primitive, with a prior pooled across primitives.

A primitive learned from ten demonstrations has a sample covariance of rank nine in a space of
``n_dims * n_basis`` weights: used as it is, it says that every movement outside the span of
those ten is impossible, and recognition becomes wildly overconfident. The primitives of one
dataset share their sensors, their people and their way of moving, so they are estimated
together (empirical Bayes):

1. Each primitive's weights, minus its mean (and its regression on log alpha), are its
   residuals ``E_k`` (n_k x P). Pooled over the primitives they give ``S_pool``.
2. ``S_pool`` is shrunk towards the target ``F`` (one scaled identity per dimension, see
   :func:`block_target`): ``Sigma_0 = beta F + (1 - beta) S_pool``, one ``beta`` per modality,
   the one of :data:`TARGET_GRID` with the highest K-fold held-out likelihood of the residual
   rows.
3. Each primitive's covariance has a Normal-inverse-Wishart prior centred on ``Sigma_0`` with
   ``c + P + 1`` degrees of freedom; the strength ``c`` maximises the marginal likelihood of all
   primitives' residuals (closed form, :func:`niw_log_evidence`). The posterior mean is
   ``(c Sigma_0 + E_k^T E_k) / (c + dof_k)``: a primitive with many demonstrations keeps its own
   shape, one with few borrows the shared one.
4. The predictive covariance of a new movement inflates it by ``1 + 1 / n_k`` (the mean itself is
   estimated from ``n_k`` demonstrations).

Only diagonal-plus-low-rank matrices are formed: ``Sigma_k = diag(d) + U U^T`` with ``U`` of
rank at most ``P`` (the form :class:`promp.model.Primitive` stores).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import gammaln

from promp.basis import RBFBasis

__all__ = [
    "CV_FOLDS", "MIN_SHRINKAGE", "PooledPrior", "STRENGTH_GRID", "TARGET_GRID", "block_target",
    "compress_factor", "fixed_shrinkage", "niw_log_evidence", "pooled_covariances", "target_weight"
]  # fmt: skip

TARGET_GRID = (1e-4, 1e-3, 1e-2, 0.03, 0.1, 0.3, 0.6, 0.9)
STRENGTH_GRID = np.logspace(-1, 6, 57)  # c = nu_0 - P - 1
CV_FOLDS = 10
# Smallest shrinkage intensity: keeps Sigma_w positive definite.
MIN_SHRINKAGE = 1e-12


def block_target(
    centred: np.ndarray,
    n_dims: int,
    dof: float,
    basis: RBFBasis,
    floor: np.ndarray,
    n_phases: int = 101,
) -> np.ndarray:
    """Diagonal of the shrinkage target F, one scaled identity per dimension, (n_weights,).

    The scale is set in trajectory space, where it means something: independent weights of
    variance ``tau_d`` give trajectories whose variance, averaged over the phase, equals the
    demonstrations' own average variance in dimension d. (Set from the weights' variances
    instead, an overlapping basis, whose near-collinear weights vary wildly while their
    trajectory does not, would give a target of metres.)

    Parameters
    ----------
    centred : array, shape (n, n_dims * M)
        Residual weights (dimension-major).
    dof : float
        Their degrees of freedom.
    floor : array, shape (n_dims,)
        The smallest trajectory variance of each dimension, in its unit squared (identical
        demonstrations vary by nothing): a fraction of the data's own scale
        (:mod:`promp.scale`), so that the target does not depend on the unit.
    """
    phi = basis(np.linspace(0.0, 1.0, n_phases))  # (Z, M)
    blocks = centred.reshape(centred.shape[0], n_dims, -1)  # (N, D, M)
    trajectories = np.einsum("ndm,zm->ndz", blocks, phi)
    spread = (trajectories**2).sum(axis=0).mean(axis=-1) / max(dof, 1e-12)  # (D,)
    gain = float((phi**2).sum(axis=1).mean())  # trajectory variance per unit weight variance
    tau = np.maximum(spread, np.asarray(floor, dtype=float)) / gain
    return np.repeat(tau, phi.shape[1])


def fixed_shrinkage(
    residuals: np.ndarray, dof: float, basis: RBFBasis, shrinkage: float, floor: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(1 - lambda) S + lambda F`` of one primitive alone (``Settings.shrinkage``), as
    ``(cov_diag (P,), cov_factor (P, n))``.

    Parameters
    ----------
    residuals : array, shape (n, P)
        The primitive's residual weights; ``dof`` their degrees of freedom.
    floor : array, shape (n_dims,)
        The smallest trajectory variance of each dimension (see :func:`block_target`).
    """
    n_dims = floor.shape[0]
    target = block_target(residuals, n_dims, dof, basis, floor)
    per_weight = np.full(target.shape[0], max(float(shrinkage), MIN_SHRINKAGE))
    factor = np.sqrt((1.0 - per_weight) / dof)[:, None] * residuals.T
    return per_weight * target, factor


def target_weight(
    rows: np.ndarray, dof: float, target: np.ndarray, folds: int = CV_FOLDS, seed: int = 0
) -> float:
    """The ``beta`` of :data:`TARGET_GRID` whose ``beta F + (1 - beta) S`` gives the rows the
    highest K-fold held-out Gaussian likelihood (rows: pooled residuals of one modality;
    ``dof``: the degrees of freedom of all the rows together). Every fold and every ``beta``
    in one batch of factorisations."""
    n = rows.shape[0]
    order = np.random.default_rng(seed).permutation(n)
    parts = [p for p in np.array_split(order, min(folds, n)) if p.size]
    width = max(p.size for p in parts)
    samples = np.empty((len(parts), rows.shape[1], rows.shape[1]))
    held_out = np.zeros((len(parts), rows.shape[1], width))  # zero columns add nothing
    counts = np.empty(len(parts))
    for i, part in enumerate(parts):
        outside = np.ones(n, dtype=bool)
        outside[part] = False
        train = np.nonzero(outside)[0]  # the sorted complement of the fold
        samples[i] = rows[train].T @ rows[train] / max(dof * train.size / n, 1.0)
        held_out[i, :, : part.size] = rows[part].T
        counts[i] = part.size
    betas = np.array(TARGET_GRID)[:, None, None, None]
    covs = (1.0 - betas) * samples + betas * np.diag(target)  # (B, K, P, P)
    score = _held_out_log_likelihood(covs, held_out, counts).sum(axis=1)  # (B,)
    return float(TARGET_GRID[int(np.argmax(score))])


def _held_out_log_likelihood(
    covs: np.ndarray, held_out: np.ndarray, counts: np.ndarray
) -> np.ndarray:
    """Gaussian log-likelihood (without the 2 pi term) of the columns of ``held_out[k]``
    (K, P, n; ``counts[k]`` of them, the others zero) under each covariance ``covs[b, k]``
    (B, K, P, P): shape (B, K); -inf for one that is not positive definite."""
    out = np.full(covs.shape[:2], -np.inf)
    try:
        chol = np.linalg.cholesky(covs)  # all at once
        good = np.ones(covs.shape[:2], dtype=bool)
    except np.linalg.LinAlgError:
        chol = np.zeros_like(covs)
        good = np.zeros(covs.shape[:2], dtype=bool)
        for index in np.ndindex(*covs.shape[:2]):
            try:
                chol[index] = np.linalg.cholesky(covs[index])
                good[index] = True
            except np.linalg.LinAlgError:
                pass
    chol = chol[good]  # (G, P, P)
    rhs = np.broadcast_to(held_out, covs.shape[:2] + held_out.shape[1:])[good]
    z = np.linalg.solve(chol, rhs)
    logdet = np.log(np.diagonal(chol, axis1=-2, axis2=-1)).sum(-1)
    n = np.broadcast_to(counts, covs.shape[:2])[good]
    out[good] = -0.5 * (z**2).sum(axis=(-1, -2)) - n * logdet
    return out


def _log_multigamma(a: np.ndarray, p: int) -> np.ndarray:
    """``log Gamma_p(a)`` of every ``a`` (array)."""
    a = np.asarray(a, dtype=float)
    terms = gammaln(a[..., None] - np.arange(p) / 2.0).sum(-1)
    return p * (p - 1) / 4.0 * math.log(math.pi) + terms


def niw_log_evidence(
    strength: float | np.ndarray, eigenvalues: Sequence[np.ndarray], dofs: Sequence[float],
    n_weights: int, logdet_prior: float,
) -> float | np.ndarray:  # fmt: skip
    """Log marginal likelihood of every primitive's residuals under an inverse-Wishart prior of
    scale ``strength * Sigma_0`` and ``strength + P + 1`` degrees of freedom (at every strength
    of an array at once).

    ``eigenvalues[k]`` are those of ``E_k Sigma_0^-1 E_k^T`` (n_k of them), ``dofs[k]`` the
    primitive's residual degrees of freedom, ``logdet_prior = log |Sigma_0|``.
    """
    p, c = n_weights, np.asarray(strength, dtype=float)
    nu0 = c + p + 1.0
    total = np.zeros_like(c)
    for eig, dof in zip(eigenvalues, dofs, strict=True):
        nun = nu0 + dof
        logdet_psi = p * np.log(c) + logdet_prior
        logdet_post = logdet_prior + np.log(c[..., None] + eig).sum(-1) + (p - eig.size) * np.log(c)
        total += (
            -dof * p / 2.0 * math.log(math.pi)
            + _log_multigamma(nun / 2.0, p)
            - _log_multigamma(nu0 / 2.0, p)
            + nu0 / 2.0 * logdet_psi
            - nun / 2.0 * logdet_post
        )
    return float(total) if total.ndim == 0 else total


def compress_factor(factor: np.ndarray) -> np.ndarray:
    """A factor with as many columns as rows and the same product: shape (P, r) -> (P, P)
    with ``G G^T = F F^T`` (for r > P).

    ``G = R^T`` from the QR factorisation ``F^T = Q R``: every row of ``G`` is the row of ``F``
    times the same orthonormal ``Q``, computed with an error relative to that row. So
    dimensions in units a million times apart (a hand in km beside a head in radians) keep
    their precision, where the eigendecomposition of ``F F^T`` would lose the small ones in
    the round-off of the large.
    """
    r = np.linalg.qr(factor.T, mode="r")  # (P, P) for r > P
    return np.ascontiguousarray(r.T)


@dataclass(frozen=True)
class PooledPrior:
    """What :func:`pooled_covariances` chose, and why (recorded in the model file).

    Attributes
    ----------
    target_weight : array, shape (n_dims,)
        ``beta`` of each dimension (one per modality), by K-fold likelihood.
    strength : float
        ``c``, the prior's weight in demonstrations' worth, by marginal likelihood.
    log_evidence : float
        The marginal likelihood reached.
    """

    target_weight: np.ndarray
    strength: float
    log_evidence: float
    # Sigma_0 = diag(target_part) + keep (rows^T rows) keep / dof, for the leave-one-out
    # downdates of promp.selection (never stored in the model file)
    target_part: np.ndarray | None = None  # beta F, (P,)
    keep: np.ndarray | None = None  # sqrt(1 - beta), (P,)
    scatter: np.ndarray | None = None  # rows^T rows of every primitive's residuals, (P, P)
    dof: float = 0.0

    def describe(self) -> dict:
        return {
            "rule": "hierarchical (Normal-inverse-Wishart) prior pooled across primitives",
            "target_weight": [float(b) for b in self.target_weight],
            "target_weight_rule": f"{CV_FOLDS}-fold held-out likelihood of the pooled residuals",
            "strength": float(self.strength),
            "strength_rule": "marginal likelihood of every primitive's residuals",
            "log_evidence": float(self.log_evidence),
        }


def pooled_covariances(
    residuals: Sequence[np.ndarray],
    dofs: Sequence[float],
    dims_of_modality: Sequence[np.ndarray],
    n_dims: int,
    basis: RBFBasis,
    floor: np.ndarray,
) -> tuple[list[tuple[np.ndarray, np.ndarray]], PooledPrior]:
    """Every primitive's predictive weight covariance (see the module docstring).

    Parameters
    ----------
    residuals : list of arrays, shape (n_k, P)
        Each primitive's weights minus its mean (and alpha regression).
    dofs : list of float
        Their degrees of freedom (n_k - 1, or n_k - 2 with the alpha regression).
    dims_of_modality : list of int arrays
        The dimensions of each modality (one ``beta`` each).
    floor : array, shape (n_dims,)
        The smallest trajectory variance of each dimension (see :func:`block_target`).

    Returns
    -------
    list of (cov_diag (P,), cov_factor (P, r)) per primitive, and the :class:`PooledPrior`.
    """
    n_basis = basis.n_basis
    rows = np.concatenate(residuals)
    dof_pool = float(sum(dofs))
    target = block_target(rows, n_dims, dof_pool, basis, floor)
    beta = np.empty(n_dims)
    for dims in dims_of_modality:
        cols = (np.asarray(dims)[:, None] * n_basis + np.arange(n_basis)).reshape(-1)
        beta[dims] = target_weight(rows[:, cols], dof_pool, target[cols])
    beta_w = np.repeat(beta, n_basis)
    keep = np.sqrt(1.0 - beta_w)
    # Sigma_0 = diag(beta F) + V V^T with V = keep * rows^T / sqrt(dof_pool)
    pooled_factor = keep[:, None] * rows.T / math.sqrt(dof_pool)
    sigma0 = np.diag(beta_w * target) + pooled_factor @ pooled_factor.T
    chol = np.linalg.cholesky(sigma0)
    logdet = 2.0 * float(np.log(np.diag(chol)).sum())
    eigenvalues = []
    for e in residuals:
        z = np.linalg.solve(chol, e.T)  # (P, n_k)
        eigenvalues.append(np.maximum(np.linalg.eigvalsh(z.T @ z), 0.0))
    p = rows.shape[1]
    scores = niw_log_evidence(STRENGTH_GRID, eigenvalues, dofs, p, logdet)
    best = int(np.argmax(scores))
    c = float(STRENGTH_GRID[best])
    out = []
    for e, dof in zip(residuals, dofs, strict=True):
        inflate = 1.0 + 1.0 / e.shape[0]
        a = inflate * c / (c + dof)  # weight of Sigma_0
        b = inflate / (c + dof)  # weight of E_k^T E_k
        factor = np.concatenate([math.sqrt(a) * pooled_factor, math.sqrt(b) * e.T], axis=1)
        if factor.shape[1] > p:  # compress to rank <= P
            factor = compress_factor(factor)
        out.append((a * beta_w * target, factor))
    return out, PooledPrior(
        target_weight=beta,
        strength=c,
        log_evidence=float(scores[best]),
        target_part=beta_w * target,
        keep=keep,
        scatter=rows.T @ rows,
        dof=dof_pool,
    )
