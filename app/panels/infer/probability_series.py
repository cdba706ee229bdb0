"""The Infer tab's probability charts' arrays (uPlot): each primitive's probability on a grid,
with vertical marks (the offline chart's cursor and 'right from', the live chart's commitment).

uPlot shares one x array between all series, so a mark is a vertical segment drawn by a series
that holds values at two equal x entries inserted in the grid (and NaN elsewhere, where nothing
is drawn); every other series is interpolated there.
"""

from __future__ import annotations

import numpy as np

__all__ = ["marked_series"]


def marked_series(grid: np.ndarray, probabilities: np.ndarray,
                  marks: list[float | None]) -> tuple[np.ndarray, ...]:
    """uPlot's arrays: the x ``grid`` (n,) with each mark's x inserted twice, each column of
    ``probabilities`` (n, K) in % interpolated there (NaN outside its finite span), then one
    column per mark: its vertical segment (0 and 100 % at its two x entries, NaN elsewhere;
    all NaN for a None mark)."""
    shown = [m for m in marks if m is not None]
    x = np.sort(np.concatenate([grid, np.repeat(shown, 2)]), kind="stable")
    series = []
    for k in range(probabilities.shape[1]):
        p = 100.0 * probabilities[:, k]
        ok = np.isfinite(p)
        column = np.full(x.shape, np.nan)
        if ok.any():
            inside = (x >= grid[ok][0]) & (x <= grid[ok][-1])
            column[inside] = np.interp(x[inside], grid[ok], p[ok])
        series.append(column)
    for mark in marks:
        column = np.full(x.shape, np.nan)
        if mark is not None:
            first = int(np.searchsorted(x, mark, side="left"))
            column[first], column[first + 1] = 0.0, 100.0
        series.append(column)
    return (x, *series)
