"""Where a workspace's positions were recorded: in the iCub's root frame, placed there, or
elsewhere; and in the simulated scene or not.

A dataset from another robot or a motion-capture room gives the hand in its own frame. At
import the user either places it in the iCub's frame (a :class:`robots.icub.placement.Placement`:
a turn about the vertical and a translation) or keeps it in its own frame, drawn where it is
without the robot. Every other position in space of the layout (a marker, another robot's
tool) is taken to be in the hand's frame and moves with it, except a **partner's** position (a
human's hand): it was recorded in the partner's frame (its origin the partner) and has a
placement of its own, which puts it beside the scene's partner
(:func:`robots.icub.placement.partner_placement`), never where the robot's hand goes.

Which positions are the partner's: what ``studio.json`` says (the user's choice, in the 3D
view's *Positions* controls); at import, a guess from the modality's name (a word for a person
in it: :data:`PARTNER_WORDS`, e.g. ``human``, ``partner_hand``, ``Subject1``), which the user
can change for any lab's names. The workspace keeps them all::

    "frame": {"placement": {"translation_m": [x, y, z], "yaw_rad": yaw},
              "imported": true,
              "partner": {"human": {"translation_m": [x, y, z], "yaw_rad": yaw}}}
    "frame": {"own": true, "imported": true}

and no ``frame`` at all for the studio's own recordings, made in its simulated scene (every
workspace written before). ``imported``: the data was recorded elsewhere (any import), so the
simulated table, bins and partner are not drawn by default (:attr:`HandFrame.in_scene`).

Inside the studio there is one frame: the workspace's demonstrations (the hand, and every other
position in space of the layout), on disk and in memory, are in the iCub's root frame once
placed (what the 3D view, the arm and the tubes use; a take recorded later is in that frame
too). Only a file that leaves the studio, an exported workspace, goes back to the data's own
frames (:meth:`HandFrame.as_recorded`), and one that comes in is placed again
(:meth:`HandFrame.placed`): an export holds the data as it was recorded.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import numpy as np

from promp.data import Demonstration, Layout
from robots.icub.layout import HAND, position_modalities
from robots.icub.placement import Placement, partner_placement

MAX_TRANSLATION_M = 10.0  # a placement further than this is a typing mistake
MAX_YAW_DEG = 360.0
# Words that name a person in a modality's name: that position is the partner's.
PARTNER_WORDS = frozenset({"human", "partner", "person", "subject", "participant", "operator",
                           "user", "hum"})  # fmt: skip

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


Moves = dict[str, Callable[[np.ndarray], np.ndarray]]  # modality -> points (n, 3) moved


@dataclass(frozen=True)
class HandFrame:
    """The frames of a workspace's positions (see the module docstring).

    Attributes
    ----------
    placement : Placement or None
        Moved the hand (and the positions recorded with it) into the iCub's root frame.
    own : bool
        The hand stays in its own frame, drawn without the robot (nothing is moved).
    imported : bool
        Recorded elsewhere (a dataset imported), not in the studio's simulated scene.
    partner : tuple of (str, Placement)
        The partner's positions, by modality name (sorted), each with the placement that put
        it beside the scene's partner.
    """

    placement: Placement | None = None
    own: bool = False
    imported: bool = False
    partner: tuple[tuple[str, Placement], ...] = ()

    def __post_init__(self) -> None:
        if self.own and self.placement is not None:
            raise ValueError("a hand is either placed in the iCub's frame or in its own, not both")
        if self.placement is not None:
            checked_placement(self.placement)
        names = [name for name, _ in self.partner]
        if self.own and names:
            raise ValueError("a hand kept in its own frame keeps every position as recorded")
        if HAND.name in names or len(set(names)) != len(names):
            raise ValueError(f"the partner's positions are other modalities than the robot's "
                             f"hand, each once; got {names}")  # fmt: skip
        for _, placement in self.partner:
            checked_placement(placement)
        object.__setattr__(self, "partner", tuple(sorted(self.partner)))

    @property
    def robot_shown(self) -> bool:
        """The iCub is drawn with the demonstrations (not for data in its own frame)."""
        return not self.own

    @property
    def in_scene(self) -> bool:
        """Recorded in the studio's simulated scene: its table, bins and partner are drawn
        by default (not for data imported, placed or kept in its own frame)."""
        return not (self.imported or self.own or self.placement is not None)

    @property
    def partner_names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.partner)

    def to_json(self) -> dict | None:
        """The ``frame`` of ``studio.json``; None for the studio's own (not written)."""
        value: dict = {}
        if self.own:
            value["own"] = True
        if self.placement is not None:
            value["placement"] = self.placement.to_json()
        if self.imported:
            value["imported"] = True
        if self.partner:
            value["partner"] = {name: p.to_json() for name, p in self.partner}
        return value or None

    @classmethod
    def from_json(cls, value: object, label: str, layout: Layout | None = None) -> HandFrame:
        """Read :meth:`to_json`'s form (absent: None); ValueError starting with ``label``,
        also for a partner's position that is not a position of ``layout`` (when given)."""
        if value is None:
            return cls()
        keys = {"own", "placement", "imported", "partner"}
        if not isinstance(value, dict) or not set(value) <= keys or (
            value.get("own", True) is not True or value.get("imported", True) is not True
            or not isinstance(value.get("partner", {}), dict)
        ):
            raise ValueError(
                f'{label}: \'frame\' is {{"own": true}} or {{"placement": {{"translation_m": '
                f'[x, y, z], "yaw_rad": yaw}}}}, with "imported": true and "partner": '
                f'{{"modality": placement}} if need be, got {value!r}'
            )
        try:
            placement = value.get("placement")
            partner = tuple((str(name), Placement.from_json(p))
                            for name, p in value.get("partner", {}).items())  # fmt: skip
            frame = cls(None if placement is None else Placement.from_json(placement),
                        bool(value.get("own")), bool(value.get("imported")), partner)  # fmt: skip
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{label}: 'frame': {exc}") from None
        if layout is not None:
            positions = {m.name for m in position_modalities(layout)}
            unknown = [name for name in frame.partner_names if name not in positions]
            if unknown:
                raise ValueError(f"{label}: 'frame': the partner's positions {unknown} are not "
                                 f"positions of the layout ({sorted(positions)})")  # fmt: skip
        return frame

    def moves(self, layout: Layout, undo: bool = False) -> Moves:
        """Each position of ``layout`` that is moved, and how (``undo``: back as recorded)."""
        partner = dict(self.partner)
        moves: Moves = {}
        for modality in position_modalities(layout):
            placement = partner.get(modality.name, self.placement)
            if placement is not None:
                moves[modality.name] = placement.undo if undo else placement.apply
        return moves

    def placed(self, demos: Demos, layout: Layout) -> dict[str, list[Demonstration]]:
        """``demos`` (the data's own frames) with every position in the iCub's root frame."""
        return move_positions(demos, layout, self.moves(layout))

    def as_recorded(self, demos: Demos, layout: Layout) -> dict[str, list[Demonstration]]:
        """The inverse of :meth:`placed`: every position back in the frame it was recorded in."""
        return move_positions(demos, layout, self.moves(layout, undo=True))

    def with_partner(self, name: str, partner: bool, recorded: Demos, layout: Layout) -> HandFrame:
        """This frame with position ``name`` the partner's (placed by what ``recorded``, the
        demonstrations as recorded, hold of it) or back in the hand's frame.

        Raises
        ------
        ValueError
            ``name`` is not a position of ``layout`` other than the hand, or the hand stays
            in its own frame (nothing is placed).
        """
        if name not in {m.name for m in position_modalities(layout)} or name == HAND.name:
            raise ValueError(f"{name!r} is not a position modality of this workspace other than "
                             "the robot's hand")  # fmt: skip
        if self.own:
            raise ValueError("the hand stays in its own frame: every position is drawn as "
                             "recorded, none is placed beside the partner")  # fmt: skip
        kept = tuple(item for item in self.partner if item[0] != name)
        if partner:
            kept += ((name, partner_placement(points_of(recorded, layout, name))),)
        return replace(self, partner=kept)


