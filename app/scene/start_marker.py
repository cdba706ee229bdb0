"""The ghost of the start pose in Teach: a translucent sphere, in the selected primitive's
colour, where its demonstrations start on average (:func:`app.live.takes.mean_start`), so that a new
take starts where the others did ("Go to start" puts the hand there)."""

from __future__ import annotations

import numpy as np
import viser

RADIUS = 0.022  # metres: a little larger than the hand's frame, seen around it
OPACITY = 0.35


class StartMarker:
    """The ghost's scene nodes (see the module docstring)."""

    def __init__(self, server: viser.ViserServer):
        self.sphere = server.scene.add_icosphere(
            "/start/ghost", radius=RADIUS, color=(128, 128, 128), opacity=OPACITY,
            cast_shadow=False, receive_shadow=False, visible=False,
        )  # fmt: skip
        self.label = server.scene.add_label(
            "/start/ghost/label", "start", position=(0.0, 0.0, 1.6 * RADIUS), visible=False
        )
        self.position: np.ndarray | None = None

    def place(self, position: np.ndarray | None, color: tuple[int, int, int]) -> None:
        """Put the ghost at ``position`` (3,) in ``color``; None: there is no start to show."""
        self.position = None if position is None else np.asarray(position, dtype=float)
        if self.position is not None:
            if not np.allclose(self.sphere.position, self.position):
                self.sphere.position = self.position
            if tuple(self.sphere.color) != tuple(color):
                self.sphere.color = color

    def show(self, visible: bool) -> None:
        wanted = visible and self.position is not None
        for node in (self.sphere, self.label):
            if node.visible != wanted:
                node.visible = wanted
