"""The whitened sufficient statistics of Eq. 6 at candidate speeds, and how they are kept
while an observation grows: what both forms of the likelihood read
(:mod:`promp.evidence.woodbury`, :mod:`promp.evidence.weight_space`).

For a candidate alpha (its duration D, the basis ``Psi`` at the phases ``elapsed / D``, the
prior mean ``mu(alpha)``) and an observed dimension d of noise group g (correlation time
``tau_g``, :func:`promp.noise.noise_groups`):

    gram_g = Psi^T K_g^-1 Psi,    proj_d = Psi^T K_g^-1 r_d,    rr_d = r_d^T K_g^-1 r_d,

``r_d = y_d - Psi mu_d(alpha)``, and ``log det K_g``. With ``K^-1 = W^T W``
(:func:`promp.noise.whiten`) each is a sum over the samples of products of whitened rows, and
the whitened row of sample i depends on samples i and i - 1 alone: the sums over the first n
samples extend to n + k by adding the terms of the k new samples
(:meth:`ObservationSums.rows`). Either way the residual is formed sample by sample rather than
expanded (``y^T K^-1 y - 2 mu^T Psi^T K^-1 y + ...`` cancels to a few digits).

**Kept while the observation grows.** A live movement is inferred on again each time samples
arrive, from every sample so far (:mod:`promp.live.predictor`), and at a candidate speed the
terms of the samples already observed do not change as more arrive (the basis at their phases,
their whitening, their residual). :class:`KeptSums` keeps each candidate's sums, and the sums of
a longer observation of the movement (:class:`ObservationSums`, which
:meth:`promp.evidence.Evidence.extended` makes) add only the new samples' terms: the work of an
update grows with the samples that arrived since the last one, not with the movement's length.
The numbers are those from every sample to round-off (only the order of the additions differs).
Recognition's quadrature nodes stay where they are while the movement is shorter than a
primitive's fastest plausible speeds, and past that the nodes beyond the bound are dropped,
never moved (:func:`promp.evidence.speed.anchored_nodes`): only the node at the bound and the
refined nodes around a best node that moved are new candidates, whose sums come from every
sample (:meth:`ObservationSums.dense`). An update of a 10 s movement at 250 Hz whitens ~10 rows
per sample instead of ~100 (``bench/live_update.py``).

One :class:`KeptSums` belongs to the evidences of one movement: no global cache. Given an
observation that does not extend the one it saw last, it forgets everything and starts again,
so a wrong one costs time, never a wrong number. Threads may share one: what it holds is read
and replaced under its lock, and computed outside it (as :mod:`promp._recent`'s caches are);
the sums of an observation that replaced the one they were computed for are not stored.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from promp.model import Primitive, ProMPModel
from promp.noise import correlation_steps, noise_groups
from promp.observation import Observation

__all__ = ["KeptSums", "ObservationSums", "WhitenedSums"]


@dataclass(frozen=True)
class WhitenedSums:
    """The statistics of A candidate speeds over ``n`` samples (see the module docstring).

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
    n : int
        The samples summed over.
    """

    gram: np.ndarray
    group: np.ndarray
    proj: np.ndarray
    rr: np.ndarray
    logdet_k: np.ndarray
    n: int


def _whitened(x: np.ndarray, rho: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``(x_i - rho_i x_(i-1)) / scale_i`` along the last axis of ``x`` (..., k + 1) (``rho``
    and ``scale`` of shape (..., k) broadcasting against it): the rows of
    :func:`promp.noise.whiten` after the first."""
    return (x[..., 1:] - rho * x[..., :-1]) / scale


@dataclass(frozen=True, eq=False)
class _NoiseTerms:
    """What the noise of ``primitive`` makes of one observation, whatever the candidate speed:
    its groups ({tau: positions in dims}, :func:`promp.noise.noise_groups`), each observed
    dimension's group and ``log det K`` (:class:`WhitenedSums`' ``group``, ``logdet_k``), and
    the whitening's steps between the samples (:func:`promp.noise.correlation_steps`)."""

    groups: dict[float, np.ndarray]
    group: np.ndarray
    logdet_k: np.ndarray
    rho: np.ndarray  # (G, n - 1)
    scale: np.ndarray  # (G, n - 1)

    @property
    def terms(self) -> tuple[np.ndarray, np.ndarray]:
        return self.group, self.logdet_k

    @classmethod
    def of(cls, primitive: Primitive, dims: np.ndarray, elapsed: np.ndarray) -> _NoiseTerms:
        groups = noise_groups(primitive, dims)
        rho, scale = correlation_steps(elapsed, np.array(list(groups), dtype=float))
        group = np.empty(dims.shape[0], dtype=int)
        logdet_k = np.empty(dims.shape[0])
        for index, (tau, cols) in enumerate(groups.items()):
            group[cols] = index
            logdet_k[cols] = 2.0 * np.log(scale[index]).sum() if tau > 0 else 0.0
        for array in (group, logdet_k, rho, scale):
            array.setflags(write=False)  # shared by every sums of the observation
        return cls(groups, group, logdet_k, rho, scale)


