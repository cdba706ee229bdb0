"""Recognition by the mixture over a primitive's training demonstrations (``"mixture:H"``,
:attr:`promp.model.Settings.recognition`).

One Gaussian over the weights and one Student-t over the log speed describe a primitive whose
demonstrations vary smoothly around a mean. Where they come in families (two ways of reaching
the same goal, a few speeds), the Gaussian's mass falls between them, and an early observation
that is close to one demonstration looks less likely than it is. The mixture keeps each
training demonstration as a component, shrunk towards the primitive (kernel shrinkage: West
1993; Liu & West 2001): demonstration ``j``'s weights are

    N(mu(alpha) + sqrt(1 - H^2) e_j, H^2 Sigma_w)

(``e_j`` its residual from the regression on log alpha, :attr:`promp.model.Primitive.
residuals`), and its log speed the primitive's Student-t prior with every component moved
``sqrt(1 - H^2)`` of the way from its centre to the demonstration's own log speed, ``H`` times
as wide. The mixture's mean and covariance are the primitive's: ``H = 1`` is the ProMP
exactly, and as ``H`` falls each demonstration becomes a template at its own speed with the
ProMP's noise.

A primitive's evidence is the components' average, each integrated over its speed on the
primitive's quadrature (:mod:`promp.evidence.speed`, refined around the best node of their
sum). The speed's posterior (hence the timing) is the mixture's; the conditioning and the
predictions stay the ProMP's (:meth:`promp.evidence.Evidence.condition`). Every component
shares one covariance, so a candidate speed costs one Cholesky factorisation of the observed
weights' posterior precision, as the ProMP's weight-space form does
(:mod:`promp.evidence.weight_space`), and a triangular solve for each demonstration.
Measured with ``bench/directions.py`` and the evaluation CLI (``--recognition``): see
docs/evaluation.md.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special
from scipy.linalg import lapack

from promp._recent import cached_on
from promp.evidence.speed import (
    AlphaPrior,
    logsumexp,
    logsumexp_rows,
    quadrature,
    quadrature_weights,
    refined_nodes,
    t_logpdf,
)
from promp.evidence.sums import WhitenedSums
from promp.evidence.weight_space import diagonal_blocks, observed_precision
from promp.evidence.woodbury import LOG_2PI
from promp.model import Primitive
from promp.quality import winsorized

__all__ = ["integrate", "kernel", "log_likelihoods", "speed_kernels"]


def _shifts(primitive: Primitive, dims: np.ndarray, share: float) -> np.ndarray:
    """Each component's shift of the observed weights' mean, ``share * e_j``, (J, Do, M)."""
    key = (tuple(int(d) for d in dims), float(share))

    def make() -> np.ndarray:
        n_dims = primitive.noise_var.shape[0]
        e = np.asarray(primitive.residuals, dtype=float)
        shifts = share * e.reshape(e.shape[0], n_dims, -1)[:, list(key[0])]
        shifts.setflags(write=False)  # shared by threads: read, never written
        return shifts

    return cached_on(primitive, "_mixture_shifts", key, make)


def log_likelihoods(
    sums: WhitenedSums,
    primitive: Primitive,
    dims: np.ndarray,
    noise_var: np.ndarray,
    bandwidth: float,
) -> np.ndarray:
    """Each component's ``log N(y | A (mu + s e_j), H^2 A Sigma_o A^T + R)`` at every
    candidate of ``sums``, shape (A, J), at one noise level ``noise_var`` (Do,).

    In weight space (the determinant lemma and Woodbury's identity, as
    :func:`promp.evidence.weight_space.log_likelihoods`): ``b_j = A^T R^-1 r_j`` and
    ``r_j^T R^-1 r_j`` follow from the ProMP's whitened sums and the shift alone, and every
    component shares the factor of ``Sigma_o^-1 / H^2 + A^T R^-1 A``."""
    h2 = bandwidth * bandwidth
    shifts = _shifts(primitive, dims, math.sqrt(max(1.0 - h2, 0.0)))  # (J, Do, M)
    n_j, n_do, m = shifts.shape
    p, n_cand = n_do * m, sums.proj.shape[0]
    gram = sums.gram[:, sums.group]  # (A, Do, M, M)
    inv_s2 = 1.0 / noise_var
    # A^T K^-1 A s e_j per dimension: (A, Do, M, M) @ (Do, M, J), as (A, J, Do, M)
    g_shift = (gram @ shifts.transpose(1, 2, 0)).transpose(0, 3, 1, 2)
    proj = sums.proj[:, None] - g_shift  # (A, J, Do, M): Psi^T K^-1 r_j
    rr = sums.rr[:, None] + ((g_shift - 2.0 * sums.proj[:, None]) * shifts).sum(-1)  # (A, J, Do)
    # (C-ordered: each candidate's transpose is the Fortran array LAPACK solves in place)
    b = np.ascontiguousarray((inv_s2[:, None] * proj).reshape(n_cand, n_j, p))
    quad = rr @ inv_s2  # r^T R^-1 r, then less b^T (...)^-1 b below
    padded, logdet_sigma = observed_precision(primitive, dims)
    precision = padded[:p, :p] / h2
    # every candidate's matrix filled at once (one numpy call, not one per dimension and
    # candidate: at D_o = 12 those calls took a third of an update), then each factorised and
    # solved by LAPACK in place (the C array's transpose is the matrix in Fortran order; the
    # factor is in its upper triangle)
    stack = np.empty((n_cand, p, p))
    stack[:] = precision
    diagonal_blocks(stack, n_do, m)[:] += inv_s2[None, :, None, None] * gram
    for a, matrix in enumerate(stack):
        _, info = lapack.dpotrf(matrix.T, 1, 0, 1)  # lower, not cleaned, in place
        if info != 0:
            raise np.linalg.LinAlgError("Matrix is not positive definite")
        _, info = lapack.dtrtrs(matrix.T, b[a].T, 1, 0, 0, p, 1)  # L z = b (lower, in place)
        if info != 0:
            raise np.linalg.LinAlgError("singular factor")
    quad -= (b * b).sum(axis=-1)  # (b holds each candidate's z^T now)
    logdet = 2.0 * np.log(np.diagonal(stack, axis1=1, axis2=2)).sum(axis=-1)
    logdet += logdet_sigma + p * math.log(h2)
    logdet_r = float((sums.n * np.log(noise_var) + sums.logdet_k).sum())
    return -0.5 * (quad + logdet[:, None] + logdet_r + sums.n * n_do * LOG_2PI)


def speed_kernels(
    primitive: Primitive, prior: AlphaPrior, nodes: np.ndarray, bound: float, bandwidth: float
) -> np.ndarray:
    """Each component's log quadrature weights at ``nodes`` (log alpha, increasing), (J, A):
    the speed ``prior`` with each of its components moved ``sqrt(1 - H^2)`` of the way to the
    demonstration's own log speed (winsorized, as the prior's fit) and ``H`` times as wide,
    normalised to its mass below ``bound`` (:func:`promp.evidence.speed.quadrature_weights`)."""
    own = _own_log_speeds(primitive)  # (J,)
    density = np.full((own.shape[0], nodes.shape[0]), -np.inf)
    mass = np.full(own.shape[0], -np.inf)
    for loc, scale, dof, weight in zip(prior.locs, prior.scales, prior.dofs, prior.weights,
                                       strict=True):  # fmt: skip
        d, below = kernel(nodes, loc, scale, dof, own, bound, bandwidth)
        density = np.logaddexp(density, d + math.log(weight))
        mass = np.logaddexp(mass, below + math.log(weight))
    return quadrature_weights(nodes[None], density, mass)


def _own_log_speeds(primitive: Primitive) -> np.ndarray:
    """The primitive's demonstrations' log speeds winsorized as its speed prior's fit, (J,),
    computed once per primitive: a recognition reads them twice per primitive (the coarse
    nodes, then the refined ones), and the median behind the winsorizing took a tenth of a
    sweep's recognition."""

    def make() -> np.ndarray:
        own = winsorized(np.log(np.asarray(primitive.alphas, dtype=float)))
        own.setflags(write=False)  # shared by threads: read, never written
        return own

    return cached_on(primitive, "_mixture_own_speeds", "winsorized", make)


