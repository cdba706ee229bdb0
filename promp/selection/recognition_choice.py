"""The recognition variant chosen by the data (:attr:`promp.model.Settings.recognition` left
None): the ProMP, or the mixture over the training demonstrations at one of
:data:`BANDWIDTHS` (:mod:`promp.evidence.mixture`), whichever has the lowest recognition
log-loss on the leave-one-out rule's own trials (:mod:`promp.selection.loo`), at the settings
already chosen. A trial's demonstration is out of the model it is scored by: its primitive's
mean, regression, scatter and speed prior downdated as for the ProMP, and its own component out
of its primitive's mixture; the other components placed by the regression without it, their
speeds winsorized without it (like the scorer's noise and pooled prior, the other primitives'
components are the whole fit's: an approximation, one demonstration moves them little). In the
evaluation the choice is made inside every fold, without the trial under test.

The choice follows the one-standard-error rule (Breiman et al. 1984; Hastie, Tibshirani &
Friedman, 2009, section 7.10): the simplest variant whose mean loss is within one standard error
of the lowest, the error of the trials' paired differences with it. The ProMP is the simplest,
then the mixtures from the widest bandwidth down. So a mixture is chosen only where it beats the
ProMP by more than the trials' own noise: a few trials' luck does not change the model.
:data:`RECOGNITION_RULE` is the rule's line in the fit's report; the studio shows it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy.linalg import lapack

from promp.evidence.mixture import kernel
from promp.evidence.speed import logsumexp_rows, quadrature_weights
from promp.evidence.weight_space import diagonal_blocks
from promp.model import recognition_bandwidth
from promp.quality import winsorized
from promp.recognition import label_noise, with_label_noise
from promp.selection.loo import LooScorer, held_out

__all__ = [
    "BANDWIDTHS",
    "KEPT_RECOGNITION_RULE",
    "RECOGNITION_RULE",
    "choose_recognition",
    "kept_bandwidths",
    "mixture_losses",
]

_CHUNK_BYTES = 4 << 20  # the stack of matrices factorised at once (in the cache: 32 MB took
# ~10 % longer)

BANDWIDTHS = (0.85, 0.7, 0.5)  # from the simplest (the closest to the ProMP) down
RECOGNITION_RULE = (
    "the recognition log-loss of the training demonstrations left out in turn, the ProMP "
    "against the mixture over the demonstrations at bandwidths "
    + ", ".join(str(h) for h in BANDWIDTHS)
    + ": the simplest within one standard error of the lowest"
)
KEPT_RECOGNITION_RULE = (
    "kept with the settings from the previous fit while, by the same rule, it still beats the "
    "ProMP on these demonstrations' trials (every variant is scored again when the settings' "
    "search runs again)"
)


def choose_recognition(
    scorer: LooScorer, noise_scale: float, bandwidths: Sequence[float] = BANDWIDTHS
) -> tuple[str, dict]:
    """The variant chosen by the one-standard-error rule (module docstring) on ``scorer``'s
    trials at ``noise_scale`` (in the scorer's units) among the ProMP and the mixture at
    ``bandwidths``, and the report: ``{"value", "rule", "log_loss": {variant: mean},
    "lowest"}``."""
    losses = {"promp": scorer((noise_scale,))[0]}
    for h, loss in mixture_losses(scorer, noise_scale, bandwidths).items():
        losses[f"mixture:{h}"] = loss
    means = {name: float(np.mean(loss)) for name, loss in losses.items()}
    lowest = min(means, key=lambda name: means[name])  # (the first of equals: the simplest)
    chosen = lowest
    if math.isfinite(means[lowest]):
        for name, loss in losses.items():  # from the simplest
            gap = loss - losses[lowest]
            error = float(np.std(gap, ddof=1) / math.sqrt(gap.size)) if gap.size > 1 else 0.0
            if means[name] - means[lowest] <= error + 1e-9:  # (round-off: a tie)
                chosen = name
                break
    shown = {name: round(v, 6) if math.isfinite(v) else None for name, v in means.items()}
    return chosen, {"value": chosen, "rule": RECOGNITION_RULE, "log_loss": shown,
                    "lowest": lowest}  # fmt: skip


def kept_bandwidths(previous: Mapping | None) -> tuple[float, ...] | None:
    """What a refit that kept the previous settings (:data:`promp.selection.keep.KEPT_RULE`)
    scores of the variants: the previous choice's report ``previous`` (its
    ``report["settings"]["recognition"]``) chose the ProMP, nothing more (); a mixture at
    one of :data:`BANDWIDTHS`, that mixture against the ProMP. None (the whole choice again)
    when the report names no such variant."""
    value = previous.get("value") if isinstance(previous, Mapping) else None
    if value == "promp":
        return ()
    try:
        h = recognition_bandwidth(value) if isinstance(value, str) else None
    except ValueError:
        return None
    return (h,) if h in BANDWIDTHS else None


def mixture_losses(
    scorer: LooScorer, noise_scale: float, bandwidths: Sequence[float]
) -> dict[float, np.ndarray]:
    """``-ln p(true primitive)`` of every trial of ``scorer`` with each primitive scored by its
    mixture at each bandwidth (module docstring), at ``noise_scale``: {bandwidth: (n_trials,)}.
    At bandwidth 1 it is the ProMP's :class:`~promp.selection.loo.LooScorer` loss."""
    out = {float(h): np.full(scorer.n_trials, np.inf) for h in bandwidths}
    if not scorer.inside or not out:
        return out
    model = scorer.model
    inv_noise = scorer.inverse_noise(noise_scale)
    m, n_prims = model.basis.n_basis, len(model.primitives)
    eps = label_noise(model)
    log_alphas = [np.log(p.alphas) for p in model.primitives]
    for i, batch in enumerate(scorer.batches):
        precision, logdet_sigma, gram, proj, rr = scorer.setup(i)
        dims = batch.dims
        cols = (dims[:, None] * m + np.arange(m)).reshape(-1)
        residuals = _residuals(scorer, batch, cols)
        inv_s2 = inv_noise[dims]
        evidence = {h: np.empty((batch.truth.shape[0], n_prims)) for h in out}
        for k in range(n_prims):
            tables = _component_log_likelihoods(
                precision[:, k], logdet_sigma[:, k], gram, proj[:, k], rr[:, k],
                residuals[k].reshape(residuals[k].shape[:2] + (dims.shape[0], m)), inv_s2,
                tuple(out),
            )  # fmt: skip
            mine = np.nonzero(batch.truth == k)[0]  # its own demonstration: out
            own = _own_speeds(log_alphas[k], batch.truth == k, np.array(batch.demos))
            for h, ll in zip(out, tables, strict=True):
                ll[mine, np.array(batch.demos)[mine]] = -np.inf
                count = np.where(batch.truth == k, ll.shape[1] - 1, ll.shape[1])
                with np.errstate(invalid="ignore"):
                    total = logsumexp_rows((ll + _kernels(batch, k, own, h)).reshape(
                        ll.shape[0], -1))  # fmt: skip
                evidence[h][:, k] = total - np.log(np.maximum(count, 1))
        rows = np.arange(batch.truth.shape[0])
        for h, table in evidence.items():
            total = logsumexp_rows(table)
            with np.errstate(invalid="ignore", over="ignore"):
                p_all = with_label_noise(np.exp(table - total[:, None]), eps)
            out[h][batch.index] = np.where(np.isfinite(total), -np.log(p_all[rows, batch.truth]),
                                           math.log(n_prims))  # fmt: skip
    return out


