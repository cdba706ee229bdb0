"""The whitened sufficient statistics of Eq. 6 at candidate speeds: what both forms of the
likelihood read (:mod:`promp._weight_space`, :func:`promp._likelihood.rotate`).

For a candidate alpha (its duration D, the basis ``Psi`` at the phases ``elapsed / D``, the
prior mean ``mu(alpha)``) and an observed dimension d of noise group g (correlation time
``tau_g``, :func:`promp.noise.noise_groups`):

    gram_g = Psi^T K_g^-1 Psi,    proj_d = Psi^T K_g^-1 r_d,    rr_d = r_d^T K_g^-1 r_d,

``r_d = y_d - Psi mu_d(alpha)``, and ``log det K_g``. With ``K^-1 = W^T W``
(:func:`promp.noise.whiten`) each is a sum over the samples of products of whitened rows, and
the whitened row of sample i depends on samples i and i - 1 alone: the sums over the first n
samples extend to n + k by adding the terms of the k new samples (:func:`row_sums` from a
start row; :class:`promp.incremental.IncrementalStatistics` does it for a growing
observation). :func:`dense_sums` computes them from every sample at once: the reference, and
the path of an observation scored once. Either way the residual is formed sample by sample
rather than expanded (``y^T K^-1 y - 2 mu^T Psi^T K^-1 y + ...`` cancels to a few digits).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from promp.model import Primitive, ProMPModel
from promp.noise import correlation_steps, log_det_correlation, noise_groups, whiten
from promp.observation import Observation


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


def row_sums(
    model: ProMPModel,
    primitive: Primitive,
    elapsed: np.ndarray,
    values: np.ndarray,
    dims: np.ndarray,
    alphas: np.ndarray,
    durations: np.ndarray,
    start: int,
) -> WhitenedSums:
    """The terms of the samples ``start, ..., n - 1`` in the sums of :class:`WhitenedSums`
    (``start = 0``: the sums of the whole observation); ``group`` and ``logdet_k`` of all n
    samples.

    The numbers of :func:`dense_sums` but for the order of the additions: the basis
    (:meth:`promp.basis.RBFBasis.columns`) and its whitening for every noise group at once
    (the steps of :func:`promp.noise.whiten`), with the samples along the contiguous axis,
    so that a sample costs a few operations per candidate, and a call a few dozen numpy
    operations whatever the number of samples.

    Parameters
    ----------
    elapsed : array, shape (n,)
        The observation's times from its first sample.
    values : array, shape (n, Do)
    dims : int array, shape (Do,)
    alphas, durations : array, shape (A,)
    start : int
        The first sample whose terms are wanted (0 <= start < n).
    """
    m = model.basis.n_basis
    n_cand, n_do = alphas.shape[0], dims.shape[0]
    groups = noise_groups(primitive, dims)
    taus = np.array(list(groups))
    group, logdet_k = noise_terms(primitive, dims, elapsed)
    first = max(start - 1, 0)  # the sample before the part, for its whitening
    times = elapsed[first:]
    psi = model.basis.columns(times[None, :] / durations[:, None])  # (A, M, k)
    mu = primitive.mean_at(alphas).reshape(n_cand, model.n_dims, m)[:, dims]  # (A, Do, M)
    rho, scale = correlation_steps(times, taus)  # (G, k - 1)
    # the whitened basis of every group (A, G, M, k'), and the whitened values (Do, k')
    psi_w = _whitened(psi[:, None], rho[:, None], scale[:, None], start == 0)
    y_w = _whitened(values[first:].T, rho[group], scale[group], start == 0)
    gram = psi_w @ psi_w.swapaxes(-1, -2)  # (A, G, M, M)
    proj = np.empty((n_cand, n_do, m))
    rr = np.empty((n_cand, n_do))
    for index, cols in enumerate(groups.values()):
        basis = psi_w[:, index]  # (A, M, k')
        resid = y_w[cols] - mu[:, cols] @ basis  # (A, Dg, k')
        proj[:, cols] = resid @ basis.swapaxes(-1, -2)
        rr[:, cols] = np.einsum("adk,adk->ad", resid, resid)
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
