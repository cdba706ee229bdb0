"""The Infer tab (being built)."""

from __future__ import annotations


class InferPanel:
    def __init__(self, studio) -> None:
        self.studio = studio
        studio.server.gui.add_markdown("Infer: coming in this change.")

    def step(self) -> None:
        pass
