"""What a viewer file holds, whatever its format: 3-D things and scalar series, each at a path,
static or at a time on a named timeline.

A :class:`SceneLog` is written to Rerun (:mod:`promp.viewers.rerun_writer`) and to MCAP for
Foxglove and PlotJuggler (:mod:`promp.viewers.mcap_writer`) alike, so the two files hold the
same entities and values, and a test reads either back against the log it came from.

Units: positions and sizes in metres, in the scene's frame (:data:`FRAME`, the iCub's root
frame: z up, the robot faces -x, its left is -y); angles in radians; times in seconds. A
series says its unit (:attr:`Series.unit`); a sequence timeline counts whole steps (the
observed percent of a movement).

Paths are ``/``-separated names (``demos/reach/demo-3``): Rerun's entity paths, and MCAP's
topics and entity ids.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

__all__ = [
    "FRAME", "check_path", "Color", "Ellipsoids", "Event", "Item", "Mesh", "Model", "Note",
    "Points", "SceneLog", "Series", "Stamp", "Strips", "Timeline", "TimelineKind"
]  # fmt: skip

FRAME = "root_link"  # the iCub URDF's root: the studio's world frame
Color = tuple[int, int, int]  # 0-255
TimelineKind = Literal["seconds", "sequence"]
_NAME = re.compile(r"^[A-Za-z0-9_.%()+-][A-Za-z0-9_.%()+ -]*$")


def check_path(path: str) -> str:
    """``path`` if it is ``/``-separated names (letters, digits, ``_.-%()+`` and inner spaces);
    ValueError otherwise (an empty part, a leading or trailing ``/``, another character)."""
    parts = path.split("/")
    if not path or any(not _NAME.match(p) or p != p.strip() for p in parts):
        raise ValueError(
            f"a viewer path is '/'-separated names of letters, digits, '_.-%()+' and inner "
            f"spaces, got {path!r}"
        )
    return path


@dataclass(frozen=True)
class Timeline:
    """A time axis of the log.

    Attributes
    ----------
    name : str
        As the viewer shows it (``demo_time``, ``observed_percent``).
    kind : {"seconds", "sequence"}
        Seconds (a duration from the start of a movement, or a clock such as LSL's), or whole
        steps.
    label : str
        What it measures, in words (the file's description).
    """

    name: str
    kind: TimelineKind
    label: str

    def __post_init__(self) -> None:
        check_path(self.name)
        if "/" in self.name or self.kind not in ("seconds", "sequence"):
            raise ValueError(f"a timeline is one name of kind 'seconds' or 'sequence', got "
                             f"{self.name!r} of kind {self.kind!r}")  # fmt: skip


@dataclass(frozen=True)
class Stamp:
    """A time on a timeline: ``value`` seconds, or a whole number of steps."""

    timeline: str
    value: float


def _points(values, label: str) -> np.ndarray:
    array = np.array(values, dtype=float)
    if array.ndim != 2 or array.shape[1] != 3 or not np.all(np.isfinite(array)):
        raise ValueError(f"{label}: finite 3-D points of shape (n, 3) expected, got "
                         f"shape {array.shape}")  # fmt: skip
    array.flags.writeable = False
    return array


def _color(color) -> Color:
    rgb = tuple(int(c) for c in color)
    if len(rgb) != 3 or any(not 0 <= c <= 255 for c in rgb):
        raise ValueError(f"a colour is three integers in 0-255, got {color!r}")
    return rgb  # type: ignore[return-value]


def _opacity(opacity: float) -> float:
    if not 0.0 < float(opacity) <= 1.0:
        raise ValueError(f"an opacity is in (0, 1], got {opacity}")
    return float(opacity)


@dataclass(frozen=True, eq=False)
class Strips:
    """Line strips (paths) in metres.

    Attributes
    ----------
    path : str
    strips : tuple of array, shape (n_i, 3)
        Each strip's points, metres, in :data:`FRAME`.
    color : Color
    width : float
        The lines' width, metres.
    at : Stamp or None
        None: static (shown at every time).
    """

    path: str
    strips: tuple[np.ndarray, ...]
    color: Color
    width: float = 0.004
    at: Stamp | None = None

    def __post_init__(self) -> None:
        check_path(self.path)
        strips = tuple(_points(s, self.path) for s in self.strips)
        if not strips or any(s.shape[0] < 2 for s in strips):
            raise ValueError(f"{self.path}: every strip needs at least two points")
        object.__setattr__(self, "strips", strips)
        object.__setattr__(self, "color", _color(self.color))


@dataclass(frozen=True, eq=False)
class Points:
    """Points (an end, a hand at a time), metres; ``radius`` in metres."""

    path: str
    positions: np.ndarray
    color: Color
    radius: float = 0.01
    at: Stamp | None = None

    def __post_init__(self) -> None:
        check_path(self.path)
        object.__setattr__(self, "positions", _points(self.positions, self.path))
        object.__setattr__(self, "color", _color(self.color))


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh (a region's tube).

    Attributes
    ----------
    vertices : array, shape (n, 3)
        Metres, in :data:`FRAME`.
    faces : array, shape (m, 3)
        Vertex indices of each triangle.
    opacity : float
        In (0, 1].
    """

    path: str
    vertices: np.ndarray
    faces: np.ndarray
    color: Color
    opacity: float = 1.0
    at: Stamp | None = None

    def __post_init__(self) -> None:
        check_path(self.path)
        vertices = _points(self.vertices, self.path)
        faces = np.array(self.faces, dtype=np.int64)
        if faces.ndim != 2 or faces.shape[1] != 3 or faces.size == 0:
            raise ValueError(f"{self.path}: faces of shape (m, 3) expected, got {faces.shape}")
        if faces.min() < 0 or faces.max() >= vertices.shape[0]:
            raise ValueError(f"{self.path}: a face names a vertex that does not exist")
        faces.flags.writeable = False
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "faces", faces)
        object.__setattr__(self, "color", _color(self.color))
        object.__setattr__(self, "opacity", _opacity(self.opacity))


@dataclass(frozen=True, eq=False)
class Ellipsoids:
    """Ellipsoids (a region at some phases: :func:`promp.viewers.regions.region_ellipsoids`).

    Attributes
    ----------
    centers : array, shape (n, 3)
        Metres.
    half_axes : array, shape (n, 3)
        The semi-axes' lengths, metres.
    rotations : array, shape (n, 3, 3)
        Each ellipsoid's axes as the columns of a rotation matrix (determinant +1).
    """

    path: str
    centers: np.ndarray
    half_axes: np.ndarray
    rotations: np.ndarray
    color: Color
    opacity: float = 0.3
    at: Stamp | None = None

    def __post_init__(self) -> None:
        check_path(self.path)
        centers = _points(self.centers, self.path)
        half_axes = _points(self.half_axes, self.path)
        rotations = np.array(self.rotations, dtype=float)
        n = centers.shape[0]
        if half_axes.shape[0] != n or rotations.shape != (n, 3, 3):
            raise ValueError(f"{self.path}: {n} centres need {n} half-axes and {n} rotations")
        if np.any(half_axes < 0) or not np.allclose(np.linalg.det(rotations), 1.0, atol=1e-6):
            raise ValueError(f"{self.path}: half-axes must be >= 0 and rotations proper")
        rotations.flags.writeable = False
        object.__setattr__(self, "centers", centers)
        object.__setattr__(self, "half_axes", half_axes)
        object.__setattr__(self, "rotations", rotations)
        object.__setattr__(self, "color", _color(self.color))
        object.__setattr__(self, "opacity", _opacity(self.opacity))


@dataclass(frozen=True, eq=False)
class Model:
    """A 3-D model as glTF binary (``.glb``), already placed in :data:`FRAME` (metres)."""

    path: str
    glb: bytes
    at: Stamp | None = None

    def __post_init__(self) -> None:
        check_path(self.path)
        if not isinstance(self.glb, bytes) or not self.glb.startswith(b"glTF"):
            raise ValueError(f"{self.path}: a model is glTF binary (starting with b'glTF')")


@dataclass(frozen=True, eq=False)
class Series:
    """A scalar against a timeline: ``values[i]`` at ``times[i]``.

    Attributes
    ----------
    label : str
        What it is, for a legend (``p(reach)``, ``hand x``).
    unit : str
        ``"m"``, ``"rad"``, ``"s"``, ``"1"`` (a probability), ``""`` (none stated).
    timeline : str
    times : array, shape (n,)
        Seconds, or whole steps on a sequence timeline.
    values : array, shape (n,)
        NaN where there is none (not drawn).
    """

    path: str
    label: str
    unit: str
    timeline: str
    times: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        check_path(self.path)
        times = np.array(self.times, dtype=float)
        values = np.array(self.values, dtype=float)
        if times.ndim != 1 or times.shape != values.shape or not np.all(np.isfinite(times)):
            raise ValueError(f"{self.path}: one finite time per value expected, got "
                             f"{times.shape} times and {values.shape} values")  # fmt: skip
        times.flags.writeable = values.flags.writeable = False
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)


