"""ROS bags, read with ``rosbags`` (no ROS install): ROS 1 ``.bag``, ROS 2 bag folders
(``metadata.yaml`` with ``.db3`` or ``.mcap`` files) and bare ``.mcap``/``.db3`` files.

A topic is a stream; its fields are dotted paths into the message (``pose.position.x``,
``position[3]``, and ``orientation.roll``/``pitch``/``yaw``: the Euler angles, x-y-z extrinsic
like ``tf.transformations``' ``sxyz``, of a quaternion field). On a ``tf2_msgs/TFMessage`` topic
(``/tf``) a field starts with the child frame: ``/tf:left_hand.translation.{x,y,z}``, or for
short ``/tf:left_hand.x,y,z`` (translation) and ``/tf:head.roll,pitch,yaw`` (rotation). A sample's
time is its header stamp when it has one on the bag's clock (within :data:`CLOCK_S` of the time
it was logged), else the time it was logged; every time counts from the bag's start. Units are
ROS's (REP 103): positions in metres, angles in radians. A ``std_msgs/String`` topic is a marker
stream. Images, point clouds and other topics of large arrays are left out of the guess.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from promp.names import natural_sorted
from promp.rigs.streams import Recording, unreadable

__all__ = [
    "CLOCK_S",
    "euler",
    "find_recordings",
    "FRAMES_SCAN",
    "getter",
    "leaves",
    "LEFT_OUT_TYPES",
    "MARKER_TYPES",
    "MAX_GUESSED_ARRAY",
    "needs_rosbags",
    "open_recording",
    "PART",
    "RosbagRecording",
    "SUFFIXES",
    "TF_TYPES",
]

SUFFIXES = (".bag", ".mcap", ".db3")
CLOCK_S = 1.0
MAX_GUESSED_ARRAY = 16  # arrays up to this length are flattened into the guess
LEFT_OUT_TYPES = ("Image", "CompressedImage", "PointCloud2", "PointCloud", "CameraInfo",
                  "LaserScan", "OccupancyGrid")  # fmt: skip
MARKER_TYPES = ("std_msgs/msg/String",)
TF_TYPES = ("tf2_msgs/msg/TFMessage",)
FRAMES_SCAN = 200  # messages of a /tf topic scanned for its child frames
PART = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)$")


def needs_rosbags():
    """The ``rosbags`` reader, or the error naming the extra that installs it."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise ValueError(
            "reading ROS bags needs the optional extra: pip install "
            "'icub-intention-studio[rosbag]' (rosbags)"
        ) from None
    return AnyReader, get_typestore(Stores.LATEST)


def find_recordings(root: Path) -> list[Path]:
    """The bags under ``root``: ``.bag``/``.mcap``/``.db3`` files and ROS 2 bag folders
    (whose storage files are not counted again), sorted."""
    root = Path(root)
    if root.is_file():
        return [root]
    if (root / "metadata.yaml").is_file():
        return [root]
    folders = {p.parent for p in root.rglob("metadata.yaml") if p.is_file()}
    files = [
        p for p in root.rglob("*")
        if p.is_file() and p.suffix.lower() in SUFFIXES and not p.name.startswith(".")
        and not any(f == p.parent or f in p.parents for f in folders)
    ]  # fmt: skip
    return natural_sorted(files + list(folders), key=lambda p: p.relative_to(root))


def _is_message(value: object) -> bool:
    return hasattr(value, "__msgtype__")


def _fields(message: object) -> list[str]:
    return [f for f in message.__dataclass_fields__ if not f.startswith("__")]


def _is_quaternion(message: object) -> bool:
    return _is_message(message) and set(_fields(message)) == {"x", "y", "z", "w"}


