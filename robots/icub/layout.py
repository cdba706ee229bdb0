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


def is_position(modality: Modality) -> bool:
    """Whether ``modality`` is a point in space the 3D view can draw: three linear columns in
    metres (the robot's hand, a partner's hand, a marker), or three linear columns of no
    stated unit whose names end in x, y and z, in that order (``hx, hy, hz``, ``marker_x, ...``:
    a CSV's columns other than x, y, z get no unit, and are taken for metres). A modality in
    another unit (a force in N, an orientation in rad) or of another size is not."""
    if modality.kind != "linear" or len(modality.columns) != 3:
        return False
    if modality.unit == "m":
        return True
    named = all(c.lower().endswith(a) for c, a in zip(modality.columns, "xyz", strict=True))
    return modality.unit == "" and named


def position_modalities(layout: Layout) -> tuple[Modality, ...]:
    """The position modalities of ``layout`` (:func:`is_position`), the ``hand`` first, then
    in the layout's order."""
    found = [m for m in layout.modalities if is_position(m)]
    return tuple(sorted(found, key=lambda m: m.name != HAND.name))
