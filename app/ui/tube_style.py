"""The "Tubes" dropdown: how the 3D view draws the prior and posterior tubes
(:data:`app.core.view_state.TUBE_STYLES`). One choice, in the view state, that Teach's Prior
folder and Infer's Display folder both show: choosing in one shows it in the other (and in
every browser tab) at the next frame. Not written to the workspace.
"""

from __future__ import annotations

from app.core.snapshot import Snapshot
from app.core.view_state import TUBE_STYLES, View
from app.ui.context import PanelGui

HINT = (
    "How the distribution tubes are drawn in 3D: a translucent band at ±2σ or ±1σ around the "
    "mean hand path, only its outline (thin rings and lines at ±2σ), or off. Demonstration "
    "lines stay visible above them."
)


class TubeStyleControl:
    """The dropdown (built in the current container) and the view state it sets."""

    def __init__(self, gui: PanelGui, view: View):
        self.view = view
        self.dropdown = gui.add_dropdown(
            "Tubes", TUBE_STYLES, initial_value=view.state.tube_style, hint=HINT
        )
        self._shown = view.state.tube_style  # the state's style the dropdown shows
        self.dropdown.on_update(self._chosen)

    def _chosen(self, _event) -> None:
        if self.dropdown.value in TUBE_STYLES:
            self.view.set_tube_style(self.dropdown.value)

    def step(self, snapshot: Snapshot) -> None:
        """Show ``snapshot``'s style, when it changed in the state (a choice made after the
        snapshot was taken is not undone)."""
        style = snapshot.view.tube_style
        if style != self._shown:
            self._shown = style
            if self.dropdown.value != style:
                self.dropdown.value = style
