"""Per-dimension charts of trajectory distributions (uPlot bands) for the GUI panels.

One chart shows, over time, any number of distributions as a mean line inside a filled band of
mean +- ``n_sigma`` standard deviations (:class:`Band`), and any number of plain curves
(:class:`Trace`): a demonstration, the observed samples of a movement, the ground truth.

uPlot draws every series against one shared x array, so :func:`band_chart` merges the time
grids of all inputs into one increasing grid (the union of their times). On it, each mean line
and each continuous trace is linearly interpolated within its own time span; a trace drawn as
``points`` keeps exactly its own samples. Everywhere else such a series holds NaN: viser ships
the arrays as ``Float64Array`` (no ``null`` is possible), and uPlot hands a NaN to the canvas,
which skips it, so a line simply ends before and after its span.

Three uPlot behaviours with NaN, seen in headless Chromium, shape this module:

- a NaN *between* two values is bridged by a straight line, so no input may contain NaN and
  interpolation fills every series inside its span;
- a NaN in the *first* grid point makes uPlot's automatic y range NaN (an empty chart), so the
  y range is computed here and sent as a fixed scale, rounded outwards to a tick step so that
  small data changes (a live recording) do not move the axis (the x range is fixed too, to
  the grid: viser's browser side otherwise keeps the previous relative x range);
- a band *fill* whose edges end in NaN is closed through the end of the grid (a stray
  triangle), so outside a band's span its two edges hold the nearest end value of the *mean*:
  a band of zero width, which fills nothing. The edges themselves are not stroked (only the
  fill and the mean line are drawn), so nothing shows there.

A time and its interval (:class:`app.ui.chart_marks.TimeInterval`: the predicted end of a
movement and its 90 % interval) is drawn across the whole height, on a scale of its own; a
value at a time with its spread (:class:`app.ui.chart_marks.PointMark`: a via-point) as a ring
on a vertical bar.

Usage::

    chart = band_chart([Band("curved", t, mean, std, (213, 94, 0))],
                       [Trace("demo 3", t3, x3, (40, 40, 40))])
    handle = add_band_chart(gui, chart, title="hand x (cm)")
    ...
    update_band_chart(handle, new_chart, server.atomic)   # data, series and bands, atomically
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass

import numpy as np
import viser
import viser.uplot as uplot

from app.ui.chart_marks import MARK_SCALE, PointMark, TimeInterval, interval_series, point_series
from app.ui.colors import RGB, check_color, css
from app.ui.display import Quantity
from promp.inference import Prediction

N_SIGMA = 2.0  # the bands' half-width, in standard deviations (and a via-point's bar's)


def _check_curve(what: str, times: np.ndarray, *columns: np.ndarray) -> None:
    if times.ndim != 1 or times.shape[0] < 1:
        raise ValueError(f"{what}: times must be a non-empty 1-D array, got shape {times.shape}")
    for column in columns:
        if column.shape != times.shape:
            raise ValueError(
                f"{what}: values must have the shape of times {times.shape}, got {column.shape}"
            )
    for array in (times, *columns):
        if not np.all(np.isfinite(array)):
            raise ValueError(f"{what}: times and values must be finite (no NaN or inf)")
    if times.shape[0] > 1 and not np.all(np.diff(times) > 0):
        raise ValueError(f"{what}: times must be strictly increasing")


@dataclass(frozen=True)
class Band:
    """A distribution over time drawn as its mean inside a band of mean +- n_sigma std.

    Parameters
    ----------
    label : str
    times : array, shape (n,)
        Seconds, strictly increasing.
    mean, std : array, shape (n,)
        Finite; ``std >= 0``.
    color : (int, int, int)
    """

    label: str
    times: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    color: RGB

    def __post_init__(self) -> None:
        for name in ("times", "mean", "std"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float))
        _check_curve(f"band {self.label!r}", self.times, self.mean, self.std)
        if np.any(self.std < 0):
            raise ValueError(f"band {self.label!r}: std must be >= 0")
        object.__setattr__(self, "color", check_color(f"band {self.label!r}", self.color))

    @classmethod
    def from_prediction(
        cls, prediction: Prediction, quantity: Quantity, label: str, color: Sequence[int]
    ) -> Band:
        """The band of one dimension (``quantity``) of ``prediction``, in its display unit."""
        dim, scale = quantity.column, quantity.scale
        mean, std = scale * prediction.mean[:, dim], scale * prediction.std[:, dim]
        return cls(label, prediction.times, mean, std, color)


@dataclass(frozen=True)
class Trace:
    """A curve (``points=False``: a line through the samples) or samples (``points=True``:
    a marker at each, joined by a thin line).

    Parameters
    ----------
    label : str
    times, values : array, shape (m,)
        Finite; times strictly increasing.
    color : (int, int, int)
    width : float
        Line width in CSS pixels.
    dash : tuple of float, optional
        Dash pattern in CSS pixels, e.g. ``(6, 4)`` for a dashed ground truth.
    points : bool
    """

    label: str
    times: np.ndarray
    values: np.ndarray
    color: RGB
    width: float = 1.5
    dash: tuple[float, ...] | None = None
    points: bool = False

    def __post_init__(self) -> None:
        for name in ("times", "values"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float))
        _check_curve(f"trace {self.label!r}", self.times, self.values)
        object.__setattr__(self, "color", check_color(f"trace {self.label!r}", self.color))
        if not np.isfinite(self.width) or self.width <= 0:
            raise ValueError(f"trace {self.label!r}: width must be positive, got {self.width}")


@dataclass(frozen=True)
class BandChart:
    """Arguments of ``gui.add_uplot``: ``data[0]`` is the shared time grid (n_grid,), then one
    array (n_grid,) per series; ``series[0]`` describes the x axis."""

    data: tuple[np.ndarray, ...]
    series: tuple[uplot.Series, ...]
    bands: tuple[uplot.Band, ...]
    y_range: tuple[float, float]

    @property
    def scales(self) -> dict[str, uplot.Scale]:
        """Fixed x and y ranges: the x range spans the grid (viser's browser side otherwise
        keeps the previous relative x range when the data's span changes); the marks' scale
        when the chart has marks (:class:`TimeInterval`)."""
        x0, x1 = float(self.grid[0]), float(self.grid[-1])
        if x1 <= x0:
            x0, x1 = x0 - 0.5, x0 + 0.5
        scales: dict[str, uplot.Scale] = {
            "x": {"time": False, "range": (x0, x1)}, "y": {"range": self.y_range}
        }
        if any(s.get("scale") == MARK_SCALE for s in self.series):
            scales[MARK_SCALE] = {"auto": False, "range": (0.0, 1.0)}
        return scales

    @property
    def grid(self) -> np.ndarray:
        return self.data[0]


def _on_grid(grid: np.ndarray, times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` interpolated on ``grid`` within [times[0], times[-1]], NaN outside."""
    out = np.full(grid.shape, np.nan)
    inside = (grid >= times[0]) & (grid <= times[-1])
    out[inside] = np.interp(grid[inside], times, values)
    return out


def _band_edge(
    grid: np.ndarray, times: np.ndarray, edge: np.ndarray, mean: np.ndarray
) -> np.ndarray:
    """A band edge on ``grid``: interpolated within the span, the mean's end values outside
    (so that the band has zero width there; see the module docstring)."""
    out = np.interp(grid, times, edge)
    out[grid < times[0]] = mean[0]
    out[grid > times[-1]] = mean[-1]
    return out


def _at_samples(grid: np.ndarray, times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` at their own times on ``grid`` (which contains them), NaN elsewhere."""
    out = np.full(grid.shape, np.nan)
    out[np.searchsorted(grid, times)] = values
    return out


def y_range(values: Sequence[np.ndarray], pad: float = 0.08) -> tuple[float, float]:
    """A y range holding every finite value of ``values``, padded by ``pad`` of the span and
    rounded outwards to a tick step (a tenth of a power of ten of the span)."""
    finite = [v[np.isfinite(v)] for v in values]
    finite = [v for v in finite if v.size]
    if not finite:
        return (-1.0, 1.0)
    lo = float(min(v.min() for v in finite))
    hi = float(max(v.max() for v in finite))
    span = hi - lo
    if span < 1e-9 * max(1.0, abs(lo), abs(hi)):
        half = max(abs(lo) * 0.05, 1e-3)
        lo, hi, span = lo - half, hi + half, 2 * half
    lo, hi = lo - pad * span, hi + pad * span
    step = 10.0 ** np.floor(np.log10(hi - lo)) / 10.0
    return (float(np.floor(lo / step) * step), float(np.ceil(hi / step) * step))


def band_chart(
    bands: Sequence[Band],
    traces: Sequence[Trace] = (),
    n_sigma: float = N_SIGMA,
    x_label: str = "t (s)",
    intervals: Sequence[TimeInterval] = (),
    grids: dict | None = None,
    points: Sequence[PointMark] = (),
) -> BandChart:
    """Series and bands of a chart showing ``bands``, ``traces``, ``intervals`` and
    ``points`` on a shared time grid.

    Per band, three series: upper edge, lower edge (thin, translucent, the band filled between
    them) and mean (solid); then one series per trace, in the order given; then per interval
    five on the mark scale: the fill's top and bottom, the line at its time, the lines at its
    low and high ends (see the module docstring); then per point two: its bar and its ring.

    Parameters
    ----------
    bands : sequence of Band
    traces : sequence of Trace
    intervals : sequence of TimeInterval
        They do not count for the y range.
    points : sequence of PointMark
        Their values count for the y range (not their spreads).
    n_sigma : float
        Half-width of the bands in standard deviations (positive).
    x_label : str
    grids : dict, optional
        Where the charts drawn together keep their time grids (the union of the times given),
        by the times arrays' identities: charts of one inference share their times, and each
        union is sorted once, not once per chart.

    Returns
    -------
    BandChart
        Equal-length arrays; NaN only outside a series' own time span (see the module
        docstring).

    Raises
    ------
    ValueError
        Nothing to draw, or ``n_sigma`` not positive.
    """
    if not bands and not traces:
        raise ValueError("a chart needs at least one band or trace")
    if not np.isfinite(n_sigma) or n_sigma <= 0:
        raise ValueError(f"n_sigma must be positive, got {n_sigma}")
    times = [b.times for b in bands] + [t.times for t in traces] + [i.times for i in intervals]
    times += [p.times for p in points]
    key = tuple(id(t) for t in times)
    grid = None if grids is None else grids.get(key, (None, None))[1]
    if grid is None:
        grid = np.unique(np.concatenate(times))
        if grids is not None:
            grids[key] = (times, grid)  # the arrays held: their ids stay theirs meanwhile
    data: list[np.ndarray] = [grid]
    series: list[uplot.Series] = [{"label": x_label}]
    fills: list[uplot.Band] = []
    sigma = f"{n_sigma:g}σ"
    for band in bands:
        upper = _band_edge(grid, band.times, band.mean + n_sigma * band.std, band.mean)
        lower = _band_edge(grid, band.times, band.mean - n_sigma * band.std, band.mean)
        mean = _on_grid(grid, band.times, band.mean)
        first = len(data)
        data += [upper, lower, mean]
        edge = {"stroke": css(band.color, 0.0), "width": 1, "points": {"show": False}}
        series += [
            {"label": f"{band.label} +{sigma}", **edge},  # type: ignore[list-item]
            {"label": f"{band.label} -{sigma}", **edge},  # type: ignore[list-item]
            {"label": band.label, "stroke": css(band.color), "width": 2, "points": {"show": False}},
        ]
        fills.append({"series": (first, first + 1), "fill": css(band.color, 0.18)})
    for trace in traces:
        if trace.points:
            data.append(_at_samples(grid, trace.times, trace.values))
            style: uplot.Series = {
                "points": {"show": True, "size": 5, "fill": css(trace.color), "width": 1},
            }
        else:
            data.append(_on_grid(grid, trace.times, trace.values))
            style = {"points": {"show": False}}
        style.update({"label": trace.label, "stroke": css(trace.color), "width": trace.width})
        if trace.dash is not None:
            style["dash"] = tuple(float(d) for d in trace.dash)
        series.append(style)
    y = y_range([*data[1:], np.array([p.value for p in points])])
    for interval in intervals:
        more, styles, fill = interval_series(grid, interval, len(data))
        data += more
        series += styles
        fills.append(fill)
    for point in points:
        more, styles = point_series(grid, point)
        data += more
        series += styles
    return BandChart(tuple(data), tuple(series), tuple(fills), y)


TIME_LABEL = "time (s)"


def chart_axes(y_label: str, x_label: str = TIME_LABEL) -> tuple[uplot.Axis, uplot.Axis]:
    """Compact axes: ``x_label`` (time) below, ``y_label`` on a narrow left axis."""
    font = "11px sans-serif"
    return (
        {
            "label": x_label,
            "size": 30,
            "font": font,
            "space": 40,
            "ticks": {"size": 4},
            "labelSize": 14,
            "labelFont": font,
        },
        {
            "label": y_label,
            "size": 46,
            "space": 18,
            "ticks": {"size": 4},
            "labelSize": 14,
            "labelFont": font,
            "font": font,
        },
    )


def add_band_chart(
    gui: viser.GuiApi,
    chart: BandChart,
    title: str | None = None,
    y_label: str = "",
    aspect: float = 2.4,
    legend: bool = False,
    visible: bool = True,
) -> viser.GuiUplotHandle:
    """Add ``chart`` to ``gui`` (inside the current folder/tab) and return its handle; the x
    axis says "time (s)", the y axis ``y_label`` (the quantity's unit)."""
    return gui.add_uplot(
        data=chart.data,
        series=chart.series,
        bands=chart.bands,
        scales=chart.scales,
        title=title,
        axes=chart_axes(y_label),
        legend={"show": legend},
        cursor={"drag": {"x": False, "y": False}},
        aspect=aspect,
        visible=visible,
    )


def update_band_chart(
    handle: viser.GuiUplotHandle,
    chart: BandChart,
    atomic: Callable[[], AbstractContextManager],
) -> None:
    """Replace the content of a chart made by :func:`add_band_chart`.

    Series, bands and scales are only re-sent when they changed (they rebuild the chart in the
    browser); when they are, everything goes in one message group (``with atomic():``, the
    server's), so the browser never sees data and series of different lengths.
    """
    same = (
        handle.series == chart.series
        and handle.bands == chart.bands
        and handle.scales == chart.scales
    )
    if same:
        handle.data = chart.data
        return
    with atomic():
        handle.series = chart.series
        handle.bands = chart.bands
        handle.scales = chart.scales
        handle.data = chart.data