def _residuals(scorer: LooScorer, batch, cols: np.ndarray) -> list[np.ndarray]:
    """Each primitive's components' residuals of the observed weights ``cols`` in every trial
    of ``batch``, (T, J, p): the whole fit's, but for the trial's own primitive, whose
    demonstrations' residuals are from its regression without the trial's demonstration (the
    components sit where the refit would put them; its own row is left out later)."""
    n_t = batch.truth.shape[0]
    held = held_out(scorer.parts, scorer.model, batch.truth, np.array(batch.demos), cols)
    out = []
    for k, part in enumerate(scorer.parts):
        e = np.repeat(part.residuals[None][:, :, cols], n_t, axis=0)  # (T, J, p)
        mine = batch.truth == k
        if mine.any():
            intercept, slope = held.mean[mine][:, cols], held.slope[mine][:, cols]  # (T_k, p)
            e[mine] = (part.weights[None][:, :, cols] - intercept[:, None]
                       - part.centred_log_alphas[None, :, None] * slope[:, None])  # fmt: skip
        out.append(e)
    return out


def _own_speeds(log_alphas: np.ndarray, mine: np.ndarray, demos: np.ndarray) -> np.ndarray:
    """A primitive's components' log speeds in each trial, (T, J), winsorized as its fit
    would winsorize them (:func:`promp.evidence.mixture.speed_kernels`): over all its
    demonstrations, but in the trials that hold one of them out (``mine``, ``demos``: which),
    over the others, as the refit without it would. (The held-out one's own component, left
    out later, keeps its speed.) Over all of them, a far-out held-out take would have set the
    others' clipping: the trial under test seen by its own score."""
    out = np.repeat(winsorized(log_alphas)[None], mine.shape[0], axis=0)
    for j in np.unique(demos[mine]):
        others = winsorized(np.delete(log_alphas, j))
        out[mine & (demos == j)] = np.insert(others, j, log_alphas[j])
    return out


def _kernels(batch, k: int, own: np.ndarray, h: float) -> np.ndarray:
    """Primitive ``k``'s components' log quadrature weights at every trial's nodes, (T, J, A)
    (:func:`promp.evidence.mixture.speed_kernels` in batch form), its components at the log
    speeds ``own``, (J,) or per trial (T, J)."""
    loc, scale, dof = (batch.priors[q, :, k][:, None] for q in range(3))  # (T, 1)
    density, mass = kernel(batch.log_alphas, loc, scale, dof, own, batch.bounds[:, None], h)
    return quadrature_weights(batch.log_alphas[:, None, :], density, mass)


