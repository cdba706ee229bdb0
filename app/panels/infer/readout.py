"""What the Infer tab shows of an inference: the probability bars and the status lines, as HTML
(pure functions of an :class:`app.live.inference.InferResult`), and the charts
(:class:`InferCharts`).
Lengths and angles in the display units of :mod:`app.ui.display`, user text escaped by
:mod:`app.ui.text`.

The charts: one chart tab per modality, one chart per dimension, each with the prior and
posterior bands of the recognised primitive, the observed samples and the truth (the paper's
Figs. 4, 7 and 9), the predicted end of the movement with its 90 % interval (a vertical
line in a shaded band: :mod:`app.panels.infer.phase`, which also words the phase estimate)
and, on the hand's charts, the via-points the prediction passes through (a ring at the time of
each one's phase and its position, on a bar of ±2σ of its precision).
While the same movement is inspected, each chart's x and y ranges only grow: scrubbing neither
rescales (and so rebuilds) a chart at every step nor leaves uPlot's automatic x range to the
browser (viser rescales it relative to the previous data, which a rebuild can leave undefined:
an empty chart).
"""

from __future__ import annotations

import dataclasses
import math
import statistics
from collections.abc import Callable, Sequence

import numpy as np

from app.live.inference import InferResult
from app.panels.infer.phase import duration_html, end_interval, phase_html
from app.scene.inference_layer import OBSERVED_COLOR, TRUTH_COLOR
from app.ui.charts import Band, BandChart, Trace, add_band_chart, band_chart, update_band_chart
from app.ui.context import PanelContext
from app.ui.display import quantities, shown
from app.ui.text import escape_html
from app.ui.via_points import via_marks
from promp.data import Layout
from promp.timing import n_samples_from_alpha

# Right padding: viser's panel scrollbar lies over the last pixels of a full-width element.
PAD = "padding-right:14px;box-sizing:border-box"
ALPHA_HELP = (
    "α, the time modulation of the paper: s̄ / the number of samples of the whole movement "
    "(s̄ = {s_bar:g}; higher is faster). Then the same speed over the recognised primitive's "
    "typical one (that of its demonstrations: 1 = typical, > 1 faster)."
)
LEGEND_HTML = (
    f'<div style="font-size:0.72em;color:#555;margin-top:4px;{PAD}">'
    'Charts: bands ±2σ: <b style="color:#7d7d7d">prior</b> · <b>posterior</b> (recognised '
    "primitive's colour) · ● observed · ╌ truth · │ predicted end, shaded: its 90 % "
    "interval · ◯ via-point, its bar ±2σ of its precision</div>"
)


def seconds(value: float, digits: int = 2) -> str:
    return "—" if not math.isfinite(value) else f"{value:.{digits}f} s"


def probabilities_html(
    result: InferResult, color_of: Callable[[str], tuple[int, int, int]]
) -> str:
    """One bar per primitive (its probability, in its colour); the recognised one in bold, a
    name cut to the column's width given whole on hover. Each row carries ``data-primitive``
    and ``data-p`` for tests and tools."""
    rows = []
    recognition = result.inference.recognition
    for k, (name, p) in enumerate(zip(result.model.names, recognition.probabilities, strict=True)):
        r, g, b = color_of(name)
        weight = "700" if k == recognition.index else "400"
        rows.append(
            f'<div data-primitive="{escape_html(name)}" data-p="{p:.6f}" '
            'style="display:flex;align-items:center;gap:6px;margin:3px 0">'
            f'<span title="{escape_html(name)}" style="width:92px;overflow:hidden;'
            f'text-overflow:ellipsis;white-space:nowrap;font-weight:{weight}">'
            f"{escape_html(name)}</span>"
            '<span style="flex:1;height:11px;background:#e9ecef;border-radius:3px;'
            'overflow:hidden">'
            f'<span style="display:block;width:{100 * p:.1f}%;height:100%;'
            f'background:rgb({r},{g},{b})"></span></span>'
            '<span style="width:48px;text-align:right;font-variant-numeric:tabular-nums">'
            f"{100 * p:.1f} %</span></div>"
        )
    return f'<div style="font-size:0.8em;margin:2px 0 4px 0;{PAD}">' + "".join(rows) + "</div>"


