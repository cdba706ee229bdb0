"""The Teach tab, top to bottom: Primitive, Record, Head source, Demonstrations, Learn, Prior.

Each folder is a section of its own module; this one builds them and runs them in the studio's
loop. Every change the user makes is either one session mutation, made in the callback (checked
and written to disk by the session, shared by every browser tab), or an intent that a section
acts on in :meth:`TeachPanel.step` (Record pressed, a slider moved). The step also redraws what
the session changed, so every browser tab shows the same state.
"""

from __future__ import annotations

import time

from app.live.take_machine import COUNTDOWN_S
from app.panels.teach.demos import DemoList
from app.panels.teach.head import HeadSection
from app.panels.teach.learn import LearnSection
from app.panels.teach.primitives import PrimitiveSection
from app.panels.teach.prior import PriorCharts
from app.panels.teach.record import RecordSection
from app.ui.context import PanelContext
from promp.data import Layout


class TeachPanel:
    """The Teach tab (see the module docstring)."""

    def __init__(self, ctx: PanelContext, countdown_s: float = COUNTDOWN_S) -> None:
        self.ctx = ctx
        self._dirty = True
        self._drawn_version = -1
        self.primitives = PrimitiveSection(ctx)
        self.record = RecordSection(
            ctx,
            selected=self.primitives.selected,
            select=self.primitives.select,
            redraw=self.redraw,
            live_plot=lambda name, recording: self.prior.draw(name, live=recording),
            countdown_s=countdown_s,
        )
        self.head = HeadSection(
            ctx,
            recording=lambda: self.record.take is not None,
            changed=self.record.forget_head_refusal,
        )
        self.demos = DemoList(ctx)
        self.learn = LearnSection(ctx)
        self.prior = PriorCharts(ctx)
        self._layout: Layout = ctx.session.layout
        self.head.show_for(self._layout)

    def redraw(self) -> None:
        """Redraw the lists and plots at the next step."""
        self._dirty = True

    def step(self) -> None:
        """Recompute what changed (called by the studio's loop at every iteration)."""
        now = time.monotonic()
        self.record.step(now)
        self.head.step(now)
        self.learn.step(now)
        self._refresh()

    def _refresh(self) -> None:
        session = self.ctx.session
        version = session.version
        if version == self._drawn_version and not self._dirty and not self.primitives.pending:
            return
        self._dirty = False
        name = self.primitives.sync()
        if version != self._drawn_version:
            if session.layout != self._layout:
                self._layout = session.layout
                self.prior.build(session.layout)
                self.head.show_for(session.layout)
            self.learn.show()
            self.demos.show_undo()
        self._drawn_version = version
        self.demos.show(name)
        self.record.show_start()
        if not self.record.sampling:
            self.prior.draw(name)
        if self.record.idle:
            self.record.show_idle()

    def close(self) -> None:
        self.head.close()
