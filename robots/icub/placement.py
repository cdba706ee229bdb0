"""A hand recorded elsewhere, placed where the iCub's left hand can be.

A dataset from another robot or a motion-capture room gives the hand in its own frame: a
Baxter's base, a Vicon room's origin. Drawn as if it were the iCub's root frame, its paths can
sit behind the iCub's head. :func:`reach_share` says how much of a hand's path the iCub's left
arm can reach (the share of samples within :data:`TOLERANCE` of a position the arm reaches,
over :data:`N_SAMPLES` configurations drawn inside its joint limits); :func:`guess_placement`
proposes the rigid motion (a turn about the vertical and a translation: the iCub's root frame
has z up) that moves the data's centre onto the centre of the reachable positions, which the
user may edit; :class:`Placement` applies it and undoes it (an export goes back to the data's
own frame). Lengths are metres, angles radians.

A partner's position (a human's hand) is recorded in the partner's frame: its origin is the
partner, z up. It is placed at the scene's partner, not where the robot's hand goes:
:func:`partner_placement` moves that origin onto :data:`PARTNER_ORIGIN` (the middle of the
partner's shoulders, :data:`SHOULDERS_BELOW_HEAD` below the centre of their head) and turns it
about the vertical so that the points lie in front of the partner, towards the robot: a hand
at work is in front of its body, whichever way the lab's horizontal axes point.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from robots.icub.kinematics import load_arm
from robots.icub.model import DEFAULT_ROBOT
from robots.icub.scene import DEFAULT_SCENE

N_SAMPLES = 4000  # arm configurations sampled for the reachable positions
TOLERANCE = 0.04  # m: a sample this close to a reachable position is in reach
IN_REACH = 0.8  # share of samples in reach for a path to count as the iCub's
SHOULDERS_BELOW_HEAD = 0.2  # m: a seated adult's shoulders, below the centre of the head
PARTNER_ORIGIN = tuple(float(v) for v in np.add(DEFAULT_SCENE.partner_head,
                                                (0.0, 0.0, -SHOULDERS_BELOW_HEAD)))
MIN_OFFSET = 0.05  # m: points closer to the origin than this (horizontally) say no direction


@dataclass(frozen=True)
class Placement:
    """``p_icub = R_z(yaw) p + translation``: ``translation`` (3,) in metres, ``yaw`` in
    radians about the vertical axis."""

    translation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw: float = 0.0

    def __post_init__(self) -> None:
        values = [*self.translation, self.yaw]
        if len(self.translation) != 3 or not all(math.isfinite(float(v)) for v in values):
            raise ValueError(
                f"a placement is a finite translation (x, y, z) in m and a yaw in rad, got "
                f"{self.translation}, {self.yaw}"
            )
        object.__setattr__(self, "translation", tuple(float(v) for v in self.translation))
        object.__setattr__(self, "yaw", float(self.yaw))

    @property
    def is_identity(self) -> bool:
        return self.translation == (0.0, 0.0, 0.0) and self.yaw == 0.0

    def _rotation(self) -> np.ndarray:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Points (n, 3) of the data's frame in the iCub's root frame."""
        return np.asarray(points, dtype=float) @ self._rotation().T + np.array(self.translation)

    def undo(self, points: np.ndarray) -> np.ndarray:
        """The inverse of :meth:`apply`."""
        shifted = np.asarray(points, dtype=float) - np.array(self.translation)
        return shifted @ self._rotation()

    def to_json(self) -> dict:
        return {"translation_m": list(self.translation), "yaw_rad": self.yaw}

    @classmethod
    def from_json(cls, data: Mapping) -> Placement:
        """Read :meth:`to_json`'s form; ValueError naming what is wrong."""
        try:
            translation = tuple(float(v) for v in data["translation_m"])
            return cls(translation, float(data["yaw_rad"]))  # type: ignore[arg-type]
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(
                f"a placement needs translation_m [x, y, z] and yaw_rad, finite: {exc}"
            ) from exc


@functools.cache
def reachable_positions(robot: str = DEFAULT_ROBOT) -> np.ndarray:
    """Hand positions the left arm reaches, (N_SAMPLES, 3), from configurations drawn
    uniformly inside its joint limits (a fixed seed: the same every time)."""
    arm = load_arm(robot)
    q = arm.random_configurations(np.random.default_rng(0), N_SAMPLES)
    points = np.array([arm.position(row) for row in q])
    points.setflags(write=False)
    return points


@functools.cache
def _tree(robot: str) -> cKDTree:
    return cKDTree(reachable_positions(robot))


def reach_share(points: np.ndarray, robot: str = DEFAULT_ROBOT) -> float:
    """The share of ``points`` (n, 3), root frame, within :data:`TOLERANCE` of a reachable
    position of the left hand (1 for no point)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if not points.shape[0]:
        return 1.0
    distance, _ = _tree(robot).query(points, distance_upper_bound=TOLERANCE)
    return float(np.mean(np.isfinite(distance)))


def guess_placement(points: np.ndarray, robot: str = DEFAULT_ROBOT) -> Placement:
    """The translation that moves the centre of ``points``' bounding box onto the median of the
    reachable positions (no turn: which way the data faces cannot be told from its extent; the
    user may add one)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    target = np.median(reachable_positions(robot), axis=0)
    return Placement(tuple(target - centre))  # type: ignore[arg-type]


def partner_placement(points: np.ndarray) -> Placement:
    """Where positions ``points`` (n, 3), recorded in the partner's frame (origin the partner,
    z up), go in the iCub's root frame: the origin onto :data:`PARTNER_ORIGIN`, turned about
    the vertical so that the points' mean horizontal direction from the origin (each point
    farther than :data:`MIN_OFFSET` one unit vector: an outlier counts as much as any other
    sample) points at the robot, from the partner towards the root frame's origin. No turn
    without such a point or direction."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    points = points[np.all(np.isfinite(points), axis=1)]
    origin = np.asarray(PARTNER_ORIGIN)
    flat = points[:, :2]
    length = np.linalg.norm(flat, axis=1)
    far = length >= MIN_OFFSET
    ahead = (flat[far] / length[far, None]).sum(axis=0)
    yaw = 0.0
    if np.linalg.norm(ahead) > 1e-9:
        towards = -origin[:2]  # from the partner to the robot
        yaw = math.atan2(towards[1], towards[0]) - math.atan2(ahead[1], ahead[0])
        yaw = math.remainder(yaw, 2.0 * math.pi) + 0.0  # no -0.0
    return Placement(tuple(origin), yaw)  # type: ignore[arg-type]
