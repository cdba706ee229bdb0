"""Where the 3D view's camera goes: the presets (*Partner view*, *Top view*, *Side view*) and
*Frame paths*, as pure maths on points (no viser; tested without a browser).

A view is a direction (from the camera towards what it looks at) and the points to frame;
every point must be inside the picture with a margin, in the part of the canvas the GUI panel
leaves free: viser's floating panel covers the right :data:`PANEL_PX` pixels, so the points are
centred in the canvas' left part (the look-at point is shifted sideways for that, and orbiting
turns about it). *Frame paths* keeps the field of view and moves the camera to the shortest
distance at which the points fit; the presets stand at a fixed place (the Partner view behind
and above the partner's head, the others :data:`PRESET_DISTANCE` from the paths) and zoom: the
narrowest field of view that fits them, so that their perspective stays natural.

What is framed is the data, robust to a few outliers (:func:`framed_points`): a glitch metres
away, or one take recorded elsewhere, does not shrink the demonstrations to a speck.

Conventions: world frame z up (the robot's root frame); a pose's ``fov`` is the vertical field
of view in radians, as viser's; pixels from the top-left corner, y down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robots.icub.scene import DEFAULT_SCENE

UP = np.array([0.0, 0.0, 1.0])
FOV = math.radians(42.0)
PANEL_PX = 400.0  # viser's "large" floating panel (24 em) and its margin
CANVAS = (1400, 900)  # assumed for the camera a new browser tab starts with
MARGIN = 0.12  # of each half of the free picture, left empty around the points
PRESET_MARGIN = 0.4  # the presets leave more room around the paths: the robot, table, bins
NEAR = 0.08  # metres: no framed point closer to the camera than this
PARTNER_EYE_OFFSET = np.array([-0.3, 0.0, 0.4])  # from the partner's head centre, metres
PRESET_DISTANCE = 1.3  # metres from the paths, Top and Side views
OUTLIER_SHARE = 0.9  # framed: the points within OUTLIER_FACTOR times the distance from their
OUTLIER_FACTOR = 3.0  # median that this share of them is within

PARTNER, TOP, SIDE, FRAME = "Partner view", "Top view", "Side view", "Frame paths"
VIEWS = (PARTNER, TOP, SIDE, FRAME)


@dataclass(frozen=True)
class CameraPose:
    """A camera: ``position`` and ``look_at`` (3,) in metres, world ``up`` (3,), vertical
    ``fov`` in radians."""

    position: np.ndarray
    look_at: np.ndarray
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    fov: float = FOV

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, forward) unit vectors of the picture, in the world frame."""
        return _axes(self.look_at - self.position, self.up)


