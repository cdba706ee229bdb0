"""The Infer tab's charts: one chart tab per modality, one chart per dimension, each with the
prior and posterior bands of the recognised primitive, the observed samples and the truth (the
paper's Figs. 4, 7 and 9), in the display units of :mod:`app.ui.display`.

While the same movement is inspected, each chart's x and y ranges only grow: scrubbing neither
rescales (and so rebuilds) a chart at every step nor leaves uPlot's automatic x range to the
browser (viser rescales it relative to the previous data, which a rebuild can leave undefined:
an empty chart).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.live.inference import ScrubResult
from app.scene.inference_layer import OBSERVED_COLOR, TRUTH_COLOR
from app.ui.charts import Band, BandChart, Trace, add_band_chart, band_chart, update_band_chart
from app.ui.context import PanelContext
from app.ui.display import quantities
from promp.data import Layout

PRIOR_COLOR = (125, 125, 125)
ASPECT = 3.3


@dataclasses.dataclass(frozen=True)
class FixedRangeChart(BandChart):
    """A band chart whose x (time) range is fixed too, in seconds."""

    x_range: tuple[float, float] = (0.0, 1.0)

    @property
    def scales(self) -> dict:
        return {"x": {"time": False, "range": self.x_range}, "y": {"range": self.y_range}}


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

    def draw(self, result: ScrubResult, movement: tuple, color: tuple[int, int, int]) -> None:
        """Draw ``result`` (posterior in ``color``); ranges grow while ``movement`` (what is
        inspected) stays the same."""
        if movement != self._range_key:
            self._range_key, self._ranges = movement, {}
        layout = result.layout
        if layout != self.layout:
            return  # an imported model of other modalities: no charts to draw into
        obs = result.observation
        observed = list(layout.dims(obs.modalities))
        truth = layout.extract(result.truth) if result.truth is not None else None
        for i, (handle, q) in enumerate(zip(self.handles, self.quantities, strict=True)):
            bands = [
                Band.from_prediction(result.prior, q, "prior", PRIOR_COLOR),
                Band.from_prediction(result.posterior, q, "posterior", color),
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
                    Trace("observed", obs.elapsed, q.scale * column, OBSERVED_COLOR, points=True)
                )
            chart = self._sticky(i, band_chart(bands, traces))
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
