"""The whitened sufficient statistics of Eq. 6 at candidate speeds: what both forms of the
likelihood read (:mod:`promp._weight_space`, :func:`promp._likelihood.rotate`).

For a candidate alpha (its duration D, the basis ``Psi`` at the phases ``elapsed / D``, the
prior mean ``mu(alpha)``) and an observed dimension d of noise group g (correlation time
``tau_g``, :func:`promp.noise.noise_groups`):

    gram_g = Psi^T K_g^-1 Psi,    proj_d = Psi^T K_g^-1 r_d,    rr_d = r_d^T K_g^-1 r_d,

``r_d = y_d - Psi mu_d(alpha)``, and ``log det K_g``. With ``K^-1 = W^T W``
(:func:`promp.noise.whiten`) each is a sum over the samples of products of whitened rows, and
the whitened row of sample i depends on samples i and i - 1 alone: the sums over the first n
samples extend to n + k by adding the terms of the k new samples
(:class:`promp.incremental.IncrementalStatistics` does it for a growing observation).
:func:`dense_sums` computes them from every sample at once, in one product: the reference.
Either way the residual is formed sample by sample rather than expanded (``y^T K^-1 y -
2 mu^T Psi^T K^-1 y + ...`` cancels to a few digits).

**One order of the additions** (:func:`folded_sums`, what the likelihood reads): the samples
in blocks of :data:`BLOCK` from the first, each block's terms summed by one product of the
same shape, the blocks added in turn, the last (partial) block added last. The sums of a
growing observation are then the same numbers, bit for bit, whether computed at once or
extended from the complete blocks kept of its first samples; otherwise they differ by
round-off, which the likelihood amplifies (it is a small difference of large whitened sums:
1e-8 nats on flt with some settings), and a live prediction would not equal the offline one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from promp.model import Primitive, ProMPModel
from promp.noise import correlation_steps, log_det_correlation, noise_groups, whiten
from promp.observation import Observation

BLOCK = 32  # samples summed by one product (module docstring)


@dataclass(frozen=True)
class WhitenedSums:
    """The statistics of A candidate speeds (see the module docstring).

    Attributes
    ----------
    gram : array, shape (A, n_groups, M, M)
        ``Psi^T K^-1 Psi`` of each noise group.
    group : int array, shape (Do,)
        The noise group of each observed dimension.
    proj : array, shape (A, Do, M)
        ``Psi^T K^-1 r`` of each observed dimension.
    rr : array, shape (A, Do)
        ``r^T K^-1 r``.
    logdet_k : array, shape (Do,)
        ``log det K``.
    """

    gram: np.ndarray
    group: np.ndarray
    proj: np.ndarray
    rr: np.ndarray
    logdet_k: np.ndarray


def dense_sums(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    dims: np.ndarray,
    alphas: np.ndarray,
    durations: np.ndarray,
) -> WhitenedSums:
    """:class:`WhitenedSums` of ``obs`` from all its samples at once.

    Parameters
    ----------
    dims : int array, shape (Do,)
        The observed model dimensions.
    alphas, durations : array, shape (A,)
        Candidate time modulations and their durations (each at least as long as ``obs``).
    """
    m = model.basis.n_basis
    n_cand, n_do = alphas.shape[0], dims.shape[0]
    psi = model.phase_basis(obs.elapsed, durations)  # (A, n, M)
    mu = primitive.mean_at(alphas).reshape(n_cand, model.n_dims, m)[:, dims]  # (A, Do, M)
    groups = noise_groups(primitive, dims)
    gram = np.empty((n_cand, len(groups), m, m))
    group = np.empty(n_do, dtype=int)
    proj = np.empty((n_cand, n_do, m))
    rr = np.empty((n_cand, n_do))
    logdet_k = np.empty(n_do)
    for index, (tau, cols) in enumerate(groups.items()):
        psi_w, logdet = whiten(obs.elapsed, tau, psi)
        y_w, _ = whiten(obs.elapsed, tau, obs.values[:, cols])
        resid = y_w[None] - psi_w @ mu[:, cols].transpose(0, 2, 1)  # (A, n, Dg)
        gram[:, index] = psi_w.transpose(0, 2, 1) @ psi_w
        group[cols] = index
        proj[:, cols] = (psi_w.transpose(0, 2, 1) @ resid).transpose(0, 2, 1)
        rr[:, cols] = (resid**2).sum(axis=1)
        logdet_k[cols] = logdet
    return WhitenedSums(gram, group, proj, rr, logdet_k)


def _whitened(x: np.ndarray, rho: np.ndarray, scale: np.ndarray, whole: bool) -> np.ndarray:
    """``(x_i - rho_i x_(i-1)) / scale_i`` along the last axis of ``x`` (..., k) (``rho`` and
    ``scale`` of shape (..., k - 1) broadcasting against it), preceded by ``x_0`` itself when
    ``x`` starts the observation (``whole``): the rows of :func:`promp.noise.whiten`."""
    rest = (x[..., 1:] - rho * x[..., :-1]) / scale
    if not whole:
        return rest
    out = np.empty(rest.shape[:-1] + (rest.shape[-1] + 1,))
    out[..., :1] = x[..., :1]
    out[..., 1:] = rest
    return out


def noise_terms(
    primitive: Primitive, dims: np.ndarray, elapsed: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:class:`WhitenedSums`' ``group`` and ``logdet_k`` of the samples at ``elapsed`` (n,)."""
    group = np.empty(dims.shape[0], dtype=int)
    logdet_k = np.empty(dims.shape[0])
    for index, (tau, cols) in enumerate(noise_groups(primitive, dims).items()):
        group[cols] = index
        logdet_k[cols] = log_det_correlation(elapsed, tau)
    return group, logdet_k


