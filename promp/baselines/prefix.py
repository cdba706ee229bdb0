"""Prefix nearest neighbour with a phase search: how far an observation is from the beginning
of each reference movement, at the best guess of how much of the reference it covers.

For each reference of ``m`` samples and each fraction ``f`` of :data:`FRACTIONS` (50 values
from 0.02 to 1), the first fraction ``f`` of the reference, the span of sample indices
``[0, f (m - 1)]``, is resampled by linear interpolation to the observation's ``n`` samples
(sample ``i`` at the fractional index ``f (m - 1) i / (n - 1)``), and compared sample by sample
with the Euclidean norm of the whole difference (the Frobenius norm of the (n, D) residual).
The span is continuous, not a whole number of samples: a short prefix of a slow movement is
not rounded to the next sample. The best ``f`` is kept per reference:
the phase search makes the comparison blind to the speed, as DTW is to its changes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from promp.baselines.relative import check_movement

__all__ = ["FRACTIONS", "prefix_search"]

FRACTIONS = np.linspace(0.02, 1.0, 50)


def prefix_search(
    query: np.ndarray,
    references: Sequence[np.ndarray],
    fractions: np.ndarray = FRACTIONS,
) -> tuple[np.ndarray, np.ndarray]:
    """The distance of ``query`` to the best prefix of every reference (module docstring).

    Parameters
    ----------
    query : array, shape (n, D)
        The observation, n >= 2, finite (a single sample has no length to resample to).
    references : sequence of arrays, shape (m_r, D)
        Reference movements, each m_r >= 2, finite, with the query's D columns.
    fractions : array, shape (n_fractions,)
        The fractions searched, each in (0, 1].

    Returns
    -------
    distances : array, shape (n_references,)
        ``min_f ||query - prefix_f(reference)||`` (Frobenius).
    best : array, shape (n_references,)
        The fraction where each minimum is reached (the first of equal ones).
    """
    q = check_movement(query, "the observation")
    fractions = np.asarray(fractions, dtype=float)
    if fractions.ndim != 1 or fractions.size == 0 or not np.all((fractions > 0) & (fractions <= 1)):
        raise ValueError(f"fractions must be a non-empty 1-D array in (0, 1], got {fractions}")
    if len(references) == 0:
        raise ValueError("the prefix search needs at least one reference movement")
    distances = np.empty(len(references))
    best = np.empty(len(references))
    n = q.shape[0]
    for k, reference in enumerate(references):
        r = check_movement(reference, f"reference {k}")
        if r.shape[1] != q.shape[1]:
            raise ValueError(
                f"reference {k} has {r.shape[1]} columns, the observation {q.shape[1]}"
            )
        d = _distances(q, r, fractions * (r.shape[0] - 1), n)
        j = int(np.argmin(d))
        distances[k], best[k] = d[j], fractions[j]
    return distances, best


def _distances(q: np.ndarray, r: np.ndarray, spans: np.ndarray, n: int) -> np.ndarray:
    """||q - prefix resampled|| for every prefix, ``spans`` (n_fractions,) its last fractional
    sample index.

    With ``p_i = (1 - w_i) r_a + w_i r_{a+1}`` (``a = low_i``), the squared distance
    ``||q||^2 - 2 sum_i <q_i, p_i> + sum_i ||p_i||^2`` needs only the Gram matrix ``q r^T``
    (n, m), the squared norms ``||r_j||^2`` and the products ``<r_j, r_{j+1}>``: no (F, n, D)
    array, so the columns cost once (one matrix product), not once per fraction."""
    grid = np.arange(n) / (n - 1)
    position = grid[None, :] * spans[:, None]  # fractional sample index (F, n)
    low = np.minimum(np.floor(position).astype(int), r.shape[0] - 2)
    w = position - low
    rows = np.arange(n)[None, :]
    gram = q @ r.T  # <q_i, r_j>: (n, m)
    cross = ((1.0 - w) * gram[rows, low] + w * gram[rows, low + 1]).sum(axis=1)
    norms = np.einsum("md,md->m", r, r)
    neighbours = np.einsum("md,md->m", r[:-1], r[1:])
    own = ((1.0 - w) ** 2 * norms[low] + 2.0 * w * (1.0 - w) * neighbours[low]
           + w**2 * norms[low + 1]).sum(axis=1)  # fmt: skip
    squared = np.einsum("nd,nd->", q, q) - 2.0 * cross + own
    return np.sqrt(np.maximum(squared, 0.0))
