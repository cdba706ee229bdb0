"""The modalities the iCub studio records, defined once.

- ``hand``: the position of ``l_hand_dh_frame`` in the robot's root frame (x, y, z, metres;
  z up, the robot faces -x, its left is -y), the physical guidance;
- ``head``: the partner's head orientation (roll, pitch, yaw, radians; the convention of
  :mod:`robots.icub.scene`), the visual guidance.

The simulated scenario writes these columns, the studio records them, and any workspace's
``hand`` modality (3 columns, metres, root frame) drives the 3D view.
"""

from __future__ import annotations

import numpy as np

from promp.data import Layout, Modality

HAND = Modality("hand", ("x", "y", "z"), unit="m", kind="linear")
HEAD = Modality("head", ("roll", "pitch", "yaw"), unit="rad", kind="angle")
STUDIO_LAYOUT = Layout((HAND, HEAD))


def hand_dims(layout: Layout) -> np.ndarray | None:
    """The dimensions (3,) of ``layout``'s ``hand`` modality, None when it has none."""
    return layout.dims([HAND.name]) if HAND.name in layout.names else None


def position_modalities(layout: Layout) -> tuple[Modality, ...]:
    """The position modalities of ``layout`` (:attr:`promp.data.Layout.positions`: the points
    in space the 3D view can draw), the ``hand`` first, then in the layout's order."""
    return tuple(sorted(layout.positions, key=lambda m: m.name != HAND.name))