def _component_log_likelihoods(
    precision: np.ndarray,
    logdet_sigma: np.ndarray,
    gram: np.ndarray,
    proj: np.ndarray,
    rr: np.ndarray,
    residuals: np.ndarray,
    inv_s2: np.ndarray,
    bandwidths: Sequence[float],
) -> np.ndarray:
    """Every component's log-likelihood of every trial at every node at each of
    ``bandwidths``, (H, T, J, A), without the terms every primitive shares (as
    :class:`~promp.selection.loo.LooScorer`): one primitive's ``precision`` (T, p, p) and
    ``logdet_sigma`` (T,), the trials' ``gram`` (T, A, Do, M, M), ``proj`` (T, A, Do, M) and
    ``rr`` (T, A, Do), its demonstrations' observed ``residuals`` in each trial (T, J, Do, M)
    and the inverse noise ``inv_s2`` (Do,).

    Each (trial, node, bandwidth) is one Cholesky factorisation of ``S = Sigma_o^-1 / H^2 +
    A^T R^-1 A`` and one triangular solve of its factor for the components' ``b_j``, both by
    LAPACK in place, as the engine's :func:`promp.evidence.mixture.log_likelihoods` (numpy's
    stacked ``solve`` on the factor, the first form, factorised it again as a general matrix:
    twice the cost). Not equilibrated: neither pivots, so the modalities' units do not change
    their relative errors. The shifts ``s e_j`` scale with ``s = sqrt(1 - H^2)``: their
    products with the observation's statistics are computed once for every bandwidth."""
    n_t, n_a, n_do, m = gram.shape[:4]
    n_j = residuals.shape[1]
    p = n_do * m
    out = np.empty((len(bandwidths), n_t, n_j, n_a))
    step = max(1, _CHUNK_BYTES // (8 * n_a * p * (p + n_j)))  # trials at once
    for first in range(0, n_t, step):
        t = slice(first, min(first + step, n_t))
        c = t.stop - t.start
        e = residuals[t][:, None]  # (c, 1, J, Do, M)
        # A^T K^-1 A e_j per dimension: (c, A, Do, M, M) @ (c, 1, Do, M, J), as (c, A, J, Do, M)
        g_e = (gram[t] @ e.transpose(0, 1, 3, 4, 2)).transpose(0, 1, 4, 2, 3)
        e_g_e = (g_e * e).sum(-1) @ inv_s2  # (c, A, J)
        proj_e = (proj[t][:, :, None] * e).sum(-1) @ inv_s2  # (c, A, J)
        u = (inv_s2[:, None] * proj[t]).reshape(c, n_a, 1, p)  # b_j = u - s w_j
        w = (inv_s2[:, None] * g_e).reshape(c, n_a, n_j, p)
        rr_t = (rr[t] @ inv_s2)[..., None]  # (c, A, 1)
        blocks = np.zeros((c * n_a, p, p))  # A^T R^-1 A, block-diagonal
        diagonal_blocks(blocks, n_do, m)[:] = (inv_s2[:, None, None] * gram[t]).reshape(
            c * n_a, n_do, m, m
        )
        blocks = blocks.reshape(c, n_a, p, p)
        matrices, rows = np.empty((c, n_a, p, p)), np.empty((c, n_a, n_j, p))
        flat_matrices, flat_rows = matrices.reshape(-1, p, p), rows.reshape(-1, n_j, p)
        for index, h in enumerate(bandwidths):
            h2 = h * h
            share = math.sqrt(max(1.0 - h2, 0.0))
            np.add(blocks, precision[t][:, None] / h2, out=matrices)
            np.subtract(u, share * w, out=rows)  # the b_j^T
            quad = rr_t + share * share * e_g_e - 2.0 * share * proj_e  # (c, A, J)
            # (the transpose of a C array is the matrix in Fortran order: LAPACK works on
            # each in place, the factor in its upper triangle, L^-1 B over the rows)
            for matrix, b in zip(flat_matrices, flat_rows, strict=True):
                _, info = lapack.dpotrf(matrix.T, 1, 0, 1)  # lower, not cleaned, in place
                if info == 0:
                    _, info = lapack.dtrtrs(matrix.T, b.T, 1, 0, 0, p, 1)  # lower, in place
                if info != 0:
                    raise np.linalg.LinAlgError("Matrix is not positive definite")
            logdet = (2.0 * np.log(np.diagonal(matrices, axis1=-2, axis2=-1)).sum(-1)
                      + logdet_sigma[t][:, None] + p * math.log(h2))  # (c, A)  # fmt: skip
            out[index, t] = (-0.5 * (quad - (rows * rows).sum(axis=-1)
                                     + logdet[..., None])).swapaxes(1, 2)  # fmt: skip
    return out
