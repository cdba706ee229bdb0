"""What the likelihood keeps of a growing observation between two inferences on it.

A live movement is inferred on again each time samples arrive, from every sample so far
(:mod:`promp.live.predictor`). The likelihood of Eq. 6 reads sums over the samples
(:mod:`promp._statistics`: ``Psi^T K^-1 Psi``, ``Psi^T K^-1 r``, ``r^T K^-1 r``), and at a
candidate speed the terms of the samples already observed do not change as more arrive (the
basis at their phases, their whitening, their residual). :class:`IncrementalStatistics` keeps
each candidate's sums and adds only the new samples' terms: the work of an update grows with
the samples that arrived since the last one, not with the movement's length. The numbers are
the dense computation's to round-off (only the order of the additions differs):
:func:`promp.pipeline.infer` given one returns what it returns without, within 1e-9.

Which candidates come back from one update to the next: recognition's quadrature nodes
(:mod:`promp.recognition`) stay where they are while the movement is shorter than the
durations of a primitive's fastest plausible speeds, and so do the refined nodes while the
best node does. Past that, the nodes beyond the fastest speed that still contains the
observation are dropped, never moved (:func:`promp.recognition.anchored_nodes`): only the
node at that bound, which moves with each sample, and the refined nodes around a best node
that moved are new candidates, whose sums are computed from every sample
(:func:`promp._statistics.row_sums`, a few operations per sample and candidate), as are the
conditioning's at the estimated speed when it changes. An update of a 10 s movement at
250 Hz whitens ~10 rows per sample instead of ~100 (``bench/live_update.py``).

The caller owns one per movement: no global cache. Given an observation that does not extend
the one it saw last (a new movement, or another one altogether), it forgets everything and
starts again, so a wrong one costs time, never a wrong number. Threads may share one (the
studio infers on several): what it holds is read and replaced under its lock, and computed
outside it (as :mod:`promp._recent`'s caches are); the sums of an observation that replaced
the one they were computed for are not stored.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from promp._statistics import WhitenedSums, dense_sums, noise_terms, row_sums
from promp.model import Primitive, ProMPModel
from promp.observation import Observation

__all__ = ["IncrementalStatistics", "whitened_sums"]


@dataclass(frozen=True)
class _Sums:
    """One candidate's sums over the first ``n`` samples (:class:`WhitenedSums`' rows)."""

    n: int
    gram: np.ndarray  # (n_groups, M, M)
    proj: np.ndarray  # (Do, M)
    rr: np.ndarray  # (Do,)


class IncrementalStatistics:
    """The likelihood's sums of one growing observation (see the module docstring).

    Pass the same one to every :func:`promp.pipeline.infer` (or
    :func:`promp.recognition.recognise`, :func:`promp.inference.log_likelihoods`) on the
    movement's observation as it grows::

        statistics = IncrementalStatistics()
        for times, values in movement_so_far:  # each update: every sample so far
            inference = infer(model, Observation(times, values, modalities),
                              statistics=statistics)

    It keeps the sums of the candidates scored at the latest two lengths of the observation;
    a candidate not scored in two updates is forgotten.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._elapsed = np.zeros(0)
        self._values = np.zeros((0, 0))
        self._generation = 0  # counts the observations it started again from
        self._entries: dict[tuple, _Sums] = {}
        self._latest = 0  # the length of the observation the latest sums were stored for
        self._previous = 0  # and of the one before

    @property
    def n_observed(self) -> int:
        """Samples of the longest observation seen since it last started again."""
        return int(self._elapsed.shape[0])

    def __len__(self) -> int:
        """Candidates whose sums are kept."""
        return len(self._entries)

    def sums(
        self,
        model: ProMPModel,
        primitive: Primitive,
        obs: Observation,
        dims: np.ndarray,
        alphas: np.ndarray,
        durations: np.ndarray,
    ) -> WhitenedSums:
        """:class:`promp._statistics.WhitenedSums` of ``obs`` at the candidates: those it kept
        extended by the new samples' terms, the others from every sample.

        Parameters
        ----------
        model : ProMPModel
        primitive : Primitive
            One of ``model``'s.
        obs : Observation
        dims : int array, shape (Do,)
            The observed model dimensions.
        alphas, durations : array, shape (A,)
            Candidate time modulations and their durations (each at least as long as
            ``obs``).
        """
        elapsed, values = obs.elapsed, obs.values
        n = elapsed.shape[0]
        key = (primitive, model.basis, tuple(dims.tolist()))
        with self._lock:
            generation = self._adopt(elapsed, values)
            kept = [self._entries.get((*key, a, d))
                    for a, d in zip(alphas.tolist(), durations.tolist(), strict=True)]  # fmt: skip
        starts = np.array([e.n if e is not None and e.n <= n else 0 for e in kept], dtype=int)
        n_cand, n_do, m = alphas.shape[0], dims.shape[0], model.basis.n_basis
        group, logdet_k = noise_terms(primitive, dims, elapsed)
        gram = np.empty((n_cand, int(group.max()) + 1, m, m))
        proj = np.empty((n_cand, n_do, m))
        rr = np.empty((n_cand, n_do))
        for start in np.unique(starts).tolist():
            which = np.flatnonzero(starts == start)
            if start < n:
                part = row_sums(model, primitive, elapsed, values, dims, alphas[which],
                                durations[which], start)  # fmt: skip
                gram[which], proj[which], rr[which] = part.gram, part.proj, part.rr
            else:
                gram[which], proj[which], rr[which] = 0.0, 0.0, 0.0
            if start > 0:  # the sums of the samples before
                gram[which] += np.stack([kept[i].gram for i in which])
                proj[which] += np.stack([kept[i].proj for i in which])
                rr[which] += np.stack([kept[i].rr for i in which])
        for kept_array in (gram, proj, rr):
            kept_array.setflags(write=False)  # rows of it are kept: read, never written
        self._store(generation, n, key, alphas, durations, gram, proj, rr)
        return WhitenedSums(gram, group, proj, rr, logdet_k)

    def _adopt(self, elapsed: np.ndarray, values: np.ndarray) -> int:
        """Compare the observation with the one seen (under the lock): start again unless one
        extends the other; keep the longer. Returns the generation the sums belong to."""
        seen = self._elapsed.shape[0]
        common = min(seen, elapsed.shape[0])
        same = (
            values.shape[1:] == self._values.shape[1:]
            and np.array_equal(elapsed[:common], self._elapsed[:common])
            and np.array_equal(values[:common], self._values[:common])
        )
        if not same:
            self._generation += 1
            self._entries.clear()
            self._latest = self._previous = 0
        if not same or elapsed.shape[0] > seen:
            self._elapsed, self._values = elapsed.copy(), values.copy()
        return self._generation

    def _store(
        self,
        generation: int,
        n: int,
        key: tuple,
        alphas: np.ndarray,
        durations: np.ndarray,
        gram: np.ndarray,
        proj: np.ndarray,
        rr: np.ndarray,
    ) -> None:
        """Keep the candidates' sums over ``n`` samples, unless the observation was replaced
        meanwhile or a longer one was seen; forget those of two updates ago."""
        with self._lock:
            if generation != self._generation or n < self._latest:
                return
            if n > self._latest:
                self._previous, self._latest = self._latest, n
                self._entries = {k: e for k, e in self._entries.items()
                                 if e.n >= self._previous}  # fmt: skip
            for i, (a, d) in enumerate(zip(alphas.tolist(), durations.tolist(), strict=True)):
                self._entries[(*key, a, d)] = _Sums(n, gram[i], proj[i], rr[i])


def whitened_sums(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    dims: np.ndarray,
    alphas: np.ndarray,
    durations: np.ndarray,
    statistics: IncrementalStatistics | None = None,
) -> WhitenedSums:
    """:class:`WhitenedSums` of ``obs``: extended from the sums ``statistics`` kept of its
    first samples when given (:class:`IncrementalStatistics`), otherwise
    from every sample (:func:`promp._statistics.dense_sums`). Parameters as
    :func:`promp._statistics.dense_sums`."""
    if statistics is not None:
        return statistics.sums(model, primitive, obs, dims, alphas, durations)
    return dense_sums(model, primitive, obs, dims, alphas, durations)
