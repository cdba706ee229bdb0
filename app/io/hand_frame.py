"""Where a workspace's hand was recorded: in the iCub's root frame, placed there, or elsewhere.

A dataset from another robot or a motion-capture room gives the hand in its own frame. At
import the user either places it in the iCub's frame (a :class:`robots.icub.placement.Placement`:
a turn about the vertical and a translation) or keeps it in its own frame, drawn where it is
without the robot. ``studio.json`` keeps the choice::

    "frame": {"placement": {"translation_m": [x, y, z], "yaw_rad": yaw}}
    "frame": {"own": true}

and no ``frame`` at all for the iCub's own recordings (every workspace written before).

Inside the studio there is one frame: the workspace's demonstrations (the hand, and every other
position in space of the layout: a partner's hand, a marker), on disk and in memory, are
in the iCub's root frame once placed (what the 3D view, the arm and the tubes use; a take
recorded later is in that frame too). Only a file that leaves the studio, an exported workspace,
goes back to the data's own frame (:meth:`HandFrame.as_recorded`), and one that comes in is
placed again (:meth:`HandFrame.placed`): an export holds the data as it was recorded.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from promp.data import Demonstration, Layout
from robots.icub.layout import HAND, position_modalities
from robots.icub.placement import Placement

MAX_TRANSLATION_M = 10.0  # a placement further than this is a typing mistake
MAX_YAW_DEG = 360.0

Demos = Mapping[str, list[Demonstration]]


def checked_placement(placement: Placement) -> Placement:
    """``placement`` when it is one a person means: each of x, y, z within
    :data:`MAX_TRANSLATION_M` and the yaw within :data:`MAX_YAW_DEG` degrees.

    Raises
    ------
    ValueError
        What is out of bounds, in the units the user types (cm, degrees).
    """
    x, y, z = placement.translation
    yaw = math.degrees(placement.yaw)
    if max(abs(x), abs(y), abs(z)) > MAX_TRANSLATION_M or abs(yaw) > MAX_YAW_DEG:
        raise ValueError(
            f"a placement moves the hand by at most {MAX_TRANSLATION_M * 100:.0f} cm along each "
            f"axis and turns it by at most {MAX_YAW_DEG:.0f}°; got x, y, z = "
            f"{x * 100:.4g}, {y * 100:.4g}, {z * 100:.4g} cm, yaw {yaw:.4g}°"
        )
    return placement


def placement_from_fields(yaw_deg: float, x_cm: float, y_cm: float, z_cm: float) -> Placement:
    """The placement the import's number fields give (degrees, cm), checked."""
    values = (yaw_deg, x_cm, y_cm, z_cm)
    if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
        raise ValueError(f"a placement's yaw (°) and x, y, z (cm) are finite numbers, got {values}")
    translation = (x_cm / 100.0, y_cm / 100.0, z_cm / 100.0)
    return checked_placement(Placement(translation, math.radians(yaw_deg)))


def reach_sentence(share: float) -> str:
    """What is said of a hand path ``share`` (0-1) within the iCub's reach, when too little."""
    return (
        f"The hand's path is {share * 100:.0f} % within the iCub's reach: it was recorded in "
        "another frame."
    )


def placement_text(placement: Placement) -> str:
    """``placement`` in the units the user types: ``yaw 0°, x -198.2 cm, y -4.1 cm, z -6.2 cm``."""
    x, y, z = (v * 100.0 for v in placement.translation)
    return f"yaw {math.degrees(placement.yaw):.0f}°, x {x:.1f} cm, y {y:.1f} cm, z {z:.1f} cm"


@dataclass(frozen=True)
class HandFrame:
    """The frame of a workspace's hand (see the module docstring): ``placement`` moved it into
    the iCub's root frame; ``own``: it stays in its own, drawn without the robot; neither: it
    was recorded in the iCub's root frame."""

    placement: Placement | None = None
    own: bool = False

    def __post_init__(self) -> None:
        if self.own and self.placement is not None:
            raise ValueError("a hand is either placed in the iCub's frame or in its own, not both")
        if self.placement is not None:
            checked_placement(self.placement)

    @property
    def robot_shown(self) -> bool:
        """The iCub is drawn with the demonstrations (not for data in its own frame)."""
        return not self.own

    def to_json(self) -> dict | None:
        """The ``frame`` of ``studio.json``; None for the iCub's own frame (not written)."""
        if self.own:
            return {"own": True}
        if self.placement is not None:
            return {"placement": self.placement.to_json()}
        return None

    @classmethod
    def from_json(cls, value: object, label: str) -> HandFrame:
        """Read :meth:`to_json`'s form (absent: None); ValueError starting with ``label``."""
        if value is None:
            return cls()
        if isinstance(value, dict) and value == {"own": True}:
            return cls(own=True)
        if isinstance(value, dict) and set(value) == {"placement"}:
            try:
                return cls(Placement.from_json(value["placement"]))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{label}: 'frame': {exc}") from None
        raise ValueError(
            f'{label}: \'frame\' is {{"own": true}} or {{"placement": {{"translation_m": '
            f'[x, y, z], "yaw_rad": yaw}}}}, got {value!r}'
        )

    def placed(self, demos: Demos, layout: Layout) -> dict[str, list[Demonstration]]:
        """``demos`` (the data's own frame) with the hand in the iCub's root frame."""
        if self.placement is None:
            return {name: list(items) for name, items in demos.items()}
        return move_hand(demos, layout, self.placement.apply)

    def as_recorded(self, demos: Demos, layout: Layout) -> dict[str, list[Demonstration]]:
        """The inverse of :meth:`placed`: the hand back in the frame it was recorded in."""
        if self.placement is None:
            return {name: list(items) for name, items in demos.items()}
        return move_hand(demos, layout, self.placement.undo)


ICUB_FRAME = HandFrame()


def move_hand(demos: Demos, layout: Layout, move) -> dict[str, list[Demonstration]]:
    """``demos`` with the points (n, 3) of the ``hand`` and of every other position in space
    (:func:`robots.icub.layout.position_modalities`: a partner's hand, a marker, recorded in
    the same frame) replaced by ``move(points)``, every other column as it was (new
    demonstrations; the given ones are not changed)."""
    if HAND.name not in layout.names:
        return {name: list(items) for name, items in demos.items()}
    positions = [list(m.columns) for m in position_modalities(layout)]
    moved: dict[str, list[Demonstration]] = {}
    for name, items in demos.items():
        moved[name] = []
        for demo in items:
            values = np.array(demo.values, dtype=float)
            for columns in positions:
                where = [demo.columns.index(c) for c in columns]
                values[:, where] = move(values[:, where])
            moved[name].append(Demonstration(demo.times, values, demo.columns, name=demo.name))
    return moved


def hand_points(demos: Demos, layout: Layout) -> np.ndarray:
    """Every sample of the ``hand`` modality, (n, 3); (0, 3) without one."""
    if HAND.name not in layout.names:
        return np.zeros((0, 3))
    columns = layout.modality(HAND.name).columns
    arrays = [demo.select(columns) for items in demos.values() for demo in items]
    return np.concatenate(arrays) if arrays else np.zeros((0, 3))
