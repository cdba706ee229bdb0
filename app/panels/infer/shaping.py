"""The Infer tab's shaping of its prediction: a line that says what the posterior tube is
(:class:`app.ui.tube_style.TubeNote`) and the Via-points folder (:mod:`app.ui.via_points`,
shared with Teach), which shapes the primitive the tab recognises: its via-points combine with
the observation (:func:`app.live.inference.inferred`)."""

from __future__ import annotations

from app.core.snapshot import Snapshot
from app.live.inference import InferView
from app.live.regions import mean_position
from app.scene.look import INFER, ViaShown
from app.ui.context import PanelContext
from app.ui.tube_style import TubeNote
from app.ui.via_points import ViaPointSection
from robots.icub.layout import HAND


class InferShaping:
    """The tube's line (built in the current container) and the Via-points folder."""

    def __init__(self, ctx: PanelContext):
        self.tube_note = TubeNote(ctx.gui.add_html(""))
        self.vias = ViaPointSection(ctx, INFER)

    def step(self, snapshot: Snapshot, view: InferView | None, color) -> ViaShown:
        """Show what ``view``'s tube is and the via-points of the primitive it recognised;
        what the 3D view shows of them."""
        result = view.result if view is not None else None
        name = result.inference.primitive if result is not None else None
        vias = len(result.via_points) if result is not None else 0
        self.tube_note.show(snapshot.view.tube_style, name, vias, result)

        def mean_at(phase: float):
            if result is None or HAND.name not in result.model.layout.names:
                return None
            return mean_position(result.model, result.weights, HAND.name, phase)

        return self.vias.step(snapshot, name, color, mean_at)
