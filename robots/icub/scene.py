"""The collaborative scene around the robot and the partner's head, in the robot's root frame.

Frame (metres): the URDF root (``root_link``, at the waist) is the studio's world frame. z is up,
the robot faces -x, its left is -y; the ground (the soles) is at z = -0.623.

Scene: a table in front of the robot, its top a little below the waist; an object on it at the
pick position; two open bins at the drop positions, the first on the robot's left, the second
just right of its midline (reached across the body). Every position the hand has to reach (the
grasp, above the bins) is inside the workspace of the left arm with the torso kept still, with a
margin of 3 cm (checked in ``tests/test_icub_scene.py``): the iCub's arm is short, so everything
sits in the first 20 cm of the table. The partner sits across the table, about 1 m in front of the
robot, facing it; the centre of their head is 1.14 m above the floor (a seated adult).

Head orientation convention (shared with the camera head-pose estimator)
------------------------------------------------------------------------
``roll``, ``pitch``, ``yaw`` in radians describe the orientation of the partner's head frame
relative to a neutral frame, and are all zero when the partner looks straight at the robot: at
its eyes (:data:`ROBOT_EYES`), where the camera of :mod:`app.headpose` sits, whose zero is
"facing the camera" along the line of sight.

- Head frame: x forward (out of the face), y the partner's LEFT, z up (out of the top of the head).
- Neutral frame (:func:`neutral_rotation`): x from the head centre towards the robot's eyes, y
  horizontal to the partner's left, z completing it (up, tilted forward). From the default
  partner (:data:`PARTNER_HEAD`, 0.265 m above the eyes and 0.935 m in front of them) x points
  15.8 deg below the horizontal and y is the root frame's +y.
- ``R = N @ Rz(yaw) @ Ry(pitch) @ Rx(roll)`` maps head-frame vectors to root-frame vectors, ``N``
  the neutral frame of the head's position (intrinsic z-y'-x'' angles about the neutral axes:
  yaw first, then pitch, then roll).
- Signs: positive yaw turns the head to the partner's left (+y, the robot's right); positive
  pitch looks DOWN (the hand's targets on the table are at pitch 12-19 deg); positive roll tilts
  the head towards the partner's right shoulder (-y).
- Gaze direction (the face's forward axis) = ``R[:, 0]`` =
  ``N @ (cos(yaw) cos(pitch), sin(yaw) cos(pitch), -sin(pitch))``.

:func:`neutral_rotation`, :func:`head_rotation`, :func:`gaze_direction`,
:func:`head_orientation_looking_at` and :func:`head_angles` implement it; each takes the head's
position (default the scene's partner), since the neutral frame depends on it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Hand positions (the l_hand_dh_frame origin) the scenario moves between.
PICK_POSITION = (-0.27, -0.10, 0.01)
DROP_HEIGHT_ABOVE_RIM = 0.09
PARTNER_HEAD = (-1.0, 0.0, 0.52)
# The point between the robot's eyes at the natural pose: the URDF has no eye links, so ~6 cm in
# front of and 2 cm above the ``head`` link origin (-0.008, 0, 0.235). It approximates where a
# camera at the robot's eyes would be, the reference of the partner's zero head orientation.
ROBOT_EYES = (-0.065, 0.0, 0.255)


@dataclass(frozen=True)
class Box:
    """An axis-aligned box: centre and full extents, shape (3,) each, in metres."""

    center: tuple[float, float, float]
    size: tuple[float, float, float]

    def __post_init__(self) -> None:
        center = tuple(float(v) for v in self.center)
        size = tuple(float(v) for v in self.size)
        if len(center) != 3 or len(size) != 3:
            raise ValueError(f"a box needs a 3-D center and size, got {center} and {size}")
        if not all(np.isfinite(center + size)) or min(size) <= 0.0:
            raise ValueError(
                f"a box needs a finite center and positive sizes, got {center}, {size}"
            )
        object.__setattr__(self, "center", center)
        object.__setattr__(self, "size", size)

    @property
    def top(self) -> float:
        return self.center[2] + self.size[2] / 2

    @property
    def bottom(self) -> float:
        return self.center[2] - self.size[2] / 2

    def contains(self, point: np.ndarray, margin: float = 0.0) -> bool:
        """True if ``point``, shape (3,), is inside the box grown by ``margin`` metres."""
        offset = np.abs(np.asarray(point, dtype=float) - np.asarray(self.center))
        return bool(np.all(offset <= np.asarray(self.size) / 2 + margin))


@dataclass(frozen=True)
class Bin:
    """An open box standing on the table: its outer box and the hand position to drop at."""

    box: Box
    wall: float = 0.008

    @property
    def rim(self) -> float:
        """Height of the rim, metres."""
        return self.box.top

    @property
    def drop_position(self) -> np.ndarray:
        """Hand position above the middle of the bin where the object is let go, shape (3,)."""
        cx, cy, _ = self.box.center
        return np.array([cx, cy, self.rim + DROP_HEIGHT_ABOVE_RIM])

    def parts(self) -> tuple[Box, ...]:
        """The bottom and the four walls, as boxes (for drawing)."""
        (cx, cy, cz), (sx, sy, sz), w = self.box.center, self.box.size, self.wall
        return (
            Box((cx, cy, self.box.bottom + w / 2), (sx, sy, w)),
            Box((cx - sx / 2 + w / 2, cy, cz), (w, sy, sz)),
            Box((cx + sx / 2 - w / 2, cy, cz), (w, sy, sz)),
            Box((cx, cy - sy / 2 + w / 2, cz), (sx - 2 * w, w, sz)),
            Box((cx, cy + sy / 2 - w / 2, cz), (sx - 2 * w, w, sz)),
        )


@dataclass(frozen=True)
class Scene:
    """Static geometry of the workspace (root frame, metres).

    Attributes
    ----------
    table : Box
        The table top.
    object : Box
        The object to carry, standing on the table at the pick position.
    pick_position : tuple of float, length 3
        Hand position when grasping the object (just above its top).
    bins : tuple of Bin
        Where the object goes: ``bins[0]`` for the two primitives of the paper, ``bins[1]`` for
        the optional third one.
    partner_head : tuple of float, length 3
        Centre of the partner's head.
    """

    table: Box
    object: Box
    pick_position: tuple[float, float, float]
    bins: tuple[Bin, ...]
    partner_head: tuple[float, float, float]

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

    def hand_targets(self) -> dict[str, np.ndarray]:
        """Every hand position the scenario needs, name -> shape (3,)."""
        targets = {"pick": np.array(self.pick_position, dtype=float)}
        for i, b in enumerate(self.bins):
            targets[f"drop{i}"] = b.drop_position
        return targets


def _on_table(table: Box, xy: tuple[float, float], size: tuple[float, float, float]) -> Box:
    return Box((xy[0], xy[1], table.top + size[2] / 2), size)


_TABLE = Box(center=(-0.42, -0.1, -0.085), size=(0.5, 0.8, 0.05))
DEFAULT_SCENE = Scene(
    table=_TABLE,
    object=_on_table(_TABLE, PICK_POSITION[:2], (0.05, 0.05, 0.06)),
    pick_position=PICK_POSITION,
    bins=(
        Bin(_on_table(_TABLE, (-0.24, -0.29), (0.14, 0.14, 0.07))),
        Bin(_on_table(_TABLE, (-0.25, 0.03), (0.12, 0.12, 0.07))),
    ),
    partner_head=PARTNER_HEAD,
)


# ---------------------------------------------------------------------- head orientation


def _angle(value: object, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} contains NaN or infinite values")
    return arr


def _point(value: object, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (3,):
        raise ValueError(f"{what} must have shape (3,), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} must be finite (no NaN or inf)")
    return arr


def neutral_rotation(
    head_position: np.ndarray = PARTNER_HEAD, target: np.ndarray = ROBOT_EYES
) -> np.ndarray:
    """The neutral head frame: looking from ``head_position`` at ``target``, shape (3, 3).

    Columns, in the root frame: x the unit vector from the head to the target, y horizontal to
    the partner's left (``z_root x x``, normalised), z = x cross y (up, tilted towards the gaze).

    Parameters
    ----------
    head_position : array, shape (3,)
        Centre of the partner's head; default the scene's partner.
    target : array, shape (3,)
        What the neutral head looks at; default the robot's eyes.

    Raises
    ------
    ValueError
        If an input is not a finite 3-vector, or the target is at or straight above/below the
        head (no horizontal "left").
    """
    head = _point(head_position, "head_position")
    forward = _point(target, "target") - head
    norm = np.linalg.norm(forward)
    if norm < 1e-9:
        raise ValueError("cannot look at a point at the head position: no direction")
    forward /= norm
    left = np.cross([0.0, 0.0, 1.0], forward)
    left_norm = np.linalg.norm(left)
    if left_norm < 1e-9:
        raise ValueError("the target is straight above or below the head: no neutral frame")
    left /= left_norm
    return np.column_stack([forward, left, np.cross(forward, left)])


def head_rotation(
    roll: float, pitch: float, yaw: float, head_position: np.ndarray = PARTNER_HEAD
) -> np.ndarray:
    """Rotation of the head frame in the root frame, ``N @ Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Parameters
    ----------
    roll, pitch, yaw : float or array, shape (n,)
        Head angles in radians (see the module docstring for the convention).
    head_position : array, shape (3,)
        Centre of the head, which sets the neutral frame ``N`` (:func:`neutral_rotation`).

    Returns
    -------
    array, shape (3, 3) or (n, 3, 3)
    """
    r, p, y = np.broadcast_arrays(_angle(roll, "roll"), _angle(pitch, "pitch"), _angle(yaw, "yaw"))
    neutral = neutral_rotation(head_position)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rot = np.empty(r.shape + (3, 3))
    rot[..., 0, 0] = cy * cp
    rot[..., 0, 1] = cy * sp * sr - sy * cr
    rot[..., 0, 2] = cy * sp * cr + sy * sr
    rot[..., 1, 0] = sy * cp
    rot[..., 1, 1] = sy * sp * sr + cy * cr
    rot[..., 1, 2] = sy * sp * cr - cy * sr
    rot[..., 2, 0] = -sp
    rot[..., 2, 1] = cp * sr
    rot[..., 2, 2] = cp * cr
    return neutral @ rot


def head_angles(
    rotation: np.ndarray, head_position: np.ndarray = PARTNER_HEAD
) -> tuple[float, float, float]:
    """Inverse of :func:`head_rotation`: ``(roll, pitch, yaw)`` of a rotation, shape (3, 3).

    ``rotation`` is the head frame in the root frame; the angles are relative to the neutral
    frame of ``head_position``. Pitch is returned in [-pi/2, pi/2], roll and yaw in (-pi, pi].

    Raises
    ------
    ValueError
        If ``rotation`` is not a finite 3x3 rotation matrix, or ``head_position`` is bad.
    """
    rot = np.asarray(rotation, dtype=float)
    if rot.shape != (3, 3) or not np.all(np.isfinite(rot)):
        raise ValueError(f"rotation must be a finite array of shape (3, 3), got {rot.shape}")
    if np.abs(rot @ rot.T - np.eye(3)).max() > 1e-6 or np.linalg.det(rot) < 0.0:
        raise ValueError("rotation must be a rotation matrix (orthonormal, det +1)")
    rot = neutral_rotation(head_position).T @ rot
    # arctan2 rather than arcsin: accurate near +-pi/2, where rounding in rot[2, 0] would cost
    # ~1e-8 rad.
    cos_pitch = float(np.hypot(rot[0, 0], rot[1, 0]))
    pitch = float(np.arctan2(-rot[2, 0], cos_pitch))
    if cos_pitch < 1e-12:  # looking straight up or down: only yaw - roll (or yaw + roll) is defined
        return 0.0, pitch, float(np.arctan2(-rot[0, 1], rot[1, 1]))
    yaw = float(np.arctan2(rot[1, 0], rot[0, 0]))
    # Row 1 of Rz(yaw).T @ R is row 1 of Rx(roll), (0, cos, -sin): stable near gimbal lock, where
    # an error in yaw is then made up by roll.
    cy, sy = np.cos(yaw), np.sin(yaw)
    roll = float(np.arctan2(sy * rot[0, 2] - cy * rot[1, 2], cy * rot[1, 1] - sy * rot[0, 1]))
    return roll, pitch, yaw


def gaze_direction(
    roll: float, pitch: float, yaw: float, head_position: np.ndarray = PARTNER_HEAD
) -> np.ndarray:
    """Unit gaze direction in the root frame, ``R[:, 0]``; shape (3,) or (n, 3) for arrays.

    Roll does not change it (the face turns about its own forward axis). ``head_position`` sets
    the neutral frame, as in :func:`head_rotation`.
    """
    _angle(roll, "roll")
    p, y = np.broadcast_arrays(_angle(pitch, "pitch"), _angle(yaw, "yaw"))
    neutral = neutral_rotation(head_position)
    local = np.stack([np.cos(y) * np.cos(p), np.sin(y) * np.cos(p), -np.sin(p)], axis=-1)
    return local @ neutral.T


def head_orientation_looking_at(
    point: np.ndarray, head_position: np.ndarray = PARTNER_HEAD
) -> tuple[float, float, float] | tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Head angles ``(roll, pitch, yaw)`` that point the gaze at ``point`` (roll 0).

    Parameters
    ----------
    point : array, shape (3,) or (n, 3)
        Where the partner looks, root frame, metres.
    head_position : array, shape (3,)
        Centre of the partner's head; default the scene's partner. The angles are relative to
        its neutral frame: looking at :data:`ROBOT_EYES` is (0, 0, 0) from any head position.

    Returns
    -------
    roll, pitch, yaw : float, or arrays of shape (n,) for n points
        Radians; ``gaze_direction(roll, pitch, yaw, head_position)`` is the unit vector towards
        ``point``.

    Raises
    ------
    ValueError
        If an input has the wrong shape, contains NaN/inf, or a point is at the head position.
    """
    target = np.asarray(point, dtype=float)
    head = np.asarray(head_position, dtype=float)
    if target.shape[-1:] != (3,) or target.ndim > 2:
        raise ValueError(f"point must have shape (3,) or (n, 3), got {target.shape}")
    if head.shape != (3,):
        raise ValueError(f"head_position must have shape (3,), got {head.shape}")
    if not np.all(np.isfinite(target)) or not np.all(np.isfinite(head)):
        raise ValueError("point and head_position must be finite (no NaN or inf)")
    d = (target - head) @ neutral_rotation(head)  # in the neutral frame
    horizontal = np.hypot(d[..., 0], d[..., 1])
    if np.any(horizontal + np.abs(d[..., 2]) < 1e-9):
        raise ValueError("cannot look at a point at the head position: no direction")
    yaw = np.arctan2(d[..., 1], d[..., 0])
    pitch = np.arctan2(-d[..., 2], horizontal)
    roll = np.zeros_like(yaw)
    if target.ndim == 1:
        return 0.0, float(pitch), float(yaw)
    return roll, pitch, yaw
