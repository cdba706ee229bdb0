"""The closed-form leave-one-out scorer: the recognition log-loss of every trial of a candidate
at any noise scale, each trial's demonstration left out of the model fitted on all of them
(rank-one downdates of :class:`promp.fitting.FitParts`), every trial of a modality set in one
batch (:mod:`promp.selection.batches`). ``tests/test_promp_selection.py`` checks the downdates
against refits and the batched score against the engine's own likelihood."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from scipy.linalg import lapack

from promp.evidence.speed import logsumexp_rows
from promp.evidence.weight_space import (
    cholesky_diagonals,
    diagonal_blocks,
    equilibrated_precision,
)
from promp.fitting import FitParts
from promp.model import ProMPModel
from promp.recognition import label_noise, with_label_noise
from promp.selection.batches import Batch
from promp.selection.region import within_region
from promp.timing import duration_from_alpha

__all__ = ["HeldOut", "LooScorer", "held_out", "loo_score"]


def _whiten_padded(elapsed: np.ndarray, mask: np.ndarray, tau: float, x: np.ndarray) -> np.ndarray:
    """:func:`promp.noise.whiten` along axis -2 of padded observations (..., T, [A,] n, k):
    ``elapsed``/``mask`` (T, n) broadcast over the axes between; padded rows come out zero."""
    extra = x.ndim - 3  # axes between T and n
    shape = (elapsed.shape[0],) + (1,) * extra + (elapsed.shape[1], 1)
    keep = mask.reshape(shape)
    if tau <= 0:
        return np.where(keep, x, 0.0)
    step = np.diff(elapsed, axis=1)
    rho = np.exp(-np.where(step > 0, step, np.inf) / tau).reshape(shape[:-2] + (-1, 1))
    out = np.array(x, dtype=float, copy=True)
    out[..., 1:, :] = (x[..., 1:, :] - rho * x[..., :-1, :]) / np.sqrt(1.0 - rho**2)
    return np.where(keep, out, 0.0)


def loo_score(
    fitted: tuple[ProMPModel, Sequence[FitParts]],
    batches: Sequence[Batch],
    n_trials: int,
    noise_scales: Sequence[float],
    region: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """:func:`promp.selection.cv.score`'s loss by the closed-form leave-one-out rule: shape
    (n_scales, n_trials), ``-ln p(true primitive)`` of every trial; infinite everywhere when the
    model's mean trajectories leave ``region``.

    ``fitted``: the model fitted on every demonstration with the candidate settings (noise scale
    1, or the one given), and its parts (:func:`promp.fitting.fit_parts`). A trial's
    demonstration is then left out of its own primitive exactly for the mean, the regression on
    log alpha and the residual scatter (rank-one downdates, :class:`promp.fitting.FitParts`),
    while the noise, the ridge and the pooled prior's target and strength stay those of the
    whole set (an approximation: one demonstration moves them little). Each primitive's
    likelihood (Eq. 6 in weight space, with the Ornstein-Uhlenbeck noise) is integrated over its
    speed prior on the batch's nodes, as :attr:`promp.evidence.Evidence.recognition` does; the
    terms every primitive shares (the noise determinant) cancel in the posterior.
    """
    return LooScorer(fitted, batches, n_trials, region)(noise_scales)


class LooScorer:
    """:func:`loo_score` of one candidate at any noise scales: what does not depend on the
    scale (the observations' whitened statistics against every primitive's prior, the
    downdated covariances' factorisations) is computed once per batch, on first use."""

    def __init__(
        self,
        fitted: tuple[ProMPModel, Sequence[FitParts]],
        batches: Sequence[Batch],
        n_trials: int,
        region: tuple[np.ndarray, np.ndarray] | None = None,
    ):
        self.model, self.parts = fitted
        self.batches, self.n_trials = batches, n_trials
        self.inside = region is None or within_region(self.model, *region)
        self._setups: dict[int, tuple] = {}
        # per noise scale: each batch's true primitive's log-likelihood at every node, (T, A)
        self._speed_tables: dict[float, dict[int, np.ndarray]] = {}
        self._losses: dict[float, np.ndarray] = {}  # per noise scale, each trial's loss

    def __call__(self, noise_scales: Sequence[float]) -> np.ndarray:
        """``-ln p(true primitive)`` of every trial at every scale, (n_scales, n_trials); a
        scale scored before is not scored again (the search's, then the recognition
        variant's choice, :mod:`promp.selection.recognition_choice`)."""
        new = [float(s) for s in dict.fromkeys(noise_scales) if float(s) not in self._losses]
        if new:
            self._losses.update(zip(new, self._score(new), strict=True))
        return np.array([self._losses[float(s)] for s in noise_scales])

    def _score(self, noise_scales: Sequence[float]) -> np.ndarray:
        """:meth:`__call__` at ``noise_scales``, every one scored."""
        model = self.model
        n_scales = len(noise_scales)
        out = np.empty((n_scales, self.n_trials))
        if not self.inside:
            out[:] = np.inf
            return out
        n_prims, m = len(model.primitives), model.basis.n_basis
        inv_noise = np.array([self.inverse_noise(s) for s in noise_scales])  # (L, n_dims)
        eps = label_noise(model)
        for i, batch in enumerate(self.batches):
            precision, logdet_sigma, gram, proj, rr = self.setup(i)
            dims = batch.dims
            n_t, n_a = batch.log_alphas.shape
            n_do = dims.shape[0]
            p = n_do * m
            inv_s2 = inv_noise[:, dims]  # (L, Do)
            for level in range(n_scales):
                b = (inv_s2[level, :, None] * proj).reshape(n_t, n_prims, n_a, p)
                corner = rr @ inv_s2[level] + 1.0
                diag = _bordered_diagonals(precision, inv_s2[level], gram, b, corner)
                log_lik = -0.5 * (
                    diag[..., p] ** 2
                    - 1.0
                    + 2.0 * np.log(diag[..., :p]).sum(-1)
                    + logdet_sigma[..., None]
                )  # (T, K, A), without the terms every primitive shares
                self._speed_tables.setdefault(float(noise_scales[level]), {})[i] = log_lik[
                    np.arange(n_t), batch.truth
                ]
                evidence = logsumexp_rows((log_lik + batch.log_weights).reshape(-1, n_a))
                evidence = evidence.reshape(n_t, n_prims)
                total = logsumexp_rows(evidence)
                with np.errstate(invalid="ignore", over="ignore"):
                    p_all = with_label_noise(np.exp(evidence - total[:, None]), eps)
                out[level, batch.index] = np.where(
                    np.isfinite(total),
                    -np.log(p_all[np.arange(n_t), batch.truth]),
                    math.log(n_prims),
                )
        return out

    def speed_trials(self, noise_scale: float) -> list[tuple[np.ndarray, ...]]:
        """What the speed's posterior of every trial's own primitive is made of at
        ``noise_scale`` (scored first if it was not): per batch, the nodes (T, A) in log
        alpha, the log-likelihood (T, A) and the log quadrature weights (T, A) of the true
        primitive, and the true log alphas (T,)."""
        if not self.inside:
            return []
        if float(noise_scale) not in self._speed_tables:
            self((noise_scale,))
        tables = self._speed_tables[float(noise_scale)]
        return [
            (b.log_alphas, tables[i], b.log_weights[np.arange(b.truth.shape[0]), b.truth],
             b.true_log_alphas)
            for i, b in enumerate(self.batches)
        ]  # fmt: skip

    def inverse_noise(self, noise_scale: float) -> np.ndarray:
        """Each model dimension's inverse noise variance at ``noise_scale`` (the modalities
        whose noise is given keep theirs), (n_dims,)."""
        settings, layout = self.model.settings, self.model.layout
        scaled = np.concatenate([np.full(len(mod.columns), mod.name not in settings.noise_std)
                                 for mod in layout.modalities])  # fmt: skip
        noise_var = self.model.primitives[0].noise_var  # pooled: the same for every primitive
        return 1.0 / (noise_var * np.where(scaled, float(noise_scale) ** 2, 1.0))

    def setup(self, i: int) -> tuple:
        """Batch ``i``'s terms that no noise scale changes (:meth:`_setup`), computed on
        first use."""
        if i not in self._setups:
            self._setups[i] = self._setup(self.batches[i])
        return self._setups[i]

    def _setup(self, batch: Batch) -> tuple:
        """(precision (T, K, p, p), log det Sigma (T, K), gram (T, A, Do, M, M), proj
        (T, K, A, Do, M), rr (T, K, A, Do)) of one batch: every primitive's prior of the
        observed weights, without the trial's demonstration (its own primitive's mean,
        regression and scatter, and the pooled prior every primitive borrows from), and the
        whitened statistics of the observation's residual at every node."""
        model, parts = self.model, self.parts
        settings, dt = model.settings, model.sample_period
        n_prims, m = len(model.primitives), model.basis.n_basis
        noise_tau = model.primitives[0].noise_tau
        dims = batch.dims
        n_t, n_a = batch.log_alphas.shape
        n_do = dims.shape[0]
        p = n_do * m
        cols = (dims[:, None] * m + np.arange(m)).reshape(-1)
        durations = duration_from_alpha(np.exp(batch.log_alphas), dt, settings.s_bar)
        phases = batch.elapsed[:, None, :] / durations[:, :, None]  # (T, A, n)
        real = np.broadcast_to(batch.mask[:, None, :], phases.shape)
        psi = np.zeros(phases.shape + (m,))  # (T, A, n, M), padded rows zero
        psi[real] = model.basis(phases[real])
        gram = np.empty((n_t, n_a, n_do, m, m))
        cross = np.empty((n_t, n_a, n_do, m))  # Psi^T K^-1 y
        yy = np.empty((n_t, n_do))
        for tau in np.unique(noise_tau[dims]):
            group = np.nonzero(noise_tau[dims] == tau)[0]
            psi_w = _whiten_padded(batch.elapsed, batch.mask, float(tau), psi)
            y_w = _whiten_padded(batch.elapsed, batch.mask, float(tau), batch.values[..., group])
            gram[:, :, group] = (psi_w.swapaxes(-1, -2) @ psi_w)[:, :, None]
            cross[:, :, group] = (psi_w.swapaxes(-1, -2) @ y_w[:, None]).swapaxes(-1, -2)
            yy[:, group] = (y_w**2).sum(axis=1)
        truth = batch.truth
        held = held_out(parts, model, truth, np.array(batch.demos), cols)
        means = np.empty((n_t, n_prims, n_a, p))
        for k, prim in enumerate(model.primitives):
            means[:, k] = prim.mean_at(np.exp(batch.log_alphas))[..., cols]
            mine = truth == k
            if mine.any():  # the regression without the demonstration
                shift = batch.log_alphas[mine] - prim.log_alpha_mean  # (T_k, A)
                means[mine, k] = (
                    held.mean[mine][:, None] + shift[..., None] * held.slope[mine][:, None]
                )[..., cols]
        precision, logdet_sigma = _prior_precisions(model, parts, held, truth, cols)
        means = means.reshape(n_t, n_prims, n_a, n_do, m)
        proj = cross[:, None] - np.einsum("tadmn,tkadn->tkadm", gram, means)  # Psi^T K^-1 r
        rr = (
            yy[:, None, None]
            - 2.0 * np.einsum("tkadm,tadm->tkad", means, cross)
            + np.einsum("tkadm,tadmn,tkadn->tkad", means, gram, means)
        )
        return precision, logdet_sigma, gram, proj, rr


def _prior_precisions(
    model: ProMPModel,
    parts: Sequence[FitParts],
    held: HeldOut,
    truth: np.ndarray,
    cols: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Every primitive's prior precision of the observed weights ``cols`` (p,) and its log
    determinant, without each trial's demonstration (its own primitive's scatter and degrees
    of freedom, and the pooled prior every primitive borrows from): (T, K, p, p), (T, K).

    The covariances inverted directly are built here (``sigma``); every other primitive's is
    its covariance with the pooled scatter's degrees of freedom less one (``bases``) less a
    rank-one downdate of the pooled scatter (``downdate``, zero without a pooled prior), which
    :func:`_precisions` applies."""
    n_t, n_prims, p = truth.shape[0], len(model.primitives), cols.shape[0]
    sigma = np.empty((n_t, n_prims, p, p))
    bases = np.empty((n_prims, p, p))
    downdate = np.zeros((n_t, p))
    shares = np.zeros(n_prims)  # each primitive's factor of the pooled covariance
    prior = parts[0].prior
    if prior is not None:
        keep = prior.keep[cols]
        scatter0 = prior.scatter[np.ix_(cols, cols)]
        pooled = (scatter0[None] - held.drop) / (prior.dof - 1.0)
        sigma0 = keep[:, None] * pooled * keep[None, :]
        sigma0[:, np.arange(p), np.arange(p)] += prior.target_part[cols]
        base0 = keep[:, None] * (scatter0 / (prior.dof - 1.0)) * keep[None, :]
        base0[np.arange(p), np.arange(p)] += prior.target_part[cols]
        downdate = keep * held.vector / math.sqrt(prior.dof - 1.0)
    for k, (prim, part) in enumerate(zip(model.primitives, parts, strict=True)):
        n = part.residuals.shape[0]
        scatter = part.residuals[:, cols].T @ part.residuals[:, cols]
        mine = truth == k
        direct = mine | ~held.rank_one  # the others: a rank-one downdate (_precisions)
        own = np.where(  # the rows inverted directly
            mine[direct, None, None], scatter[None] - held.drop[direct], scatter[None]
        )
        a_full, b_full = part.weights_of(n, part.dof)
        loo = {d: part.weights_of(n - 1, int(d)) for d in np.unique(held.dof[mine])}
        a = np.array([loo[d][0] if t else a_full for d, t in zip(held.dof, mine, strict=True)])
        b = np.array([loo[d][1] if t else b_full for d, t in zip(held.dof, mine, strict=True)])
        if prior is not None:
            sigma[direct, k] = a[direct, None, None] * sigma0[direct] + b[direct, None, None] * own
            bases[k] = a_full * base0 + b_full * scatter
        else:  # a fixed shrinkage: the target part stays
            target = prim.cov[np.ix_(cols, cols)] - b_full * scatter
            sigma[direct, k] = target[None] + b[direct, None, None] * own
            bases[k] = target + b_full * scatter
        shares[k] = a_full
    return _precisions(sigma, bases, shares, downdate, truth, held.rank_one)


# Below this, Sherman-Morrison's denominator ``1 - u^T Sigma^-1 u`` (the share of the
# determinant a downdate keeps) has lost too many digits to cancellation: inverted directly.
_LEAST_DENOMINATOR = 1e-6


def _precisions(
    sigma: np.ndarray,
    bases: np.ndarray,
    shares: np.ndarray,
    downdate: np.ndarray,
    truth: np.ndarray,
    rank_one: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``(Sigma^-1, log det Sigma)`` of every trial's every primitive, (T, K, p, p) and (T, K).

    A trial's own primitive (and every primitive of a trial whose demonstration's downdate is
    not of rank one) has its covariance in ``sigma`` and is inverted directly
    (:func:`equilibrated_precision`). Every other primitive's covariance is its ``base``
    (K, p, p: the pooled prior's scatter over its degrees of freedom less one) less
    ``shares[k] * d d^T`` (``d = downdate[t]``, the held-out demonstration's residual in the
    pooled scatter): one inversion per primitive and batch, then Sherman-Morrison and the
    determinant lemma per trial, ``O(p^2)`` instead of ``O(p^3)`` (K - 1 of every K
    inversions: a quarter of a fold's CPU on the 70 x 15 set went to them). The same numbers up
    to rounding (the test against refits and the engine's likelihood covers both paths)."""
    n_t, n_prims = sigma.shape[:2]
    precision = np.empty_like(sigma)
    logdet = np.empty((n_t, n_prims))
    for k in range(n_prims):
        direct = (truth == k) | ~rank_one
        if direct.any():
            precision[direct, k], logdet[direct, k] = equilibrated_precision(sigma[direct, k])
        others = np.nonzero(~direct)[0]
        if not others.size:
            continue
        base, base_logdet = equilibrated_precision(bases[k])
        u = math.sqrt(shares[k]) * downdate[others]  # (T_o, p)
        w = u @ base  # (T_o, p): Sigma_k^-1 u
        denominator = 1.0 - np.einsum("tp,tp->t", w, u)  # (T_o,) > 0: Sigma stays positive
        precision[others, k] = base[None] + w[:, :, None] * (w / denominator[:, None])[:, None, :]
        # (a denominator under the bound is replaced below: its log is not taken)
        logdet[others, k] = base_logdet + np.log(np.maximum(denominator, _LEAST_DENOMINATOR))
        close = others[denominator < _LEAST_DENOMINATOR]  # the update cancels: inverted anew
        if close.size:
            lost = u[denominator < _LEAST_DENOMINATOR]
            precision[close, k], logdet[close, k] = equilibrated_precision(
                bases[k][None] - lost[:, :, None] * lost[:, None, :]
            )
    return precision, logdet


# From this many observed weights on, the bordered matrices are filled and factorised one at a
# time (each stays in the processor's cache; a stack of them is ~100 MB at D_o M ~ 200).
_LOOP_WEIGHTS = 64
_STACK_BYTES = 1 << 20  # below it, a stack of a few trials' matrices at once, filled and
# factorised while in the cache (the whole batch at once, ~150 MB on flt-shapes, took 30 % longer)


def _bordered_diagonals(
    precision: np.ndarray,
    inv_s2: np.ndarray,
    gram: np.ndarray,
    b: np.ndarray,
    corner: np.ndarray,
) -> np.ndarray:
    """The diagonal of the Cholesky factor of every bordered matrix
    ``[[Sigma_o^-1 + A^T R^-1 A, b], [b^T, r^T R^-1 r + 1]]`` of a batch (the module
    docstring of :mod:`promp.evidence.weight_space`), shape (T, K, A, P + 1).

    Parameters
    ----------
    precision : array, shape (T, K, P, P)
    inv_s2 : array, shape (Do,)
        Each observed dimension's inverse noise variance.
    gram : array, shape (T, A, Do, M, M)
        The whitened Gram matrix of each dimension (``A^T R^-1 A`` is block-diagonal).
    b : array, shape (T, K, A, P)
    corner : array, shape (T, K, A)
    """
    n_t, n_prims, n_a, p = b.shape
    n_do, m = gram.shape[2], gram.shape[3]
    scaled = inv_s2[:, None, None] * gram  # (T, A, Do, M, M)
    if p < _LOOP_WEIGHTS:  # small: stacks of a few trials, numpy's loops
        out = np.empty((n_t, n_prims, n_a, p + 1))
        step = max(1, _STACK_BYTES // (8 * n_prims * n_a * (p + 1) ** 2))
        for first in range(0, n_t, step):
            t = slice(first, min(first + step, n_t))
            c = t.stop - t.start
            blocks = np.zeros((c * n_a, p, p))  # A^T R^-1 A, block-diagonal
            diagonal_blocks(blocks, n_do, m)[:] = scaled[t].reshape(c * n_a, n_do, m, m)
            blocks = blocks.reshape(c, 1, n_a, p, p)
            bordered = np.empty((c, n_prims, n_a, p + 1, p + 1))
            np.add(blocks, precision[t, :, None], out=bordered[..., :p, :p])
            bordered[..., :p, p] = b[t]  # (LAPACK reads the C array's upper triangle)
            bordered[..., p, p] = corner[t]
            out[t] = cholesky_diagonals(bordered.reshape(-1, p + 1, p + 1)).reshape(
                c, n_prims, n_a, p + 1
            )
        return out
    buffer = np.empty((p + 1, p + 1))
    flat = buffer.reshape(-1)
    start = np.arange(n_do)[:, None, None] * m
    rows, cols = start + np.arange(m)[:, None], start + np.arange(m)[None, :]
    blocks = rows * (p + 1) + cols  # (Do, M, M) flat positions of the diagonal blocks
    out = np.empty((n_t, n_prims, n_a, p + 1))
    for t in range(n_t):
        for k in range(n_prims):
            for a in range(n_a):
                buffer[:p, :p] = precision[t, k]
                flat[blocks] += scaled[t, a]
                buffer[:p, p] = b[t, k, a]  # (LAPACK reads the C array's upper triangle)
                buffer[p, p] = corner[t, k, a]
                factor, info = lapack.dpotrf(buffer.T, lower=1, clean=0, overwrite_a=1)
                if info != 0:
                    raise np.linalg.LinAlgError("Matrix is not positive definite")
                out[t, k, a] = flat[:: p + 2]
    return out


@dataclasses.dataclass(frozen=True)
class HeldOut:
    """Each trial's primitive refitted without its demonstration
    (:meth:`promp.fitting.FitParts.without`, vectorised): mean and slope (T, P), scatter lost
    (T, p, p), degrees of freedom (T,)."""

    mean: np.ndarray
    slope: np.ndarray
    drop: np.ndarray
    dof: np.ndarray
    vector: np.ndarray  # (T, p): drop = vector vector^T where rank_one
    rank_one: np.ndarray  # (T,) bool


def held_out(
    parts: Sequence[FitParts],
    model: ProMPModel,
    truth: np.ndarray,
    demos: np.ndarray,
    cols: np.ndarray,
) -> HeldOut:
    n_t, n_w = truth.shape[0], model.primitives[0].mean.shape[0]
    mean, slope = np.empty((n_t, n_w)), np.empty((n_t, n_w))
    drop, dof = np.empty((n_t, cols.shape[0], cols.shape[0])), np.empty(n_t, dtype=int)
    vector, rank_one = np.zeros((n_t, cols.shape[0])), np.zeros(n_t, dtype=bool)
    for k, (prim, part) in enumerate(zip(model.primitives, parts, strict=True)):
        mine = np.nonzero(truth == k)[0]
        if not mine.size:
            continue
        n = part.residuals.shape[0]
        if part.slope_weight > 0.0 and n - 1 < 3:  # the few: one at a time
            for t in mine:
                mean[t], slope[t], drop[t], dof[t] = part.without(
                    int(demos[t]), prim.mean, prim.alpha_slope, cols
                )
            continue
        rows = demos[mine]
        e, h = part.residuals[rows], part.leverage[rows]
        mean[mine] = prim.mean - e / (n * (1.0 - h))[:, None]
        slope[mine] = (
            prim.alpha_slope
            - (part.slope_weight * part.centred_log_alphas[rows] / (1.0 - h))[:, None] * e
        )
        e_o = e[:, cols]
        drop[mine] = e_o[:, :, None] * e_o[:, None, :] / (1.0 - h)[:, None, None]
        vector[mine], rank_one[mine] = e_o / np.sqrt(1.0 - h)[:, None], True
        dof[mine] = part.dof - 1
    return HeldOut(mean, slope, drop, dof, vector, rank_one)
