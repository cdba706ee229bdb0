"""The Teach tab, top to bottom: Primitive, Record, Live takes (LSL), Head source,
Demonstrations, Learn, Via-points (:mod:`app.ui.via_points`, which Infer shares), Prior.

Each folder is a section of its own module; this one builds them and runs them in the studio's
loop. Every change the user makes is either one mutation, made in the callback (the store's,
checked and written to disk, or the view state's; shared by every browser tab), or a press
that a section acts on in its step (Record, Go to start). At every frame each section shows
the frame's snapshot, redrawing only what changed, so every browser tab shows the same state.
"""

from __future__ import annotations

from app.live.recorder import Recording
from app.live.regions import prior_shape
from app.live.take_controller import COUNTDOWN_S, Phase
from app.panels.teach.demos import DemoList
from app.panels.teach.head import HeadSection
from app.panels.teach.learn import LearnSection
from app.panels.teach.live_record import LiveTakes
from app.panels.teach.primitives import PrimitiveSection
from app.panels.teach.prior import PriorCharts
from app.panels.teach.record import RecordSection
from app.scene.look import TEACH, Shown
from app.ui.context import Frame, PanelContext
from app.ui.via_points import ViaPointSection
from promp.region import mean_position
from robots.icub.layout import HAND


class TeachPanel:
    """The Teach tab (see the module docstring)."""

    def __init__(self, ctx: PanelContext, countdown_s: float = COUNTDOWN_S) -> None:
        self.ctx = ctx
        self._live: Recording | None = None  # the take being recorded, as last plotted
        self.primitives = PrimitiveSection(ctx)
        self.record = RecordSection(ctx, self._plot_live, countdown_s)
        self.live_takes = LiveTakes(ctx)
        self.head = HeadSection(ctx, recording=lambda: self.record.take is not None)
        self.demos = DemoList(ctx)
        self.learn = LearnSection(ctx)
        self.vias = ViaPointSection(ctx, TEACH)
        self.prior = PriorCharts(ctx)

    def _plot_live(self, _primitive: str | None, recording: Recording | None) -> None:
        self._live = recording

    def step(self, frame: Frame) -> Shown:
        """Show ``frame`` in every folder; the ghost of the start for the 3D view."""
        snapshot = frame.snapshot
        name = self.primitives.step(snapshot)
        start = self.record.step(frame)
        self.live_takes.step(frame)
        self.head.step(frame)
        listed = self.demos.step(snapshot)
        self.learn.step(frame)
        self.prior.tubes.step(snapshot)
        self.prior.show_tubes(snapshot)
        take = self.record.take
        recording = take is not None and self.record.takes.phase is Phase.RECORDING
        if recording and self._live is not None:
            self.prior.draw(snapshot, take.primitive, live=self._live)
        elif not listed:  # the list and the charts in two frames: no frame does both
            self.prior.draw(snapshot, name)
        model = snapshot.model
        known = model is not None and name in model.names and HAND.name in model.layout.names

        def mean_at(phase: float):
            if not known:
                return None
            shape = prior_shape(model, name, snapshot.view.via_points)
            return mean_position(model, shape.weights, HAND.name, phase)

        color = snapshot.store.color(name) if name in snapshot.store.names else (128, 128, 128)
        vias = self.vias.step(snapshot, name if known else None, color, mean_at)
        return Shown(start=start, vias=(vias,))

    def close(self) -> None:
        self.record.close()
        self.live_takes.close()
        self.head.close()
