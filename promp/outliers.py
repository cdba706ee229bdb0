"""Far out among the others: the robust rule every comparison of a take with its primitive's
other takes uses (:mod:`promp.quality`, :mod:`promp.endpoints`).

A value is far out when it lies more than :data:`OUTLIER_Z` robust deviations from the median
of the others: the median absolute deviation read as a normal's standard deviation
(``MAD / 0.6745``), Iglewicz and Hoaglin's modified z-score. A comparison needs
:data:`MIN_OTHERS` other takes; below that nothing is far out.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MIN_OTHERS", "OUTLIER_Z", "robust_deviation"]

OUTLIER_Z = 3.5  # robust deviations: Iglewicz and Hoaglin's cut-off for outliers
MIN_OTHERS = 3  # comparisons with the class need this many other demonstrations


def robust_deviation(values: np.ndarray, axis: int = -1) -> np.ndarray:
    """The median absolute deviation of ``values`` along ``axis`` read as a normal's
    standard deviation (``MAD / 0.6745``), the axis kept (shape 1 there)."""
    values = np.asarray(values, dtype=float)
    centre = np.median(values, axis=axis, keepdims=True)
    return np.median(np.abs(values - centre), axis=axis, keepdims=True) / 0.6745