@dataclass(frozen=True)
class Note:
    """Markdown text (what the file holds, its units), static."""

    path: str
    text: str

    def __post_init__(self) -> None:
        check_path(self.path)


@dataclass(frozen=True)
class Event:
    """Something that happened at a time (a movement's start, a marker, a prediction sent):
    Rerun's ``TextLog``, Foxglove's ``Log`` message."""

    path: str
    text: str
    at: Stamp

    def __post_init__(self) -> None:
        check_path(self.path)


Item = Strips | Points | Mesh | Ellipsoids | Model | Series | Note | Event


@dataclass(frozen=True, eq=False)
class SceneLog:
    """Everything one viewer file holds (see the module docstring).

    Attributes
    ----------
    name : str
        The recording's name (Rerun's application id; MCAP's metadata).
    timelines : tuple of Timeline
    items : tuple of Item
    camera : ((x, y, z), (x, y, z)) or None
        Where a viewer's 3-D view starts: its eye and the point it looks at, metres (z up).
    """

    name: str
    timelines: tuple[Timeline, ...]
    items: tuple[Item, ...] = field(default=())
    camera: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None

    def __post_init__(self) -> None:
        check_path(self.name)
        if self.camera is not None:
            eye, target = (tuple(float(v) for v in _points([p], "camera")[0])
                           for p in self.camera)  # fmt: skip
            if eye == target:
                raise ValueError("the camera's eye and target must differ")
            object.__setattr__(self, "camera", (eye, target))
        object.__setattr__(self, "timelines", tuple(self.timelines))
        object.__setattr__(self, "items", tuple(self.items))
        names = [t.name for t in self.timelines]
        if len(set(names)) != len(names):
            raise ValueError(f"timelines named twice: {names}")
        for item in self.items:
            self.check_time(item)

    def timeline(self, name: str) -> Timeline:
        """The timeline ``name``; ValueError when the log has none of that name."""
        for timeline in self.timelines:
            if timeline.name == name:
                return timeline
        raise ValueError(f"no timeline {name!r} (the log has {[t.name for t in self.timelines]})")

    def check_time(self, item: Item) -> None:
        """ValueError unless ``item``'s times are on a timeline of the log, whole steps on a
        sequence one."""
        if isinstance(item, Series):
            name, values = item.timeline, item.times
        elif getattr(item, "at", None) is not None:
            name, values = item.at.timeline, np.array([item.at.value], dtype=float)
        else:
            return
        timeline = self.timeline(name)
        if not np.all(np.isfinite(values)):
            raise ValueError(f"{item.path}: times must be finite")
        if timeline.kind == "sequence" and not np.all(values == np.round(values)):
            raise ValueError(f"{item.path}: {name} counts whole steps, got {values}")

    def paths(self) -> list[str]:
        """Every item's path, in order (a path may hold items at several times)."""
        return [item.path for item in self.items]
