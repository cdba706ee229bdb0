"""The Teach tab's Prior folder: the selected primitive's prior, one chart per dimension.

Each chart shows the prior of a new movement of the primitive at its typical speed, shaped by
its via-points (:func:`app.live.regions.prior_shape`; mean +- 2 sd, in the display units of
:mod:`app.ui.display`; each via-point marked, :func:`app.ui.via_points.via_marks`) with the
newest demonstration over it, or, while recording, the
demonstration being recorded. Drawn from the frame's snapshot, again only when what they show
changed. The folder also holds the 3D view's tube style
(:class:`app.ui.tube_style.TubeStyleControl`, shared with Infer's Display folder), a line that
says what the tubes are and the share of each primitive's demonstrations measured inside them
(:func:`app.live.regions.measured_shares`); the charts keep their ±2σ bands whatever the tubes
show.
"""

from __future__ import annotations

import numpy as np

from app.core.snapshot import Snapshot
from app.live.recorder import Recording
from app.live.regions import measured_shares, prior_shape
from app.scene.inference_layer import darker
from app.scene.tubes import tube_look
from app.ui.charts import Band, Trace, add_band_chart, band_chart, update_band_chart
from app.ui.context import PanelContext
from app.ui.display import quantities
from app.ui.tube_style import TubeStyleControl, measured_sentence, prior_widths, tube_sentence
from app.ui.via_points import via_marks
from promp.data import Layout
from robots.icub.layout import HAND, HEAD

PLOT_POINTS = 100
NO_COLOR = (128, 128, 128)
LIVE_COLOR = (20, 20, 20)
DEMO_COLOR = (70, 70, 70)
NEEDS_TWO = "Record at least two demonstrations to learn a prior."


class PriorCharts:
    """The Prior folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext):
        self.ctx = ctx
        self.plots: list = []
        self.layout: Layout | None = None
        self._drawn: tuple = ()  # what the charts show
        self._measured: tuple = ()  # what the tube note was measured on
        self.folder = ctx.gui.add_folder("Prior")
        with self.folder:
            self.tubes = TubeStyleControl(ctx.gui, ctx.view)
            self.tube_note = ctx.gui.add_markdown("")
            self.note = ctx.gui.add_markdown("")
        self.build(ctx.store.state.layout)

    def build(self, layout: Layout) -> None:
        """One chart per dimension of ``layout`` (rebuilt when the workspace changes)."""
        for plot in self.plots:
            plot.remove()
        placeholder = band_chart([], [Trace("", np.array([0.0, 1.0]), np.zeros(2), (0, 0, 0))])
        with self.folder:
            self.plots = [
                add_band_chart(self.ctx.gui, placeholder, title=q.title, y_label=q.axis_label)
                for q in quantities(layout)
            ]
        self.layout = layout

    def show_tubes(self, snapshot: Snapshot) -> None:
        """What the tubes are, and each primitive's share of samples inside them (measured
        again when the model or the tubes' probability changed)."""
        model, style = snapshot.model, snapshot.view.tube_style
        store = snapshot.store
        vias = snapshot.view.via_points
        key = (style, model, store.demos, store.findings, store.checks, vias)
        if self._measured and key[0] == self._measured[0] and all(
            a is b for a, b in zip(key[1:], self._measured[1:], strict=True)
        ):
            return
        self._measured = key
        text = tube_sentence(style)
        look = tube_look(style)
        if model is not None and look.shown and HAND.name in model.layout.names:
            text = tube_sentence(style, widths=prior_widths(model, store.names, style, vias))
            learned = store.learned
            text += " " + measured_sentence(measured_shares(model, learned, look.probability))
        self.tube_note.content = text

    def draw(self, snapshot: Snapshot, name: str | None, live: Recording | None = None) -> None:
        """The prior of ``name`` per dimension, with its newest demonstration (or ``live``)."""
        store, model = snapshot.store, snapshot.model
        layout = store.layout
        demos = store.demos.get(name, ()) if name is not None else ()
        color = store.color(name) if name in store.names else NO_COLOR
        vias = snapshot.view.via_points
        drawn = (name, color, model, demos, layout, live, vias)  # two values, then objects
        if self._drawn and drawn[:2] == self._drawn[:2] and all(
            a is b for a, b in zip(drawn[2:], self._drawn[2:], strict=True)
        ):
            return
        self._drawn = drawn
        prediction, shape = None, None
        if model is not None and name in model.names and model.layout == layout:
            shape = prior_shape(model, name, vias)
            prediction = shape.prediction(model, PLOT_POINTS)
        if layout != self.layout:
            self.build(layout)
        traces: list[tuple[str, np.ndarray, np.ndarray, tuple[int, int, int]]] = []
        if live is not None and live.n_samples >= 2:
            blocks = {HAND.name: live.hand, HEAD.name: live.head}
            columns = np.column_stack([blocks[m] for m in layout.names if m in blocks])
            traces.append(("the recording", live.times, columns, LIVE_COLOR))
        elif demos:
            newest = demos[-1]
            traces.append((newest.name, newest.times, layout.extract(newest), DEMO_COLOR))
        if prediction is None and not traces:
            self.folder.label = "Prior"
            self.note.content = NEEDS_TWO if name is not None else "No primitive."
            for plot in self.plots:
                plot.visible = False
            return
        self.folder.label = f"Prior of {name}"
        shaped = ""
        if shape is not None and shape.via_points:
            n = len(shape.via_points)
            shaped = f" (through {n} via-point{'s' if n != 1 else ''})"
        if prediction is None:
            self.note.content = NEEDS_TWO
        elif traces:
            self.note.content = f"Band: the prior{shaped}, mean ± 2σ. Line: {traces[0][0]}."
        else:
            self.note.content = f"Band: the prior{shaped}, mean ± 2σ."
        for q, plot in zip(quantities(layout), self.plots, strict=True):
            bands = [] if prediction is None else [Band.from_prediction(prediction, q, name, color)]
            marks = () if prediction is None else via_marks(
                shape.via_points, q, layout, prediction.duration, darker(color))  # fmt: skip
            lines = []
            for label, times, columns, line_color in traces:
                if q.column >= columns.shape[1]:
                    continue
                values = q.scale * columns[:, q.column]
                ok = np.isfinite(values)  # a live head column has no angle without a face
                if ok.sum() >= 1:
                    lines.append(Trace(label, times[ok], values[ok], line_color, width=1.5))
            if not bands and not lines:
                plot.visible = False
                continue
            update_band_chart(plot, band_chart(bands, lines, points=marks), self.ctx.atomic)
            plot.visible = True