def euler(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """Roll, pitch, yaw (radians; rotations about the fixed x, y then z axes) of a quaternion."""
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def leaves(message: object, prefix: str = "") -> list[str]:
    """The numeric field paths of ``message`` a guess may use (headers and long arrays left
    out; a quaternion also as roll, pitch, yaw)."""
    out = []
    for name in _fields(message):
        if name == "header":
            continue
        value = getattr(message, name)
        path = f"{prefix}{name}"
        if _is_quaternion(value):
            out += [f"{path}.{a}" for a in ("roll", "pitch", "yaw")]
        elif _is_message(value):
            out += leaves(value, path + ".")
        elif isinstance(value, bool):
            continue
        elif isinstance(value, (int, float)):
            out.append(path)
        elif isinstance(value, np.ndarray) and value.dtype.kind in "if" and value.ndim == 1:
            if value.dtype.itemsize > 1 and value.size <= MAX_GUESSED_ARRAY:
                out += [f"{path}[{i}]" for i in range(value.size)]
    return out


def getter(path: str) -> Callable[[object], float]:
    """A function reading the field ``path`` (see the module docstring) from a message.

    Raises
    ------
    ValueError
        A path that is not dotted names with optional ``[index]``.
    """
    steps: list[tuple[str, list[int]]] = []
    for part in path.split("."):
        match = PART.match(part)
        if not match:
            raise ValueError(f"invalid field path {path!r}: use names.like.this and [index]")
        steps.append((match.group(1), [int(i) for i in re.findall(r"\d+", match.group(2))]))

    def read(message: object) -> float:
        value = message
        for k, (name, indices) in enumerate(steps):
            if name in ("roll", "pitch", "yaw") and not indices and k == len(steps) - 1:
                if _is_quaternion(value):
                    angles = euler(value.x, value.y, value.z, value.w)
                    return angles[("roll", "pitch", "yaw").index(name)]
            value = getattr(value, name)
            for i in indices:
                value = value[i]
        if _is_message(value) or isinstance(value, (str, bytes, list, np.ndarray)):
            raise TypeError(f"{path} is not a number")
        return float(value)

    return read


class RosbagRecording(Recording):
    """A bag's topics (see the module docstring), read topic by topic on demand."""

    def __init__(self, path: Path, label: str):
        super().__init__(label, {}, {})
        self.path = Path(path)
        self.first: dict[str, object] = {}
        self.frames: dict[str, object] = {}  # a transform of each /tf child frame seen
        self.types: dict[str, str] = {}
        left_out, markers = [], []
        with self._reader() as reader:
            self.origin = reader.start_time
            for topic, info in sorted(reader.topics.items()):
                msgtype = info.msgtype or ""
                self.types[topic] = msgtype
                conns = [c for c in reader.connections if c.topic == topic]
                if msgtype in MARKER_TYPES:
                    markers.append(topic)
                    continue
                if msgtype.rpartition("/")[2] in LEFT_OUT_TYPES or not info.msgcount:
                    left_out.append(f"{topic} ({msgtype or 'no messages'})")
                    continue
                first = None
                fields: list[str] = []
                for k, (conn, _, raw) in enumerate(reader.messages(connections=conns)):
                    message = self._decode(reader, raw, conn.msgtype)
                    first = first or message
                    if msgtype not in TF_TYPES:
                        fields = leaves(message)
                        break
                    for t in message.transforms:
                        frame = t.child_frame_id.lstrip("/")
                        if frame not in self.frames:
                            self.frames[frame] = t.transform
                            fields += [f"{frame}.{p}" for p in leaves(t.transform)]
                    if k >= FRAMES_SCAN:
                        break
                if not fields:
                    left_out.append(f"{topic} ({msgtype}: no numeric field)")
                    continue
                self.first[topic] = first
                self.catalogue[topic] = tuple(fields)
                self.units[topic] = tuple(_unit(f) for f in fields)
        self.marker_streams = tuple(markers)
        self.left_out = tuple(left_out)

    @contextmanager
    def _reader(self) -> Iterator[object]:
        """The open bag; any error of the reader (a truncated or corrupt bag: rosbags raises
        its own errors, and OSError, KeyError, struct.error...) as a ValueError naming it."""
        any_reader, typestore = needs_rosbags()
        try:
            with any_reader([self.path], default_typestore=typestore) as reader:
                yield reader
        except Exception as exc:
            raise unreadable(self.label, "ROS bag", exc) from None

    def _decode(self, reader, raw: bytes, msgtype: str) -> object:
        try:
            return reader.deserialize(raw, msgtype)
        except Exception as exc:  # a truncated or corrupt message
            raise ValueError(
                f"{self.label}: a {msgtype} message cannot be decoded ({exc})"
            ) from None

    def full_path(self, stream: str, name: str) -> str:
        """The full path of a field: on ``/tf``, ``FRAME.x`` is ``FRAME.translation.x`` and
        ``FRAME.roll`` is ``FRAME.rotation.roll`` (a shorthand)."""
        if self.types.get(stream) in TF_TYPES:
            frame, _, rest = name.partition(".")
            if rest in ("x", "y", "z"):
                return f"{frame}.translation.{rest}"
            if rest in ("roll", "pitch", "yaw", "w"):
                return f"{frame}.rotation.{rest}"
        return name

    def field_index(self, stream: str, name: str) -> int | None:
        fields = self.catalogue[stream]
        name = self.full_path(stream, name)
        if name in fields:
            return fields.index(name)
        try:  # a field the guess leaves out (a long array's element) is still readable
            sample = self.first[stream]
            if self.types[stream] in TF_TYPES:
                frame, _, name = name.partition(".")
                sample = self.frames[frame]
            getter(name)(sample)
        except (ValueError, TypeError, AttributeError, IndexError, KeyError):
            return None
        return len(fields)  # readable, past the listed ones

    def suggestions(self) -> list[tuple[str, tuple[str, ...], str]]:
        """Each topic's fields grouped by their parent (``pose.position``, a ``/tf`` frame's
        ``translation``), named after the topic (and the parent when a topic has several)."""
        out = []
        for topic, fields in self.catalogue.items():
            groups: dict[str, list[str]] = {}
            for f in fields:
                parent = f.rpartition(".")[0] if "." in f else re.sub(r"\[\d+\]$", "", f)
                groups.setdefault(parent, []).append(f)
            for parent, members in groups.items():
                last = parent.rpartition(".")[2]
                name = topic if len(groups) == 1 else f"{topic}_{last}"
                if self.types[topic] in TF_TYPES:
                    name = f"{parent.partition('.')[0]}_{last}"
                out.append((topic, tuple(members), name))
        return out

    def field_units(self, stream: str, fields: Sequence[str]) -> tuple[str, ...]:
        return tuple(_unit(self.full_path(stream, f)) for f in fields)

    def stream_title(self, stream: str) -> str:
        return f"topic {stream!r} ({self.types[stream]})"

    def samples(self, stream: str, fields: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        self.require_fields(stream, fields)
        fields = [self.full_path(stream, f) for f in fields]
        tf = self.types[stream] in TF_TYPES
        frames = {f.partition(".")[0] for f in fields} if tf else set()
        if len(frames) > 1:
            raise ValueError(
                f"{self.label}: one modality takes its fields from one frame of {stream!r}, "
                f"got {sorted(frames)}"
            )
        readers = [getter(f.partition(".")[2] if tf else f) for f in fields]
        stamps, logged, rows = [], [], []
        with self._reader() as reader:
            conns = [c for c in reader.connections if c.topic == stream]
            for conn, time, raw in reader.messages(connections=conns):
                message = self._decode(reader, raw, conn.msgtype)
                parts = [message]
                if tf:
                    parts = [
                        t for t in message.transforms if t.child_frame_id.lstrip("/") in frames
                    ]
                for part in parts:
                    header = getattr(part, "header", None)
                    stamp = header.stamp.sec * 10**9 + header.stamp.nanosec if header else 0
                    stamps.append(stamp)
                    logged.append(time)
                    target = part.transform if tf else part
                    try:
                        rows.append([read(target) for read in readers])
                    except (TypeError, AttributeError, IndexError) as exc:
                        raise ValueError(
                            f"{self.label}: message {len(rows)} of {stream!r} has no such "
                            f"field ({exc})"
                        ) from None
        stamps_ns, logged_ns = np.array(stamps, dtype=np.int64), np.array(logged, dtype=np.int64)
        on_clock = stamps_ns.size and np.all(stamps_ns > 0) and float(
            np.median(np.abs(stamps_ns - logged_ns))
        ) <= CLOCK_S * 1e9
        chosen = stamps_ns if on_clock else logged_ns
        times = (chosen - self.origin).astype(float) / 1e9
        return times, np.array(rows, dtype=float).reshape(len(rows), len(fields))

    def markers(self, stream: str) -> list[tuple[float, str]]:
        events = []
        with self._reader() as reader:
            conns = [c for c in reader.connections if c.topic == stream]
            for conn, time, raw in reader.messages(connections=conns):
                events.append(((time - self.origin) / 1e9, str(self._decode(reader, raw,
                                                                            conn.msgtype).data)))
        return events


def _unit(field: str) -> str:
    """ROS's unit of a field, where its name says it (REP 103)."""
    parts = field.split(".")
    if parts[-1] in ("roll", "pitch", "yaw"):
        return "rad"
    if parts[-1] in ("x", "y", "z") and len(parts) > 1 and parts[-2] in ("position",
                                                                         "translation", "point"):
        return "m"
    return ""


def open_recording(path: Path, label: str) -> Recording:
    """The topics of the bag ``path`` (see the module docstring).

    Raises
    ------
    ValueError
        ``rosbags`` missing (naming the extra), or the bag unreadable (truncated, not a bag).
    """
    return RosbagRecording(path, label)
