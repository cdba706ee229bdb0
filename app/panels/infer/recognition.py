"""The Infer tab's "Recognition probability vs observed %" chart: each primitive's probability
over the whole test demonstration (:mod:`app.live.recognition_curve`), a cursor at the slider and a
marker at the earliest point from which the recognition stays right.

The curve takes a hundred recognitions (half a second, more on a loaded machine), so a worker
thread computes it (:class:`app.live.recognition_curve.CurveWorker`, which gives way while the
slider moves); the loop asks for the curve of what it inspects
(:meth:`RecognitionChart.request`) and draws it once there, cached per demonstration and
settings. Moving the slider only moves the cursor.

A click on the chart moves the slider there: the page's script (``static/studio.js``) turns it
into a click on the slider's track at the same percentage.

The cursor and the marker are vertical segments (:mod:`app.panels.infer.probability_series`).
During a live session (the LSL source) this chart is hidden and its :attr:`RecognitionChart.live`
(:mod:`app.panels.infer.live_chart`), built under it, shows the live movement instead.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable

import numpy as np

from app.live.recognition_curve import CurveRequest, CurveWorker, RecognitionCurve
from app.panels.infer.live_chart import LiveChart
from app.panels.infer.probability_series import marked_series
from app.ui.charts import chart_axes, css
from app.ui.context import PanelContext
from app.ui.text import escape

TITLE = "Recognition probability vs observed %"
X_RANGE = (0.0, 100.0)
CURSOR_COLOR = (30, 30, 30)
RIGHT_COLOR = (30, 140, 60)
WAITING = "Computing the recognition over the whole movement..."
LIVE_NOTE = "Recognition over the whole movement: for a test demonstration."


def chart_data(curve: RecognitionCurve, cursor: float) -> tuple[np.ndarray, ...]:
    """uPlot's arrays: the x grid (percent) with the cursor's and the marker's x inserted
    twice each, then each primitive's probability (%), the cursor and the marker segments."""
    return marked_series(curve.percents, curve.probabilities, [cursor, curve.right_from])


def right_text(curve: RecognitionCurve) -> str:
    """The line under the chart: from when the recognition stays right."""
    if curve.truth is None:
        return ""
    right_from = curve.right_from
    if right_from is None:
        last = curve.recognised[-1]
        said = curve.names[last] if last >= 0 else "nothing"
        return f"Not right at the end: 100 % observed is recognised as **{escape(said)}**."
    return (
        f"Right from **{right_from:g} %** observed on (the green line): **{escape(curve.truth)}** "
        "is the most probable from there to the end."
    )


class RecognitionChart:
    """The chart and its note; the curves come from a :class:`CurveWorker` (see the module
    docstring)."""

    def __init__(self, ctx: PanelContext, color_of: Callable[[str], tuple[int, int, int]]):
        self.ctx = ctx
        self.color_of = color_of
        self.worker = CurveWorker()
        self._names: tuple[str, ...] = ()
        self._shown: tuple | None = None
        self._key: Hashable | None = None  # what the chart should show
        self._absent = ""
        gui = ctx.gui
        self.chart = gui.add_uplot(
            data=(np.array(X_RANGE), np.zeros(2)),
            series=({"label": "observed (%)"}, {"label": "", "stroke": "rgba(0,0,0,0)"}),
            title=TITLE,
            scales={"x": {"time": False, "range": X_RANGE}, "y": {"range": (0.0, 100.0)}},
            axes=chart_axes("probability (%)", "observed (% of the movement)"),
            legend={"show": False},
            cursor={"drag": {"x": False, "y": False}},
            aspect=2.2,
            padding=(12, 18, 0, 0),  # room for the top tick's label under the title
            visible=False,
        )
        self.note = gui.add_markdown("")
        self.live = LiveChart(ctx, color_of)  # in its place during a live session

    # ------------------------------------------------------------------ the loop

    def request(self, wanted: CurveRequest | None, absent: str = "") -> None:
        """Show the curve of ``wanted``, computed in the background unless cached; or none
        (``absent`` says why)."""
        self._key = None if wanted is None else wanted.key
        self._absent = absent
        if wanted is not None:
            self.worker.request(wanted)

    def show(self, percent: float) -> None:
        """Draw the wanted curve (when computed) with the cursor at ``percent``."""
        key = self._key
        curve = self.worker.cache.get(key) if key is not None else None
        state = (key, float(percent), curve is not None, self._absent)
        if state == self._shown:
            return
        self._shown = state
        if key is None:
            self.chart.visible = False
            self.note.content = self._absent
            return
        if curve is None:
            self.note.content = WAITING
            return
        with self.ctx.atomic():
            if curve.names != self._names:
                self._names = curve.names
                self.chart.series = self._series(curve.names)
            self.chart.data = chart_data(curve, float(percent))
            self.chart.visible = True
        self.note.content = right_text(curve)

    def _series(self, names: tuple[str, ...]) -> tuple[dict, ...]:
        lines = [
            {"label": name, "stroke": css(self.color_of(name)), "width": 2,
             "points": {"show": False}}
            for name in names
        ]  # fmt: skip
        return (
            {"label": "observed (%)"},
            *lines,
            {"label": "slider", "stroke": css(CURSOR_COLOR, 0.8), "width": 1.5,
             "points": {"show": False}},
            {"label": "right from", "stroke": css(RIGHT_COLOR), "width": 2, "dash": (5.0, 3.0),
             "points": {"show": False}},
        )  # fmt: skip

    def recolor(self) -> None:
        """Redraw the series in the primitives' current colours."""
        if self._names:
            self.chart.series = self._series(self._names)

    @property
    def key(self) -> Hashable | None:
        """What the chart should show now (the key of its curve request)."""
        return self._key

    def curve(self) -> RecognitionCurve | None:
        """The curve of what is inspected now, once computed."""
        return self.worker.cache.get(self._key) if self._key is not None else None

    def close(self) -> None:
        self.worker.close()
