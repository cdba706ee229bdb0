"""The studio's GUI panels, one tab each: Teach (issue 7), Infer (issue 8), Data (export, import,
evaluation). A panel is built inside its tab's container and has a ``step()`` the studio's
loop calls at every iteration (dirty-flag pattern: callbacks record, ``step`` recomputes)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.studio import Studio


def build_panels(studio: Studio) -> None:
    from app.panels.data import DataPanel
    from app.panels.infer import InferPanel
    from app.panels.teach import TeachPanel

    tabs = studio.server.gui.add_tab_group()
    with tabs.add_tab("Teach"):
        teach = TeachPanel(studio)
    with tabs.add_tab("Infer"):
        infer = InferPanel(studio)
    with tabs.add_tab("Data"):
        data = DataPanel(studio)
    studio.panels = [teach, infer, data]
    studio.tabs = tabs