ICUB_FRAME = HandFrame()


def name_words(name: str) -> set[str]:
    """The words of a modality's name, lower case: ``partnerHand_2`` -> partner, hand."""
    spaced = re.sub(r"([a-z])([A-Z])", r"\1 \2", name)
    return {w.lower() for w in re.split(r"[^A-Za-z]+", spaced) if w}


def guessed_partner(layout: Layout) -> tuple[str, ...]:
    """The positions of ``layout`` (not the hand) whose name has a word of
    :data:`PARTNER_WORDS`: a guess, the user says otherwise in the 3D view."""
    return tuple(m.name for m in position_modalities(layout)
                 if m.name != HAND.name and name_words(m.name) & PARTNER_WORDS)  # fmt: skip


def imported_frame(frame: HandFrame, demos: Demos, layout: Layout) -> HandFrame:
    """``frame`` (the import's choice for the hand) for data recorded elsewhere: ``imported``,
    and the positions :func:`guessed_partner` names placed beside the partner, from ``demos``
    as recorded (none when the hand stays in its own frame)."""
    partner = () if frame.own else tuple(
        (name, partner_placement(points_of(demos, layout, name)))
        for name in guessed_partner(layout)
    )  # fmt: skip
    return replace(frame, imported=True, partner=partner)


def move_positions(demos: Demos, layout: Layout, moves: Moves) -> dict[str, list[Demonstration]]:
    """``demos`` with the points (n, 3) of each position modality named in ``moves`` replaced
    by ``moves[name](points)``, every other column as it was (new demonstrations; the given
    ones are not changed)."""
    if not moves:
        return {name: list(items) for name, items in demos.items()}
    columns = {name: list(layout.modality(name).columns) for name in moves}
    moved: dict[str, list[Demonstration]] = {}
    for name, items in demos.items():
        moved[name] = []
        for demo in items:
            values = np.array(demo.values, dtype=float)
            for modality, move in moves.items():
                where = [demo.columns.index(c) for c in columns[modality]]
                values[:, where] = move(values[:, where])
            moved[name].append(Demonstration(demo.times, values, demo.columns, name=demo.name))
    return moved


def points_of(demos: Demos, layout: Layout, name: str) -> np.ndarray:
    """Every sample of modality ``name``, (n, k); (0, 3) without one."""
    if name not in layout.names:
        return np.zeros((0, 3))
    columns = layout.modality(name).columns
    arrays = [demo.select(columns) for items in demos.values() for demo in items]
    return np.concatenate(arrays) if arrays else np.zeros((0, len(columns)))


def hand_points(demos: Demos, layout: Layout) -> np.ndarray:
    """Every sample of the ``hand`` modality, (n, 3); (0, 3) without one."""
    return points_of(demos, layout, HAND.name)
