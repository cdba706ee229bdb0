"""Marks on the per-dimension charts of :mod:`app.ui.charts`.

- A time and its interval (:class:`TimeInterval`, e.g. the predicted end of a movement and its
  90 % interval), drawn across the plot's whole height as a solid vertical line at the time,
  dashed ones at the interval's ends and a light fill between them. Their series use a scale of
  their own, :data:`MARK_SCALE` (0 at the bottom, 1 at the top of the plot), so that they never
  move the y range.
- A value at a time with its spread (:class:`PointMark`, e.g. a via-point on one dimension: the
  time of its phase, its position and its precision), drawn on the chart's own axes as a ring
  at (time, value) on a vertical bar over value ± spread; the y range holds the value.

Each vertical is two samples a hair apart in time (:data:`VERTICAL_S`) on the chart's grid,
which holds their times (:attr:`TimeInterval.times`, :attr:`PointMark.times`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import viser.uplot as uplot

from app.ui.colors import RGB, check_color, css

MARK_SCALE = "mark"  # the scale of the vertical marks: 0 bottom, 1 top of the plot
VERTICAL_S = 1e-6  # seconds between a vertical's two samples (its bottom, then its top)


@dataclass(frozen=True)
class TimeInterval:
    """A time (``value``, a solid vertical line) and its interval ``[low, high]`` (dashed
    verticals, filled between), in seconds on the chart's time axis.

    Parameters
    ----------
    label : str
    value, low, high : float
        Finite, ``low <= value <= high``.
    color : (int, int, int)
    """

    label: str
    value: float
    low: float
    high: float
    color: RGB

    def __post_init__(self) -> None:
        values = (self.value, self.low, self.high)
        if not all(np.isfinite(values)) or not self.low <= self.value <= self.high:
            raise ValueError(
                f"interval {self.label!r}: need finite low <= value <= high, got {values}"
            )
        object.__setattr__(self, "color", check_color(f"interval {self.label!r}", self.color))

    @functools.cached_property
    def times(self) -> np.ndarray:
        """The grid times its verticals need: each a hair before, then at, its time; the
        fill's edges also a hair after ``high`` (one array: the charts of one inference
        share their grid by the identity of the times they are drawn on)."""
        edges = (self.low, self.value, self.high)
        times = np.array(
            [t + d for t in edges for d in (-VERTICAL_S, 0.0)] + [self.high + VERTICAL_S]
        )
        times.setflags(write=False)
        return times


@dataclass(frozen=True)
class PointMark:
    """A value at a time (a ring) and its spread (a vertical bar over ``value ± spread``), in
    the chart's units: seconds on the time axis, the dimension's display unit on the other.

    Parameters
    ----------
    label : str
    time, value : float
        Finite.
    spread : float
        Finite, >= 0 (0: the ring alone).
    color : (int, int, int)
    """

    label: str
    time: float
    value: float
    spread: float
    color: RGB

    def __post_init__(self) -> None:
        values = (self.time, self.value, self.spread)
        if not all(np.isfinite(values)) or self.spread < 0:
            raise ValueError(
                f"mark {self.label!r}: need a finite time, value and spread >= 0, got {values}"
            )
        object.__setattr__(self, "color", check_color(f"mark {self.label!r}", self.color))

    @property
    def times(self) -> np.ndarray:
        """The grid times its bar needs: a hair before, then at, its time (the same array for
        the same time: the charts of one inference share their grid by the identity of the
        times they are drawn on)."""
        return _point_times(float(self.time))


@functools.lru_cache(maxsize=64)
def _point_times(time: float) -> np.ndarray:
    times = np.array([time - VERTICAL_S, time])
    times.setflags(write=False)
    return times


def point_series(
    grid: np.ndarray, mark: PointMark
) -> tuple[list[np.ndarray], list[uplot.Series]]:
    """The data and series of ``mark`` on the chart's y scale: its bar, from ``value -
    spread`` a hair before its time to ``value + spread`` at it, then its ring (the grid
    holds both times)."""
    bar, ring = np.full(grid.shape, np.nan), np.full(grid.shape, np.nan)
    before, at = np.searchsorted(grid, mark.times)
    bar[before], bar[at] = mark.value - mark.spread, mark.value + mark.spread
    ring[at] = mark.value
    series: list[uplot.Series] = [
        {"label": f"{mark.label} ±", "stroke": css(mark.color, 0.9), "width": 1.5,
         "points": {"show": False}},
        {"label": mark.label, "stroke": css(mark.color, 0.0), "width": 1.0,
         "points": {"show": True, "size": 10.0, "width": 2.0, "stroke": css(mark.color),
                    "fill": "#ffffff"}},
    ]  # fmt: skip
    return [bar, ring], series


def _vertical(grid: np.ndarray, time: float) -> np.ndarray:
    """A vertical line at ``time`` on the mark scale: 0 a hair before it, 1 at it, NaN
    elsewhere (the grid holds both times)."""
    out = np.full(grid.shape, np.nan)
    out[np.searchsorted(grid, time - VERTICAL_S)] = 0.0
    out[np.searchsorted(grid, time)] = 1.0
    return out


def _mark(label: str, stroke: str, width: float = 1.0, **style) -> uplot.Series:
    """A series on the mark scale, without points."""
    series: dict = {"label": label, "stroke": stroke, "width": width, "scale": MARK_SCALE,
                    "points": {"show": False}, **style}  # fmt: skip
    return series  # type: ignore[return-value]


def interval_series(
    grid: np.ndarray, interval: TimeInterval, first: int
) -> tuple[list[np.ndarray], list[uplot.Series], uplot.Band]:
    """The data, series and fill of ``interval`` (its series from index ``first``)."""
    inside = (grid >= interval.low) & (grid <= interval.high)
    top, bottom = np.where(inside, 1.0, 0.0), np.zeros(grid.shape)
    hidden, line, dim = (css(interval.color, a) for a in (0.0, 1.0, 0.8))
    dashed = {"width": 1.0, "dash": (4.0, 3.0)}
    series = [
        _mark(f"{interval.label} interval", hidden),
        _mark(f"{interval.label} interval base", hidden),
        _mark(interval.label, line, width=2.0),
        _mark(f"{interval.label} low", dim, **dashed),
        _mark(f"{interval.label} high", dim, **dashed),
    ]
    data = [top, bottom] + [_vertical(grid, t) for t in (interval.value, interval.low,
                                                          interval.high)]  # fmt: skip
    fill: uplot.Band = {"series": (first, first + 1), "fill": css(interval.color, 0.12)}
    return data, series, fill