def timing_text(scrub_ms: float, recent_ms: Sequence[float], fit_ms: float) -> str:
    """The server-side time of the latest scrub step (and of a held-out fit it needed)."""
    text = (
        f"step {scrub_ms:.1f} ms (server; median of the last {len(recent_ms)}: "
        f"{statistics.median(recent_ms):.1f} ms)"
    )
    if fit_ms > 0:
        text += f" · held-out fit {fit_ms:.0f} ms"
    return text


def failure_html(message: str, timing: str) -> str:
    return (
        f'<div style="font-size:0.8em;color:#a33;{PAD}">{escape_html(message)}</div>'
        f'<div style="font-size:0.72em;color:#777;{PAD}">{timing}</div>'
    )


def alpha_text(result: InferResult) -> str:
    """The speed, each number saying what it is: ``speed α = 0.688 (100 / 145 samples): 0.97
    × curved's typical speed``."""
    alpha, s_bar = result.inference.alpha, result.model.settings.s_bar
    samples = float(n_samples_from_alpha(alpha, s_bar))
    text = f"speed α = {alpha:.3g} ({s_bar:g} / {samples:.0f} samples)"
    relative = result.relative_speed
    if math.isfinite(relative):
        text += f": {relative:.2f} × {result.inference.primitive}'s typical speed"
    return text


def alpha_html(result: InferResult) -> str:
    """:func:`alpha_text`, explained on hover."""
    help = ALPHA_HELP.format(s_bar=result.model.settings.s_bar)
    return (
        f'<span title="{escape_html(help)}" style="text-decoration:underline dotted">'
        f"{escape_html(alpha_text(result))}</span>"
    )


def status_html(
    result: InferResult, truth_primitive: str | None, model_note: str, timing: str
) -> str:
    """What was recognised, how much was observed (and which share of the movement the method
    believes that is), with which model, the predicted and true durations and the errors
    (against ``truth_primitive``, the test demonstration's, if any)."""
    obs, truth, inference = result.observation, result.truth, result.inference
    primitive = inference.primitive
    if truth is not None:
        if truth_primitive is None:
            mark = ""
        elif truth_primitive == primitive:
            mark = ' <span style="color:#2b8a3e">✓</span>'
        else:
            mark = (
                f' <span style="color:#c92a2a">✗ (truth: {escape_html(truth_primitive)})</span>'
            )
        seen = f"{obs.n_observed} / {truth.n_samples} samples, {inference.observed_until:.2f} s"
    else:
        mark = ""
        seen = f"{obs.n_observed} samples, {inference.observed_until:.2f} s"
    lines = [
        f"<b>Recognised: {escape_html(primitive)}</b>{mark} · {alpha_html(result)}",
        f"Observed: {seen} ({' + '.join(obs.modalities)})",
        phase_html(result),
        f"Model: {escape_html(model_note)}",
        duration_html(result),
        errors_line(result),
    ]
    return (
        f'<div style="font-size:0.8em;line-height:1.55;{PAD}">' + "<br>".join(lines) + "</div>"
        f'<div style="font-size:0.72em;color:#777;{PAD}">{timing}</div>'
    )


def errors_line(result: InferResult) -> str:
    """The errors of the prediction shown (through its via-points, when it has some)
    against the truth, in the unit of the modality they are measured on (``—`` without a
    truth)."""
    errors, n = result.errors, len(result.via_points)
    title = f"Errors (through {n} via-point{'s' if n != 1 else ''})" if n else "Errors"
    if errors is None:
        return f"{title}: remainder — · goal — · duration —"
    measured = result.model.layout.modality(errors.modality)
    return (
        f"{title}: remainder {shown(errors.position, measured)} · goal "
        f"{shown(errors.goal, measured)} · duration {seconds(errors.duration)}"
    )


# ---------------------------------------------------------------------- the charts

PRIOR_COLOR = (125, 125, 125)
ASPECT = 3.3