def kernel(nodes, loc, scale, dof, own: np.ndarray, bound, bandwidth: float) -> tuple:
    """One Student-t component of a speed prior (``loc``, ``scale``, ``dof``: numbers, or
    arrays (..., 1)) made each demonstration's kernel: moved ``sqrt(1 - H^2)`` of the way to
    its log speed ``own`` (J,) and ``H`` times as wide. Its log density at ``nodes`` (A,) or
    (..., A), per unit of log alpha, (..., J, A), and its log mass below ``bound`` (a number,
    or (..., 1)), (..., J). The engine's :func:`speed_kernels` and the leave-one-out scorer's
    batch (:mod:`promp.selection.recognition_choice`) both read it."""
    share = math.sqrt(max(1.0 - bandwidth * bandwidth, 0.0))
    centre = loc + share * (own - loc)  # (..., J)
    width = np.asarray(bandwidth * scale, dtype=float)
    z = (np.asarray(nodes)[..., None, :] - centre[..., None]) / width[..., None]
    density = t_logpdf(z, np.asarray(dof)[..., None]) - np.log(width)[..., None]
    with np.errstate(divide="ignore"):
        mass = np.log(special.stdtr(dof, (bound - centre) / width))
    return density, mass


def integrate(table, primitive: Primitive, prior: AlphaPrior, bound: float, bandwidth: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:  # fmt: skip
    """The mixture's quadrature over the speed: the nodes (log alpha, increasing), each node's
    log-likelihood and log prior density as the speed's posterior reads them (the mixture's
    joint over its prior, and its prior per unit of log alpha), and the log-evidence.

    ``table(x)``: every component's log-likelihood at nodes ``x`` (A,), shape (A, J), ``-inf``
    where the speed's duration is shorter than the observation."""
    nodes, _, _ = quadrature(prior, bound)
    ll = table(nodes)
    weights = speed_kernels(primitive, prior, nodes, bound, bandwidth)
    fine = refined_nodes(nodes, int(np.argmax(logsumexp_rows(ll + weights.T))))
    if fine.size:
        nodes = np.concatenate([nodes, fine])
        ll = np.concatenate([ll, table(fine)])
        order = np.argsort(nodes)
        nodes, ll = nodes[order], ll[order]
        weights = speed_kernels(primitive, prior, nodes, bound, bandwidth)
    log_j = math.log(weights.shape[0])
    prior_weight = logsumexp_rows(weights.T) - log_j  # (A,) the mixture's own weights
    with np.errstate(invalid="ignore"):
        joint = logsumexp_rows(ll + weights.T) - log_j
    likelihood = np.where(np.isfinite(prior_weight), joint - prior_weight, -np.inf)
    widths = np.gradient(nodes) if nodes.size > 1 else np.ones(1)
    return nodes, likelihood, prior_weight - np.log(widths), logsumexp(joint)
