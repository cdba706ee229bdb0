"""The collaborative scene around the robot, in the robot's root frame (metres).

z is up, the robot faces -x, its left is -y. The table stands in front of the robot, its top a
little below the waist so the left hand works just above it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Box:
    """An axis-aligned box: centre and full extents, shape (3,) each, in metres."""

    center: tuple[float, float, float]
    size: tuple[float, float, float]

    @property
    def top(self) -> float:
        return self.center[2] + self.size[2] / 2


@dataclass(frozen=True)
class Scene:
    """Static geometry of the workspace."""

    table: Box

    def table_corners(self) -> np.ndarray:
        """The four corners of the table top, shape (4, 3)."""
        cx, cy, _ = self.table.center
        hx, hy = self.table.size[0] / 2, self.table.size[1] / 2
        z = self.table.top
        return np.array(
            [
                [cx - hx, cy - hy, z],
                [cx + hx, cy - hy, z],
                [cx + hx, cy + hy, z],
                [cx - hx, cy + hy, z],
            ]
        )


DEFAULT_SCENE = Scene(table=Box(center=(-0.42, -0.1, -0.085), size=(0.5, 0.8, 0.05)))
