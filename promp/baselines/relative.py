"""Movements relative to their first sample, and the spread that scales their columns.

Both nearest-neighbour baselines (:mod:`promp.baselines.dtw`, :mod:`promp.baselines.prefix`)
compare shapes, not places: a movement ``x`` (n, D) is taken as ``x - x[0]``, so where it starts
does not matter (a person standing a little to the left). Columns of different units (metres,
radians, newtons) are put on one scale by dividing them by their spread in the training data
(:func:`column_spread`), the same rule for both baselines. Columns of one unit that form one
quantity (the hand's x, y, z in metres) share one scale, the root mean square of their
spreads, so their Euclidean geometry is kept: observing the hand alone, the distances are the
plain Euclidean ones in metres, up to one factor that changes no nearest neighbour.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["check_movement", "column_spread", "relative_to_start"]


def check_movement(values: np.ndarray, label: str, min_samples: int = 2) -> np.ndarray:
    """``values`` as a float array of shape (n, D), or a ValueError saying what is wrong.

    Parameters
    ----------
    values : array_like, shape (n, D)
    label : str
        What the values are, for the message (e.g. ``"the observation"``).
    min_samples : int
        Relative to its first sample, a movement of one sample is all zeros: nothing to
        compare, so at least 2 by default.
    """
    array = np.asarray(values, dtype=float)
    if array.ndim != 2 or array.shape[1] < 1:
        raise ValueError(f"{label}: expected shape (n_samples, n_columns), got {array.shape}")
    if array.shape[0] < min_samples:
        raise ValueError(
            f"{label}: {array.shape[0]} sample(s); at least {min_samples} are needed (relative "
            "to its first sample, a single sample is all zeros: there is no movement to compare)"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{label}: contains NaN or infinite values")
    return array


def relative_to_start(values: np.ndarray, label: str = "the movement") -> np.ndarray:
    """``values - values[0]``: the movement relative to its first sample.

    Parameters
    ----------
    values : array, shape (n, D), n >= 2, finite

    Returns
    -------
    array, shape (n, D)
        A new array; the first row is zero.
    """
    array = check_movement(values, label)
    return array - array[0]


def column_spread(
    movements: Sequence[np.ndarray], groups: Sequence[int] | None = None
) -> np.ndarray:
    """The scale each column is divided by before distances are taken: the standard
    deviation of every sample of ``movements`` relative to its movement's first sample,
    pooled; columns of one group share the root mean square of their deviations. A column
    (or group) that never moves gets 1 (nothing to scale).

    Parameters
    ----------
    movements : sequence of arrays, shape (n_i, D)
        The training demonstrations (each at least 2 samples, finite).
    groups : sequence of int, length D, optional
        A group number per column (default: every column its own group).

    Returns
    -------
    array, shape (D,), positive
    """
    if not movements:
        raise ValueError("the spread needs at least one training movement")
    relative = [relative_to_start(m, f"training movement {i}") for i, m in enumerate(movements)]
    widths = {m.shape[1] for m in relative}
    if len(widths) != 1:
        raise ValueError(f"training movements of different widths {sorted(widths)}")
    variance = np.concatenate(relative, axis=0).var(axis=0)
    if groups is not None:
        groups = np.asarray(groups)
        if groups.shape != variance.shape:
            raise ValueError(f"one group per column expected, got {groups.shape[0]} for "
                             f"{variance.shape[0]} columns")  # fmt: skip
        variance = np.array([variance[groups == g].mean() for g in groups])
    spread = np.sqrt(variance)
    return np.where(spread > 0, spread, 1.0)