@dataclasses.dataclass(frozen=True)
class FixedRangeChart(BandChart):
    """A band chart whose x (time) range is fixed too, in seconds."""

    x_range: tuple[float, float] = (0.0, 1.0)

    @property
    def scales(self) -> dict:
        return {**super().scales, "x": {"time": False, "range": self.x_range}}


class InferCharts:
    """The charts (see the module docstring), built inside the ``slot`` folder."""

    def __init__(self, ctx: PanelContext, slot, layout: Layout):
        self.ctx = ctx
        self.slot = slot
        self.handles: list = []
        self.quantities = quantities(layout)
        self.layout: Layout | None = None
        self._tabs = None
        self._range_key: tuple | None = None
        self._ranges: dict[int, tuple[float, float, float]] = {}
        self.build(layout)

    def build(self, layout: Layout) -> None:
        """One chart tab per modality of ``layout``, one chart per dimension."""
        if self._tabs is not None:
            self._tabs.remove()
        gui = self.ctx.gui
        placeholder = band_chart([], [Trace("", np.array([0.0, 1.0]), np.zeros(2), (0, 0, 0))])
        self.quantities = quantities(layout)
        self.handles = []
        with self.slot:
            self._tabs = gui.add_tab_group()
            for modality in layout.modalities:
                with self._tabs.add_tab(modality.name.capitalize()):
                    for q in self.quantities:
                        if q.modality == modality.name:
                            self.handles.append(
                                add_band_chart(
                                    gui,
                                    placeholder,
                                    title=q.title,
                                    y_label=q.axis_label,
                                    aspect=ASPECT,
                                )
                            )
        self.layout = layout
        self._range_key = None

    def draw(self, result: InferResult, movement: tuple, color: tuple[int, int, int]) -> None:
        """Draw ``result`` (posterior in ``color``); ranges grow while ``movement`` (what is
        inspected) stays the same."""
        if movement != self._range_key:
            self._range_key, self._ranges = movement, {}
        layout = result.model.layout
        if layout != self.layout:
            return  # an imported model of other modalities: no charts to draw into
        obs = result.observation
        observed = list(layout.dims(obs.modalities))
        truth = layout.extract(result.truth) if result.truth is not None else None
        end = end_interval(result, color)
        grids: dict = {}  # the charts' time grids, shared (see band_chart)
        elapsed = obs.elapsed  # (computed on each access: one array for every chart)
        duration = result.prediction.duration  # the via-points' times: their phases in it
        for i, (handle, q) in enumerate(zip(self.handles, self.quantities, strict=True)):
            bands = [
                Band.from_prediction(result.inference.prior, q, "prior", PRIOR_COLOR),
                Band.from_prediction(result.prediction, q, "posterior", color),
            ]
            traces = []
            if truth is not None:
                traces.append(
                    Trace("truth", result.truth.times, q.scale * truth[:, q.column], TRUTH_COLOR,
                          width=1.5, dash=(5.0, 4.0))
                )  # fmt: skip
            if q.column in observed:
                column = obs.values[:, observed.index(q.column)]
                traces.append(
                    Trace("observed", elapsed, q.scale * column, OBSERVED_COLOR, points=True)
                )
            marks = via_marks(result.via_points, q, layout, duration, end.color)
            chart = band_chart(bands, traces, intervals=[end], grids=grids, points=marks)
            chart = self._sticky(i, chart)
            update_band_chart(handle, chart, self.ctx.atomic)

    def _sticky(self, index: int, chart: BandChart) -> BandChart:
        """``chart`` with x and y ranges that only grow while the same movement is inspected."""
        lo, hi = chart.y_range
        x_hi = float(chart.grid[-1])
        if index in self._ranges:
            old_lo, old_hi, old_x = self._ranges[index]
            lo, hi, x_hi = min(lo, old_lo), max(hi, old_hi), max(x_hi, old_x)
        self._ranges[index] = (lo, hi, x_hi)
        fields = {f.name: getattr(chart, f.name) for f in dataclasses.fields(chart)}
        return FixedRangeChart(**{**fields, "y_range": (lo, hi)}, x_range=(0.0, x_hi))
