"""The Infer tab's live recognition chart: during a live session (or a session file's replay),
each primitive's probability at every prediction published so far in the movement going on
(or the last one), and a vertical dashed line, in the committed primitive's colour, at the
moment the commit rule committed; the note under it says it (``committed to 'top' at 0.42 s
(35 %), p=0.93``).

The x axis is the time since the movement started (s), not the observed share: a live
movement's share is an estimate, each prediction's own (its duration estimate changes as the
movement goes on), so against it the curve would run back and forth and the commitment would
sit where its own prediction thought it was; the time is measured and only grows. The
axis ends at the next half second past the latest prediction; each prediction's estimated
share is in the readout, and the commitment's in the note.

The curves come from :class:`app.live.live_curve.LiveCurves` (every prediction, bounded); the
chart draws a curve's new ``version`` at most every :data:`REDRAW_S` (a commitment, new
primitives or colours at once) and sets its series only when the primitives, their colours or
the committed one change: redrawing it at every frame (~90 predictions a second) took the
frame loop's time from the 3-D view and the take-over (`bench/live_studio.py`,
`bench/takeover.py`). The offline chart
(:mod:`app.panels.infer.recognition`) is hidden meanwhile.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from app.live.live_curve import LiveCurve
from app.live.lsl_source import Running
from app.panels.infer.probability_series import marked_series
from app.ui.charts import chart_axes, css
from app.ui.context import PanelContext
from app.ui.text import escape

__all__ = ["LIVE_TITLE", "LiveChart", "commit_text", "live_chart_data", "x_end"]

LIVE_TITLE = "Live: recognition probability vs time in the movement"
X_STEP_S = 0.5
REDRAW_S = 0.2  # the chart's new points at most five times a second
EMPTY = "The live movement's predictions are drawn here as they come."


def live_chart_data(curve: LiveCurve) -> tuple[np.ndarray, ...]:
    """uPlot's arrays: the predictions' times (s since the movement started) with the
    commitment's inserted twice, each primitive's probability (%), then the commitment's
    vertical segment at its time (all NaN without one)."""
    made = curve.committed
    mark = None if made is None else float(made.time)
    return marked_series(curve.times, curve.probabilities, [mark])


def x_end(curve: LiveCurve) -> float:
    """Where the x axis ends: the next :data:`X_STEP_S` past the latest prediction and the
    commitment (at least one step)."""
    latest = float(curve.times[-1]) if curve.times.size else 0.0
    if curve.committed is not None:
        latest = max(latest, float(curve.committed.time))
    return X_STEP_S * max(1, math.floor(latest / X_STEP_S) + 1)


def commit_text(curve: LiveCurve, rule: bool) -> str:
    """The note under the chart: the movement's commitment, or why there is none."""
    if not curve.times.size:
        return EMPTY
    head = f"Movement {curve.movement}, {curve.predictions} prediction(s)"
    made = curve.committed
    if made is None:
        return head + (": not committed yet." if rule else
                       ": no commit rule (tick Commit to a primitive before Start).")
    return (f"{head}: committed to **'{escape(made.primitive)}'** at {made.time:.2f} s "
            f"({100.0 * made.phase:.0f} %), p={made.probability:.2f} (the dashed line).")


class LiveChart:
    """The live chart and its note (see the module docstring)."""

    def __init__(self, ctx: PanelContext, color_of: Callable[[str], tuple[int, int, int]]):
        self.ctx = ctx
        self.color_of = color_of
        self._series_key: tuple | None = None
        self._shown: tuple | None = None
        self._range = (0.0, X_STEP_S)
        self._drawn_at = -math.inf  # time.monotonic() of the last drawing
        gui = ctx.gui
        self.chart = gui.add_uplot(
            data=(np.array(self._range), np.zeros(2)),
            series=({"label": "time (s)"}, {"label": "", "stroke": "rgba(0,0,0,0)"}),
            title=LIVE_TITLE,
            scales={"x": {"time": False, "range": self._range}, "y": {"range": (0.0, 100.0)}},
            axes=chart_axes("probability (%)", "time since the movement started (s)"),
            legend={"show": False},
            cursor={"drag": {"x": False, "y": False}},
            aspect=2.2,
            padding=(12, 18, 0, 0),
            visible=False,
        )
        self.note = gui.add_markdown("", visible=False)

    def step(self, lsl: bool, running: Running | None) -> None:
        """Show the live session's movement (``lsl``: the Source is the LSL one)."""
        curves = running.curves if lsl and running is not None else None
        self.show(curves.curve() if curves is not None else None,
                  running is not None and running.config.commit is not None)

    def show(self, curve: LiveCurve | None, rule: bool) -> None:
        """Draw ``curve`` (None: hide the chart and its note); ``rule``: the session commits."""
        if curve is None:
            if self._shown is not None:
                self._shown = None
                self.chart.visible = self.note.visible = False
            return
        colors = tuple(self.color_of(n) for n in curve.names)
        made = curve.committed
        series_key = (curve.names, colors, None if made is None else made.primitive)
        state = (curve.version, rule, series_key)
        if state == self._shown:
            return
        now = time.monotonic()
        if (self._shown is not None and state[1:] == self._shown[1:]
                and now - self._drawn_at < REDRAW_S):  # only new points: soon  # fmt: skip
            return
        self._shown, self._drawn_at = state, now
        text = commit_text(curve, rule)
        if text != self.note.content or not self.note.visible:
            self.note.content = text
            self.note.visible = True
        if not curve.times.size:  # (series set without their data break uPlot's axes)
            self.chart.visible = False
            return
        with self.ctx.atomic():  # the series, the range and the data together
            if series_key != self._series_key:
                self._series_key = series_key
                self.chart.series = self._series(curve, colors)
            end = x_end(curve)
            if (0.0, end) != self._range:
                self._range = (0.0, end)
                self.chart.scales = {"x": {"time": False, "range": self._range},
                                     "y": {"range": (0.0, 100.0)}}  # fmt: skip
            self.chart.data = live_chart_data(curve)
            self.chart.visible = True

    def _series(self, curve: LiveCurve, colors) -> tuple[dict, ...]:
        lines = [{"label": name, "stroke": css(color), "width": 2, "points": {"show": False}}
                 for name, color in zip(curve.names, colors, strict=True)]  # fmt: skip
        made = curve.committed
        mark = css(colors[made.index]) if made is not None else "rgba(0,0,0,0)"
        return ({"label": "time (s)"}, *lines,
                {"label": "committed", "stroke": mark, "width": 2.5, "dash": (6.0, 3.0),
                 "points": {"show": False}})  # fmt: skip