@dataclass(frozen=True)
class _Kept:
    """The sums of the candidates ``alphas`` over the first ``n`` samples, stored together
    (:class:`WhitenedSums`' arrays, read-only); ``row`` maps a candidate to its row."""

    n: int
    row: dict[float, int]
    gram: np.ndarray  # (A, n_groups, M, M)
    proj: np.ndarray  # (A, Do, M)
    rr: np.ndarray  # (A, Do)


@dataclass(frozen=True)
class _Found:
    """What :meth:`KeptSums.take` found of A candidates: ``starts`` (A,), the samples each
    one's sums are kept over (0: none), and those sums (rows of the candidates with
    ``starts > 0``, in order)."""

    starts: np.ndarray
    gram: np.ndarray
    proj: np.ndarray
    rr: np.ndarray


class KeptSums:
    """The candidates' sums of one growing observation, kept between its evidences (see the
    module docstring): those of the candidates scored at the latest two lengths of the
    observation; a candidate not scored in two updates is forgotten."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._elapsed = np.zeros(0)
        self._values = np.zeros((0, 0))
        self._generation = 0  # counts the observations it started again from
        self._kept: dict[tuple, list[_Kept]] = {}  # per key, the latest stored last
        self._latest = 0  # the length of the observation the latest sums were stored for
        self._previous = 0  # and of the one before

    @property
    def n_observed(self) -> int:
        """Samples of the longest observation seen since it last started again."""
        return int(self._elapsed.shape[0])

    def __len__(self) -> int:
        """Candidates whose sums are kept (at their latest length)."""
        with self._lock:
            return sum(len({a for k in ks for a in k.row}) for ks in self._kept.values())

    def adopt(self, elapsed: np.ndarray, values: np.ndarray) -> int:
        """Compare an observation with the one seen: start again unless one extends the
        other; keep the longer. Returns the generation its sums belong to."""
        with self._lock:
            seen = self._elapsed.shape[0]
            common = min(seen, elapsed.shape[0])
            same = (
                values.shape[1:] == self._values.shape[1:]
                and np.array_equal(elapsed[:common], self._elapsed[:common])
                and np.array_equal(values[:common], self._values[:common])
            )
            if not same:
                self._generation += 1
                self._kept.clear()
                self._latest = self._previous = 0
            if not same or elapsed.shape[0] > seen:
                self._elapsed, self._values = elapsed.copy(), values.copy()
            return self._generation

    def take(self, generation: int, key: tuple, alphas: np.ndarray, n: int) -> _Found:
        """The sums kept under ``key`` of each of ``alphas`` (A,) over at most ``n`` samples,
        the longest kept (none where the observation was replaced since ``generation``)."""
        starts = np.zeros(alphas.shape[0], dtype=int)
        with self._lock:
            stored = self._kept.get(key, []) if generation == self._generation else []
        picks: list[tuple[_Kept, int]] = []
        for i, a in enumerate(alphas.tolist()):
            for block in reversed(stored):  # the latest first
                row = block.row.get(a)
                if row is not None and block.n <= n:
                    starts[i] = block.n
                    picks.append((block, row))
                    break
        if not picks:
            return _Found(starts, *(np.zeros(0),) * 3)
        if all(block is picks[0][0] for block, _ in picks):  # the usual case: one block
            rows = [row for _, row in picks]
            block = picks[0][0]
            return _Found(starts, block.gram[rows], block.proj[rows], block.rr[rows])
        return _Found(starts, *(np.stack([getattr(b, f)[r] for b, r in picks])
                               for f in ("gram", "proj", "rr")))  # fmt: skip

    def store(self, generation: int, key: tuple, alphas: np.ndarray, sums: WhitenedSums) -> None:
        """Keep the candidates' sums, unless the observation was replaced meanwhile or a
        longer one was seen; forget those of two updates ago."""
        n = sums.n
        block = _Kept(n, {a: i for i, a in enumerate(alphas.tolist())},
                      sums.gram, sums.proj, sums.rr)  # fmt: skip
        with self._lock:
            if generation != self._generation or n < self._latest:
                return
            if n > self._latest:
                self._previous, self._latest = self._latest, n
                self._kept = {k: [b for b in bs if b.n >= self._previous]
                              for k, bs in self._kept.items()}  # fmt: skip
            self._kept.setdefault(key, []).append(block)


class ObservationSums:
    """The whitened sums of one observation at any candidate speeds (see the module
    docstring): each call computes those of the candidates asked for, from the sums kept of a
    shorter observation of the movement where there are some, and keeps them in turn.

    Parameters
    ----------
    model : ProMPModel
    observation : Observation
    dims : int array, shape (Do,)
        The model dimensions ``observation`` holds.
    kept : KeptSums, optional
        The sums kept of the movement's earlier observations (default: none yet).
    """

    def __init__(
        self,
        model: ProMPModel,
        observation: Observation,
        dims: np.ndarray,
        kept: KeptSums | None = None,
    ) -> None:
        self.model, self.dims = model, dims
        self.elapsed, self.values = observation.elapsed, observation.values
        self.kept = KeptSums() if kept is None else kept
        self._generation = self.kept.adopt(self.elapsed, self.values)
        self._key = tuple(dims.tolist())
        self._noise: dict[Primitive, _NoiseTerms] = {}  # computed once per primitive
        self._noise_of: dict[bytes, _NoiseTerms] = {}  # and per correlation times

    def _noise_terms(self, primitive: Primitive) -> _NoiseTerms:
        """The noise's terms of this observation under ``primitive`` (computed on first use:
        they do not depend on the candidate speed, only on the dimensions' correlation
        times)."""
        got = self._noise.get(primitive)
        if got is None:  # primitives whose noise has the same correlation times share them
            taus = primitive.noise_tau[self.dims].tobytes()
            got = self._noise_of.get(taus)
            if got is None:
                got = self._noise_of[taus] = _NoiseTerms.of(primitive, self.dims, self.elapsed)
            self._noise[primitive] = got
        return got

    def __call__(
        self, primitive: Primitive, alphas: np.ndarray, durations: np.ndarray
    ) -> WhitenedSums:
        """:class:`WhitenedSums` at the candidates ``alphas`` and their ``durations`` (A,)
        (each at least as long as the observation): those kept of a shorter observation
        extended by the new samples' terms, the others from every sample; kept in turn."""
        key = (primitive, self._key)
        found = self.kept.take(self._generation, key, alphas, self.elapsed.shape[0])
        if not found.starts.any():
            sums = self.dense(primitive, alphas, durations)
        else:
            sums = self._extended(primitive, alphas, durations, found)
        for array in (sums.gram, sums.proj, sums.rr):
            array.setflags(write=False)  # rows of it are kept: read, never written
        self.kept.store(self._generation, key, alphas, sums)
        return sums

    def _extended(
        self, primitive: Primitive, alphas: np.ndarray, durations: np.ndarray, found: _Found
    ) -> WhitenedSums:
        """The sums of candidates kept over their first ``found.starts`` samples (A,): the
        kept ones plus the new samples' terms (:meth:`rows`); the others (``starts == 0``)
        from every sample (:meth:`dense`)."""
        n, m, starts = self.elapsed.shape[0], self.model.basis.n_basis, found.starts
        group, logdet_k = self._noise_terms(primitive).terms
        gram = np.empty((alphas.shape[0], int(group.max()) + 1, m, m))
        proj = np.empty((alphas.shape[0], self.dims.shape[0], m))
        rr = np.empty((alphas.shape[0], self.dims.shape[0]))
        for start in np.unique(starts).tolist():
            which = np.flatnonzero(starts == start)
            if start == n:  # nothing new
                gram[which], proj[which], rr[which] = 0.0, 0.0, 0.0
            else:
                some = (primitive, alphas[which], durations[which])
                part = self.dense(*some) if start == 0 else self.rows(*some, start)
                gram[which], proj[which], rr[which] = part.gram, part.proj, part.rr
        had = starts > 0  # and the sums of the samples before, kept
        gram[had] += found.gram
        proj[had] += found.proj
        rr[had] += found.rr
        return WhitenedSums(gram, group, proj, rr, logdet_k, n)

    def dense(
        self, primitive: Primitive, alphas: np.ndarray, durations: np.ndarray
    ) -> WhitenedSums:
        """:class:`WhitenedSums` of the observation from all its samples at once: the basis at
        the observed phases from the model's cache (:class:`promp.basis.PhaseBasisCache`);
        the terms of the first sample (whitened as it is) and those of the others
        (:meth:`_terms`)."""
        psi = self.model.phase_basis(self.elapsed, durations).swapaxes(-1, -2)  # (A, M, n)
        mu = self._mean(primitive, alphas)
        sums = self._terms(primitive, mu, psi, 0)
        first = psi[..., 0]  # (A, M): the first sample's row, the same in every group
        resid = self.values[0][None, :] - np.einsum("adm,am->ad", mu, first)  # (A, Do)
        sums.gram[...] += (first[:, :, None] * first[:, None, :])[:, None]
        sums.proj[...] += resid[:, :, None] * first[:, None, :]
        sums.rr[...] += resid**2
        return sums

    def rows(
        self, primitive: Primitive, alphas: np.ndarray, durations: np.ndarray, start: int
    ) -> WhitenedSums:
        """The terms of the samples ``start, ..., n - 1`` (0 < start < n) in the sums of
        :class:`WhitenedSums`; ``group`` and ``logdet_k`` of all n samples (:meth:`_terms`,
        with the basis, :meth:`promp.basis.RBFBasis.columns`, from the sample before)."""
        times = self.elapsed[start - 1 :]  # from the sample before the part, for its whitening
        psi = self.model.basis.columns(times[None, :] / durations[:, None])  # (A, M, k + 1)
        return self._terms(primitive, self._mean(primitive, alphas), psi, start)

    def _mean(self, primitive: Primitive, alphas: np.ndarray) -> np.ndarray:
        """The prior mean weights of the observed dimensions at ``alphas`` (A,): (A, Do, M)."""
        model = self.model
        mean = primitive.mean_at(alphas).reshape(alphas.shape[0], model.n_dims, -1)
        return mean[:, self.dims]

    def _terms(
        self, primitive: Primitive, mu: np.ndarray, psi: np.ndarray, start: int
    ) -> WhitenedSums:
        """The whitened rows' terms of the samples ``max(start, 1), ..., n - 1`` in the sums
        of :class:`WhitenedSums` (``group`` and ``logdet_k`` of all n samples), from the prior
        mean weights ``mu`` (A, Do, M) and the basis ``psi`` (A, M, k + 1) at the samples
        ``max(start - 1, 0), ..., n - 1`` (each row is whitened with the sample before it).

        The numbers of :func:`promp.noise.whiten` but for the order of the additions: the
        whitening for every noise group at once, with the samples along the contiguous axis,
        so that a sample costs a few operations per candidate, and a call a few dozen numpy
        operations whatever the number of samples.
        """
        lead = max(start - 1, 0)
        n_cand, m = mu.shape[0], mu.shape[2]
        noise = self._noise_terms(primitive)
        groups, (group, logdet_k) = noise.groups, noise.terms
        rho, scale = noise.rho[:, lead:], noise.scale[:, lead:]  # (G, k)
        # the whitened basis of every group (A, G, M, k), and the whitened values (Do, k)
        psi_w = _whitened(psi[:, None], rho[:, None], scale[:, None])
        y_w = _whitened(self.values[lead:].T, rho[group], scale[group])
        gram = psi_w @ psi_w.swapaxes(-1, -2)  # (A, G, M, M)
        proj = np.empty((n_cand, self.dims.shape[0], m))
        rr = np.empty((n_cand, self.dims.shape[0]))
        for index, cols in enumerate(groups.values()):
            basis = psi_w[:, index]  # (A, M, k)
            resid = y_w[cols] - mu[:, cols] @ basis  # (A, Dg, k)
            proj[:, cols] = resid @ basis.swapaxes(-1, -2)
            rr[:, cols] = np.einsum("adk,adk->ad", resid, resid)
        return WhitenedSums(gram, group, proj, rr, logdet_k, self.elapsed.shape[0])
