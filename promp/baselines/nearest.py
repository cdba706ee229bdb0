"""The nearest neighbour's answer: which primitive, and with what probabilities.

A nearest-neighbour baseline measures a distance from the observation to every training
demonstration; the primitive of the nearest one wins. Its probabilities are a softmin of each
primitive's nearest distance, relative to the nearest of all:

    p_k ∝ exp(-d_k / d_min),   d_k = min over the demonstrations of primitive k,

so they depend only on ratios of distances (the same in metres, radians or a DTW path's summed
cost), the winner has the largest, a primitive twice as far is e times less likely, and the
log-loss stays finite (an exact match, ``d_min = 0``, gives the winners all the mass).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["nearest_primitive"]


def nearest_primitive(
    distances: np.ndarray, labels: Sequence[int], n_primitives: int
) -> tuple[int, np.ndarray, np.ndarray]:
    """The primitive of the nearest demonstration, the softmin probabilities, and each
    primitive's nearest distance.

    Parameters
    ----------
    distances : array, shape (n_demos,)
        Non-negative, finite.
    labels : sequence of int, length n_demos
        The primitive (0 .. n_primitives - 1) of each demonstration.
    n_primitives : int

    Returns
    -------
    index : int
        The nearest primitive (the lowest index among equal distances).
    probabilities : array, shape (n_primitives,)
        The softmin of the module docstring (0 for a primitive without demonstrations).
    per_primitive : array, shape (n_primitives,)
        ``d_k`` (inf for a primitive without demonstrations).
    """
    d = np.asarray(distances, dtype=float)
    labels = np.asarray(labels, dtype=int)
    if d.ndim != 1 or labels.shape != d.shape or d.size == 0:
        raise ValueError(
            f"one distance per labelled demonstration expected, got {d.shape} and {labels.shape}"
        )
    if not np.all(np.isfinite(d)) or np.any(d < 0):
        raise ValueError("distances must be finite and non-negative")
    if np.any(labels < 0) or np.any(labels >= n_primitives):
        raise ValueError(f"labels must be in 0 .. {n_primitives - 1}")
    per_primitive = np.full(n_primitives, np.inf)
    np.minimum.at(per_primitive, labels, d)
    index = int(np.argmin(per_primitive))
    nearest = per_primitive[index]
    if nearest > 0:
        logits = -per_primitive / nearest
    else:  # exact matches: they share the mass
        logits = np.where(per_primitive == 0, 0.0, -np.inf)
    weights = np.exp(logits - logits[index])
    return index, weights / weights.sum(), per_primitive
