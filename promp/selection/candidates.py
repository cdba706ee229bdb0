"""The candidate settings: the grids the search walks (the basis count M, its width, the noise
scale), the preference that breaks ties (the distance from the reference settings), and the
leave-one-out scorer of each candidate basis of one choice, each basis fitted once."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from promp.data import Demonstration, Layout
from promp.fitting import fit_parts
from promp.model import FALLBACK, Settings
from promp.selection.batches import Batch, make_batches
from promp.selection.loo import LooScorer
from promp.selection.trials import Trial

__all__ = ["BASIS_GRID", "NOISE_GRID", "WIDTH_GRID", "Candidates", "preference"]

BASIS_GRID = (5, 7, 10, 14)
WIDTH_GRID = (0.7, 1.0, 1.5)
NOISE_GRID = (1.0, 1.4, 2.0, 2.8, 4.0)  # factors of sqrt(2)


def preference(n_basis: int, width: float, noise_scale: float) -> float:
    """Distance from the fallback settings: breaks ties (e.g. every candidate perfect)."""
    return (
        abs(math.log(n_basis / FALLBACK["n_basis"]))
        + abs(math.log(width / FALLBACK["width"]))
        + abs(math.log(noise_scale / FALLBACK["noise_scale"]))
    )


class Candidates:
    """The leave-one-out scorer of each candidate basis of one choice (:class:`LooScorer`):
    each basis fitted once, every score on the same trials' observations and quadrature nodes
    (:func:`make_batches`, built at the first score)."""

    def __init__(
        self,
        dataset: Mapping[str, Sequence[Demonstration]],
        layout: Layout,
        inner: Settings,
        dt: float,
        trials: Sequence[Trial],
        region: tuple[np.ndarray, np.ndarray],
    ):
        self.dataset, self.layout, self.inner, self.dt = dataset, layout, inner, dt
        self.trials, self.region, self.n_trials = trials, region, len(trials)
        self._batches: list[Batch] | None = None
        self._scorers: dict[tuple[int, float], LooScorer] = {}

    def __call__(self, n_basis: int, width: float) -> LooScorer:
        key = (n_basis, width)
        if key not in self._scorers:
            if self._batches is None:
                self._batches = make_batches(
                    self.dataset, self.layout, self.trials, self.dt, self.inner.s_bar
                )
            candidate = dataclasses.replace(self.inner, n_basis=n_basis, width=width)
            fitted = fit_parts(self.dataset, self.layout, candidate, self.dt, alpha_models=False)
            self._scorers[key] = LooScorer(fitted, self._batches, self.n_trials, self.region)
        return self._scorers[key]
