"""Open-end dynamic time warping of an observation against reference movements.

The observation (the first samples of a movement) is aligned with the beginning of each
reference; the alignment may end anywhere in the reference (open end, Tormene et al., 2009):
with the local cost ``c(i, j) = ||q_i - r_j||`` (Euclidean) and the cumulative cost

    D(0, 0) = c(0, 0),  D(i, j) = c(i, j) + min(D(i-1, j-1), D(i-1, j), D(i, j-1)),

the distance to a reference of ``m`` samples is ``min_j D(n-1, j)`` over ``j < m`` (the last row,
every end). Both sequences start at their first sample (the start is anchored).

Row ``i`` of ``D`` depends on the observation's first ``i + 1`` samples only, so the distances
of a growing observation are computed sample by sample (:class:`OpenEndDTW`: each new sample
costs one row, whatever came before), and those of every shorter observation come with them.

Vectorised over the references, one observation row at a time: within a row the horizontal
step makes ``D(i, .)`` a running minimum, ``D(i, j) = S(j) + min_{k<=j} (E(k) - S(k))`` with
``S`` the row's cumulative local cost and ``E(k) = c(i, k) + min(D(i-1, k-1), D(i-1, k))``,
which ``numpy.minimum.accumulate`` computes for every reference at once.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from promp.baselines.relative import check_movement

__all__ = ["open_end_dtw", "OpenEndDTW"]


class OpenEndDTW:
    """Open-end DTW of a growing observation against fixed references.

    Parameters
    ----------
    references : sequence of arrays, shape (m_r, D)
        The reference movements, each m_r >= 1, finite, all with D columns.

    Attributes
    ----------
    distances : array, shape (n_observed, n_references)
        Row ``i``: the open-end distance of the observation's first ``i + 1`` samples to
        every reference, ``min_j D(i, j)``.
    """

    def __init__(self, references: Sequence[np.ndarray]):
        if len(references) == 0:
            raise ValueError("open-end DTW needs at least one reference movement")
        refs = [check_movement(r, f"reference {i}", min_samples=1)
                for i, r in enumerate(references)]  # fmt: skip
        widths = {r.shape[1] for r in refs}
        if len(widths) != 1:
            raise ValueError(f"the references have different numbers of columns {sorted(widths)}")
        lengths = np.array([r.shape[0] for r in refs])
        n_refs, m = len(refs), int(lengths.max())
        # Padded to the longest: a padded column never reaches a real one (D(i, j) depends on
        # columns <= j only), and the minima are taken over each reference's own columns (the
        # padded ones get +inf added). One column per dimension, contiguous: (D, R, m).
        columns = np.zeros((widths.pop(), n_refs, m))
        for k, r in enumerate(refs):
            columns[:, k, : r.shape[0]] = r.T
        self._columns = columns
        self._outside = np.where(np.arange(m)[None, :] >= lengths[:, None], np.inf, 0.0)
        # D(i, .) of the last sample taken, after a column of +inf: [:, :-1] is D(i, j - 1)
        # seen from column j, [:, 1:] is D(i, j).
        self._row = np.full((n_refs, m + 1), np.inf)
        self.distances = np.empty((0, n_refs))

    @property
    def n_observed(self) -> int:
        """Samples of the observation taken so far."""
        return self.distances.shape[0]

    @property
    def ends(self) -> np.ndarray:
        """Where in each reference (a sample index, shape (n_references,)) the best alignment
        of the whole observation so far ends."""
        if self.n_observed == 0:
            raise ValueError("no observation taken yet")
        return np.argmin(self._row[:, 1:] + self._outside, axis=1)

    def _local_cost(self, sample: np.ndarray) -> np.ndarray:
        """``c(i, j) = ||sample - r_j||`` for every reference: (R, m)."""
        total = np.zeros(self._columns.shape[1:])
        for column, value in zip(self._columns, sample, strict=True):
            difference = column - value
            difference *= difference
            total += difference
        return np.sqrt(total, out=total)

    def extend(self, samples: np.ndarray) -> OpenEndDTW:
        """Take the next samples of the observation (n_new, D) and return self.

        Raises
        ------
        ValueError
            Not (n_new, D), or NaN or infinite values (nothing is taken then).
        """
        new = check_movement(samples, "the observation", min_samples=0)
        if new.shape[1] != self._columns.shape[0]:
            raise ValueError(f"the observation has {new.shape[1]} columns, the references "
                             f"{self._columns.shape[0]}")  # fmt: skip
        distances = np.empty((new.shape[0], self._row.shape[0]))
        for i, sample in enumerate(new):
            c = self._local_cost(sample)
            s = np.cumsum(c, axis=1)
            if self.n_observed + i == 0:
                row = s  # D(0, j): horizontal steps from (0, 0)
            else:
                entry = np.minimum(self._row[:, :-1], self._row[:, 1:])  # the row above
                entry += c  # E(j)
                entry -= s
                row = np.minimum.accumulate(entry, axis=1, out=entry)
                row += s
            self._row[:, 1:] = row
            distances[i] = (row + self._outside).min(axis=1)
        self.distances = np.concatenate([self.distances, distances])
        return self


def open_end_dtw(
    query: np.ndarray, references: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Open-end DTW distances of ``query`` to every reference (see the module docstring).

    Parameters
    ----------
    query : array, shape (n, D)
        The observation, n >= 1, finite.
    references : sequence of arrays, shape (m_r, D)
        The reference movements, each m_r >= 1, finite, with the query's D columns.

    Returns
    -------
    distances : array, shape (n_references,)
        ``min_j D(n-1, j)``: the summed Euclidean cost of the best alignment of the whole query
        with a beginning of the reference.
    ends : int array, shape (n_references,)
        The sample ``j`` of each reference where that alignment ends.
    """
    q = check_movement(query, "the observation", min_samples=1)
    dtw = OpenEndDTW(references).extend(q)
    return dtw.distances[-1], dtw.ends
