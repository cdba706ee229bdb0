"""The partner across the table: a head avatar oriented by the head source, with a gaze ray.

Shown only when the workspace has a ``head`` modality; the gaze ray disappears while the head
source sees no face.
"""

from __future__ import annotations

import numpy as np
import viser
import viser.transforms as vtf

from robots.icub.scene import DEFAULT_SCENE, head_rotation

HEAD_NODE = "/partner"
GAZE_LENGTH = 0.9  # metres


class PartnerView:
    """The avatar's scene nodes (see the module docstring)."""

    def __init__(self, server: viser.ViserServer):
        head = np.array(DEFAULT_SCENE.partner_head)
        self.head_frame = server.scene.add_frame(HEAD_NODE, position=head, show_axes=False)
        server.scene.add_icosphere(f"{HEAD_NODE}/skull", radius=0.09, color=(236, 200, 170))
        server.scene.add_box(
            f"{HEAD_NODE}/nose", dimensions=(0.05, 0.025, 0.035), position=(0.09, 0.0, -0.01),
            color=(220, 180, 150),
        )  # fmt: skip
        self.gaze = server.scene.add_spline_catmull_rom(
            f"{HEAD_NODE}/gaze",
            points=np.array([[0.0, 0.0, 0.0], [GAZE_LENGTH, 0.0, 0.0]]),
            color=(255, 200, 0),
            thickness=3.0,
            thickness_units="screen",
        )

    def show(self, present: bool) -> None:
        """Show the partner (the workspace has a head modality) or not."""
        if self.head_frame.visible != present:
            self.head_frame.visible = present

    def orient(self, angles: np.ndarray | None) -> None:
        """Turn the head to ``angles`` (roll, pitch, yaw, rad); no gaze without a face."""
        if not self.head_frame.visible:
            return
        if angles is None:
            self.gaze.visible = False
            return
        self.head_frame.wxyz = vtf.SO3.from_matrix(head_rotation(*angles)).wxyz
        self.gaze.visible = True
