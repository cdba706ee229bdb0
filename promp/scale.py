"""The data's own scale, so that no floor or jitter of the fit depends on the unit.

A modality may be a hand in metres or millimetres, a force in newtons, an EMG in volts or a
position in kilometres: the method must give the same recognition, and the same prediction in
the modality's unit, whatever it is (a change of unit multiplies a modality's values by a
constant). Every floor that keeps a variance positive is therefore a fraction
(:data:`RELATIVE_FLOOR`) of the modality's own squared scale (:func:`modality_scale`), never an
absolute number: an absolute ``1e-12`` is a micro-unit in metres but every variance of a hand
recorded in units of 1e-8 m.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from promp.data import Layout

__all__ = ["RELATIVE_FLOOR", "modality_scale"]

# Smallest variance, as a fraction of the modality's squared scale: far below any sensor's
# resolution (a relative precision of 1e-6 in standard deviation), far above round-off.
RELATIVE_FLOOR = 1e-12


def modality_scale(values: Sequence[np.ndarray], layout: Layout) -> np.ndarray:
    """The squared scale of every dimension's modality, shape (n_dims,), in its unit squared.

    The variance of the modality's samples about each dimension's grand mean, pooled over the
    demonstrations and averaged over the modality's dimensions (which share a unit): it scales
    with the square of the unit and does not depend on where the origin is. A modality that
    never moves takes the square of its largest magnitude instead, and one that is zero
    everywhere 1 (then nothing depends on it).

    Parameters
    ----------
    values : list of arrays, shape (n_samples_j, n_dims)
        Every demonstration's values in the layout's columns.
    """
    stacked = np.concatenate([np.asarray(v, dtype=float) for v in values])
    variance = stacked.var(axis=0)  # (n_dims,)
    magnitude = np.abs(stacked).max(axis=0) ** 2
    out = np.empty(layout.n_dims)
    for modality in layout.modalities:
        dims = layout.dims([modality.name])
        scale = float(variance[dims].mean())
        if not scale > 0.0:
            scale = float(magnitude[dims].max())
        out[dims] = scale if scale > 0.0 else 1.0
    return out