@dataclass(frozen=True)
class Folded:
    """The sums of A candidates over the complete blocks of the first ``n`` samples (``n`` a
    multiple of :data:`BLOCK`): what a growing observation's next sums extend; and the
    whitened rows of the samples after them that were seen (the partial block, fewer than
    :data:`BLOCK`), so that an extension whitens only the samples new since."""

    n: int
    gram: np.ndarray  # (A, n_groups, M, M)
    proj: np.ndarray  # (A, Do, M)
    rr: np.ndarray  # (A, Do)
    psi_tail: np.ndarray | None = None  # (A, n_groups, M, r): the whitened basis
    y_tail: np.ndarray | None = None  # (Do, r): the whitened values

    @property
    def seen(self) -> int:
        """The samples whose whitened rows it holds or summed."""
        return self.n + (0 if self.y_tail is None else self.y_tail.shape[-1])


def folded_sums(
    model: ProMPModel,
    primitive: Primitive,
    elapsed: np.ndarray,
    values: np.ndarray,
    dims: np.ndarray,
    alphas: np.ndarray,
    durations: np.ndarray,
    base: Folded | None = None,
) -> tuple[WhitenedSums, Folded]:
    """:class:`WhitenedSums` of the n samples ``elapsed`` (n,), ``values`` (n, Do) in the one
    order of the additions (module docstring), extending ``base``, the folded sums of their
    first ``base.n`` samples (None: from the first sample); and the folded sums of their
    complete blocks, for the next extension.

    Parameters
    ----------
    elapsed : array, shape (n,)
        The observation's times from its first sample.
    values : array, shape (n, Do)
    dims : int array, shape (Do,)
        The observed model dimensions.
    alphas, durations : array, shape (A,)
        Candidate time modulations and their durations (each at least as long as the
        observation).
    base : Folded, optional
        Of the same A candidates.
    """
    n = elapsed.shape[0]
    m = model.basis.n_basis
    n_cand, n_do = alphas.shape[0], dims.shape[0]
    start = 0 if base is None else base.n
    end = max((n // BLOCK) * BLOCK, start)
    groups = noise_groups(primitive, dims)
    taus = np.array(list(groups))
    group, logdet_k = noise_terms(primitive, dims, elapsed)
    n_groups = len(groups)
    if base is None:
        gram = np.zeros((n_cand, n_groups, m, m))
        proj = np.zeros((n_cand, n_do, m))
        rr = np.zeros((n_cand, n_do))
    else:
        gram, proj, rr = base.gram.copy(), base.proj.copy(), base.rr.copy()
    if start == n:  # every sample in the complete blocks: no rows after them
        folded = Folded(start, gram.copy(), proj.copy(), rr.copy(),
                        np.empty((n_cand, n_groups, m, 0)), np.empty((n_do, 0)))  # fmt: skip
        return WhitenedSums(gram, group, proj, rr, logdet_k), folded
    # the whitened rows of the samples start..n-1: those the base holds, then the new ones
    have = start if base is None or base.y_tail is None else min(base.seen, n)
    if have > start:
        psi_w, y_w = base.psi_tail[..., : have - start], base.y_tail[:, : have - start]
    if have < n:
        first = max(have - 1, 0)  # the sample before the new ones, for their whitening
        times = elapsed[first:]
        if have == 0:  # the basis rows of the whole observation: cached while scrubbing
            rows = model.phase_basis(times, durations)
        else:  # the same function on the rows after those kept (the cache's miss path)
            z = (times[None, :] / durations[:, None]).reshape(-1)
            rows = model.basis(z).reshape(n_cand, times.shape[0], m)
        rho, scale = correlation_steps(times, taus)  # (G, k - 1)
        new_psi = _whitened(rows.swapaxes(-1, -2)[:, None], rho[:, None], scale[:, None],
                            have == 0)  # (A, G, M, n - have)  # fmt: skip
        new_y = _whitened(values[first:].T, rho[group], scale[group], have == 0)  # (Do, ...)
        if have > start:
            new_psi = np.concatenate([psi_w, new_psi], axis=-1)
            new_y = np.concatenate([y_w, new_y], axis=-1)
        psi_w, y_w = new_psi, new_y
    mu = primitive.mean_at(alphas).reshape(n_cand, model.n_dims, m)[:, dims]  # (A, Do, M)
    complete = end - start
    if complete:  # the blocks added in turn (a cumulative sum is one in order)
        g, p, r = _block_terms(psi_w[..., :complete], y_w[:, :complete], mu, groups, BLOCK)
        if base is not None:
            g = np.concatenate([gram[:, :, None], g], axis=2)
            p = np.concatenate([proj[:, None], p], axis=1)
            r = np.concatenate([rr[:, None], r], axis=1)
        gram = np.cumsum(g, axis=2)[:, :, -1]
        proj = np.cumsum(p, axis=1)[:, -1]
        rr = np.cumsum(r, axis=1)[:, -1]
    tail_psi, tail_y = psi_w[..., complete:], y_w[:, complete:]
    folded = Folded(end, gram.copy(), proj.copy(), rr.copy(), tail_psi.copy(), tail_y.copy())
    if end < n:  # the partial block, last
        g, p, r = _block_terms(tail_psi, tail_y, mu, groups, n - end)
        gram += g[:, :, 0]
        proj += p[:, 0]
        rr += r[:, 0]
    return WhitenedSums(gram, group, proj, rr, logdet_k), folded


def _block_terms(
    psi_w: np.ndarray, y_w: np.ndarray, mu: np.ndarray, groups: dict, width: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each block's terms: the whitened basis ``psi_w`` (A, G, M, k) and values ``y_w``
    (Do, k), k a multiple of ``width``, cut into blocks of ``width`` samples, and the prior
    means ``mu`` (A, Do, M). Every block's residual and sums are products of the same shapes
    on contiguous copies, so a block's numbers do not depend on the blocks computed with it.
    Returns gram (A, G, nb, M, M), proj (A, nb, Do, M) and rr (A, nb, Do)."""
    n_cand, n_groups, m, k = psi_w.shape
    n_blocks, n_do = k // width, y_w.shape[0]
    pb = np.ascontiguousarray(
        psi_w.reshape(n_cand, n_groups, m, n_blocks, width).transpose(0, 1, 3, 2, 4)
    )  # (A, G, nb, M, w)
    yb = np.ascontiguousarray(y_w.reshape(n_do, n_blocks, width).transpose(1, 0, 2))  # (nb, Do, w)
    gram = pb @ pb.swapaxes(-1, -2)
    proj = np.empty((n_cand, n_blocks, n_do, m))
    rr = np.empty((n_cand, n_blocks, n_do))
    for index, cols in enumerate(groups.values()):
        basis = pb[:, index]  # (A, nb, M, w)
        resid = yb[None, :, cols] - np.ascontiguousarray(mu[:, None, cols]) @ basis
        proj[:, :, cols] = resid @ basis.swapaxes(-1, -2)
        rr[:, :, cols] = (resid * resid).sum(axis=-1)
    return gram, proj, rr