def _axes(direction, up) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    forward = np.asarray(direction, dtype=float)
    norm = np.linalg.norm(forward)
    if not np.isfinite(norm) or norm < 1e-12:
        raise ValueError(f"a view direction must be a non-zero finite vector, got {direction}")
    forward = forward / norm
    right = np.cross(forward, np.asarray(up, dtype=float))
    if np.linalg.norm(right) < 1e-6:  # looking along up: any right will do
        right = np.cross(forward, [1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    return right, np.cross(right, forward), forward


def project(pose: CameraPose, points, width: int, height: int) -> np.ndarray:
    """Pixel coordinates (n, 2) of world ``points`` (n, 3) in a ``width`` x ``height``
    picture; NaN for points behind the camera."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    right, up, forward = pose.axes()
    rel = points - pose.position
    depth = rel @ forward
    focal = (height / 2.0) / math.tan(pose.fov / 2.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = width / 2.0 + focal * (rel @ right) / depth
        y = height / 2.0 - focal * (rel @ up) / depth
    out = np.column_stack([x, y])
    out[depth <= 0] = np.nan
    return out


def frame(
    points,
    direction,
    width: int = CANVAS[0],
    height: int = CANVAS[1],
    fov: float = FOV,
    up=UP,
    panel_px: float = PANEL_PX,
    margin: float = MARGIN,
    distance: float | None = None,
) -> CameraPose:
    """The camera looking along ``direction`` at ``points`` (n, 3) so that every point lies
    inside the free part of a ``width`` x ``height`` canvas (left of ``panel_px``), with
    ``margin`` of each half-extent left empty: from the shortest distance at which they fit in
    ``fov``, or, given a ``distance`` (from the camera to the points' centre, along the
    direction), with the narrowest field of view at which they fit from there.

    Raises
    ------
    ValueError
        No finite point, a zero direction, a canvas with no free part, or a ``distance`` that
        puts a point behind the camera.
    """
    points = np.atleast_2d(np.asarray(points, dtype=float))
    points = points[np.all(np.isfinite(points), axis=1)]
    if points.shape[0] == 0:
        raise ValueError("nothing to frame: no finite point")
    free = width - panel_px
    if width <= 0 or height <= 0 or free < 0.2 * width:
        raise ValueError(f"a {width} x {height} canvas leaves no room beside a {panel_px} px panel")
    right, up_, forward = _axes(direction, up)
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    rel = points - centre
    x, y, z = rel @ right, rel @ up_, rel @ forward
    aspect = width / height
    # The free picture in normalised coordinates (-1..1 across the whole canvas), shrunk.
    x_lo, x_hi = -1.0, 1.0 - 2.0 * panel_px / width
    x_mid, x_half = 0.5 * (x_lo + x_hi), 0.5 * (x_hi - x_lo) * (1.0 - margin)
    ranges = ((x_mid - x_half, x_mid + x_half), (-(1.0 - margin), 1.0 - margin))

    def shifts(distance: float, tan_v: float) -> tuple[float, float] | None:
        """Sideways and vertical shifts of the look-at point that fit every point at this
        distance and field of view, or None when none does."""
        depth = distance + z
        if np.any(depth < NEAR):
            return None
        out = []
        for coord, tan, (lo, hi) in ((x, tan_v * aspect, ranges[0]), (y, tan_v, ranges[1])):
            # lo <= (coord - s) / (depth tan) <= hi  <=>  coord - hi depth tan <= s <= ...
            low = np.max(coord - hi * depth * tan)
            high = np.min(coord - lo * depth * tan)
            if low > high:
                return None
            out.append(0.5 * (low + high))
        return out[0], out[1]

    if distance is None:  # the shortest distance at this field of view
        tan_v = math.tan(fov / 2.0)
        fits = lambda d: shifts(d, tan_v) is not None  # noqa: E731
        lo, hi = float(np.max(-z)) + NEAR, 1.0
    else:  # the narrowest field of view from this distance
        if np.any(distance + z < NEAR):
            raise ValueError(f"from {distance:.2f} m, some points are behind the camera")
        fits = lambda t: shifts(distance, t) is not None  # noqa: E731
        lo, hi = 1e-4, math.tan(fov / 2.0)
    while not fits(hi):
        hi *= 2.0
        if hi > 1e6:
            raise ValueError("cannot frame these points")
    for _ in range(60):  # bisection: the values that fit are an interval [v*, inf)
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if fits(mid) else (mid, hi)
    if distance is None:
        distance, tan_v = hi, math.tan(fov / 2.0)
    else:
        tan_v = hi
    sx, sy = shifts(distance, tan_v)
    look_at = centre + sx * right + sy * up_
    return CameraPose(
        look_at - distance * forward, look_at, tuple(float(u) for u in up), 2 * math.atan(tan_v)
    )


def framed_points(points) -> np.ndarray:
    """``points`` (n, 3) without their outliers: those farther from the points' median (per
    axis) than :data:`OUTLIER_FACTOR` times the distance :data:`OUTLIER_SHARE` of the points
    are within. Paths, however they spread, have their farthest points within about 1.1 times
    that distance (a straight segment, seen from its middle: 1 / 0.9); a glitch, or a few
    takes out of hundreds of samples, far beyond it is left out. The finite points all kept
    when they are all at one place."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    points = points[np.all(np.isfinite(points), axis=1)]
    if points.shape[0] == 0:
        return points
    distance = np.linalg.norm(points - np.median(points, axis=0), axis=1)
    scale = float(np.quantile(distance, OUTLIER_SHARE))
    if scale <= 0.0:
        return points
    return points[distance <= OUTLIER_FACTOR * scale]


def preset_direction(view: str) -> np.ndarray:
    """The direction the Top and Side views look along."""
    if view == TOP:
        return np.array([0.08, 0.0, -1.0])  # from above, the robot at the top of the picture
    if view == SIDE:
        return np.array([0.0, 1.0, -0.3])  # from the robot's left, a little above
    raise ValueError(f"no fixed direction for view {view!r}; expected {TOP!r} or {SIDE!r}")


def partner_eye() -> np.ndarray:
    """Where the Partner view looks from: behind and above the partner's head, so that the
    head stays below the line of sight."""
    return np.asarray(DEFAULT_SCENE.partner_head) + PARTNER_EYE_OFFSET


def view_pose(view: str, points, width: int = CANVAS[0], height: int = CANVAS[1]) -> CameraPose:
    """The camera of preset ``view`` (Partner, Top or Side) framing ``points`` (n, 3) by its
    field of view: the Partner view from :func:`partner_eye`, the others from
    :data:`PRESET_DISTANCE` away; from further back along the same direction when some points
    would be behind the camera."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    finite = points[np.all(np.isfinite(points), axis=1)]
    if finite.shape[0] == 0:
        raise ValueError("nothing to frame: no finite point")
    centre = 0.5 * (finite.min(axis=0) + finite.max(axis=0))
    if view == PARTNER:
        direction = centre - partner_eye()
        distance = float(np.linalg.norm(direction))
    else:
        direction, distance = preset_direction(view), PRESET_DISTANCE
    # Paths that reach behind the eye (a large or distant dataset) are framed from further
    # back along the same direction, never from among them.
    _, _, forward = _axes(direction, UP)
    distance = max(distance, float(np.max((centre - finite) @ forward)) + 2.0 * NEAR)
    return frame(finite, direction, width, height, FOV, margin=PRESET_MARGIN, distance=distance)


def scene_points() -> np.ndarray:
    """What to frame when there are no paths: every hand target of the scene (pick, bins)."""
    return np.array(list(DEFAULT_SCENE.hand_targets().values()))
