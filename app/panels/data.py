"""The Data tab (being built)."""

from __future__ import annotations


class DataPanel:
    def __init__(self, studio) -> None:
        self.studio = studio
        studio.server.gui.add_markdown("Data: coming in this change.")

    def step(self) -> None:
        pass
