"""The Teach tab (being built)."""

from __future__ import annotations


class TeachPanel:
    def __init__(self, studio) -> None:
        self.studio = studio
        studio.server.gui.add_markdown("Teach: coming in this change.")

    def step(self) -> None:
        pass
