"""The data-region guard: a candidate whose mean trajectories leave the box the demonstrations
span, widened on every side by its extent, is never chosen (its predictions would be metres
off)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from promp.data import Demonstration, Layout
from promp.model import ProMPModel
from promp.quality import winsorized

__all__ = ["REGION_PHASES", "data_region", "within_region"]


def data_region(
    dataset: Mapping[str, Sequence[Demonstration]], layout: Layout
) -> tuple[np.ndarray, np.ndarray]:
    """The box the demonstrations span, widened on every side by its own extent: (low, high),
    shape (n_dims,) each. A modality's extent is its largest range over its dimensions (a
    dimension that hardly moves is not held to its own few millimetres)."""
    values = np.concatenate([layout.extract(d) for demos in dataset.values() for d in demos])
    low, high = values.min(axis=0), values.max(axis=0)
    extent = np.empty(layout.n_dims)
    for modality in layout.modalities:
        dims = layout.dims([modality.name])
        extent[dims] = float((high - low)[dims].max())
    return low - extent, high + extent


REGION_PHASES = np.linspace(0.0, 1.0, 51)


def within_region(model: ProMPModel, low: np.ndarray, high: np.ndarray) -> bool:
    """Whether every primitive's mean trajectory, at the slowest and the fastest of its
    training speeds (winsorized, as the coupling of shape and speed saw them), stays inside
    [``low``, ``high``] (:func:`data_region`): a candidate whose predictions leave the region
    the demonstrations span is never chosen."""
    phi = model.basis(REGION_PHASES)
    for primitive in model.primitives:
        logs = winsorized(np.log(primitive.alphas))
        alphas = np.exp([logs.min(), logs.max()])
        means = primitive.mean_at(alphas).reshape(2, model.n_dims, -1)
        paths = means @ phi.T  # (2, n_dims, n_phases)
        if np.any(paths < low[None, :, None]) or np.any(paths > high[None, :, None]):
            return False
    return True
