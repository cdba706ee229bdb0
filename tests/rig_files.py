"""Small rig recordings written by each format's own writer, for ``tests/test_promp_rigs.py``
and the bad-input corpus: a ROS 2 MCAP bag, a ROS 1 bag, an XDF file (a tiny writer of the XDF
1.0 chunks below: pyxdf only reads), a C3D file (ezc3d) and YARP dumps.

Every session holds the same movement, known in closed form so that a value read anywhere is
checked exactly: the hand moves linearly (:func:`hand_at`, metres) and is sampled at 100 Hz; the
head turns linearly (:func:`head_at`, radians) and is sampled at 30 Hz, from 5 ms later;
:data:`MARKERS` cut six demonstrations of two classes (:data:`SPANS`).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from pathlib import Path

import numpy as np

HAND_HZ, HEAD_HZ = 100.0, 30.0
DURATION = 10.6
HEAD_DELAY = 0.005
EPOCH_NS = 1_700_000_000 * 10**9  # the ROS bags' clock starts here
SPANS = (("reach", 0.5, 1.8), ("wave", 2.2, 3.6), ("reach", 4.0, 5.5),
         ("wave", 5.8, 7.2), ("reach", 7.6, 8.9), ("wave", 9.2, 10.3))  # fmt: skip
MARKERS = tuple(m for klass, a, b in SPANS for m in ((a, f"start {klass}"), (b, f"end {klass}")))


def hand_at(t: np.ndarray) -> np.ndarray:
    """The hand at times ``t`` (s): shape (n, 3), metres; linear, so interpolation is exact."""
    t = np.asarray(t, dtype=float)
    return np.column_stack([0.1 + 0.05 * t, -0.2 + 0.01 * t, 0.3 - 0.02 * t])


def head_at(t: np.ndarray) -> np.ndarray:
    """The head's roll, pitch, yaw at ``t`` (s): shape (n, 3), radians."""
    t = np.asarray(t, dtype=float)
    return np.column_stack([0.1 * t, -0.05 * t, 0.2 - 0.01 * t])


def hand_times(duration: float = DURATION) -> np.ndarray:
    return np.arange(round(duration * HAND_HZ)) / HAND_HZ


def head_times(duration: float = DURATION) -> np.ndarray:
    return HEAD_DELAY + np.arange(round(duration * HEAD_HZ)) / HEAD_HZ


def quaternion(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """x, y, z, w of the rotation roll about x, then pitch about y, then yaw about z (fixed)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)  # fmt: skip


# ------------------------------------------------------------------------------ ROS


def _ns(t: float) -> int:
    return EPOCH_NS + round(t * 1e9)


def write_ros2_bag(
    path: Path,
    markers: Sequence[tuple[float, str]] = MARKERS,
    hand: tuple[np.ndarray, np.ndarray] | None = None,
    head_duration: float = DURATION,
) -> Path:
    """A ROS 2 bag folder in MCAP storage: ``/hand`` (PoseStamped, 100 Hz), ``/head``
    (PoseStamped, 30 Hz, the orientation a quaternion), ``/events`` (String)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.LATEST)
    t = store.types
    pose_type, string_type = "geometry_msgs/msg/PoseStamped", "std_msgs/msg/String"

    def pose(time: float, position, orientation=(0.0, 0.0, 0.0, 1.0)):
        ns = _ns(time)
        header = t["std_msgs/msg/Header"](t["builtin_interfaces/msg/Time"](ns // 10**9,
                                                                           ns % 10**9), "base")
        return t[pose_type](header, t["geometry_msgs/msg/Pose"](
            t["geometry_msgs/msg/Point"](*map(float, position)),
            t["geometry_msgs/msg/Quaternion"](*orientation)))  # fmt: skip

    hand_t, hand_v = hand if hand is not None else (hand_times(), hand_at(hand_times()))
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        hand_c = writer.add_connection("/hand", pose_type, typestore=store)
        head_c = writer.add_connection("/head", pose_type, typestore=store)
        events = writer.add_connection("/events", string_type, typestore=store)
        messages = [(_ns(s), hand_c, pose(s, v)) for s, v in zip(hand_t, hand_v, strict=True)]
        for s in head_times(head_duration):
            angles = head_at([s])[0]
            messages.append((_ns(s), head_c, pose(s, (0, 0, 0), quaternion(*angles))))
        messages += [(_ns(s), events, t[string_type](label)) for s, label in markers]
        for ns, conn, message in sorted(messages, key=lambda m: m[0]):
            writer.write(conn, ns, store.serialize_cdr(message, conn.msgtype))
    return path


def write_ros1_bag(path: Path, markers: Sequence[tuple[float, str]] = MARKERS) -> Path:
    """A ROS 1 bag: ``/tf`` (TFMessage: ``left_hand`` at 100 Hz and ``head`` at 30 Hz, in the
    same topic at their own times) and ``/events`` (String)."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)  # it lacks tf2_msgs: register it
    store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                      "tf2_msgs/msg/TFMessage"))  # fmt: skip
    t = store.types

    def transform(time: float, frame: str, translation, rotation=(0.0, 0.0, 0.0, 1.0)):
        ns = _ns(time)
        header = t["std_msgs/msg/Header"](0, t["builtin_interfaces/msg/Time"](ns // 10**9,
                                                                              ns % 10**9), "base")
        moved = t["geometry_msgs/msg/Transform"](
            t["geometry_msgs/msg/Vector3"](*map(float, translation)),
            t["geometry_msgs/msg/Quaternion"](*rotation),
        )
        return t["geometry_msgs/msg/TransformStamped"](header, frame, moved)

    tf_type = "tf2_msgs/msg/TFMessage"
    messages = [(s, "tf", transform(s, "left_hand", v))
                for s, v in zip(hand_times(), hand_at(hand_times()), strict=True)]  # fmt: skip
    messages += [(s, "tf", transform(s, "head", (0, 0, 0), quaternion(*head_at([s])[0])))
                 for s in head_times()]  # fmt: skip
    messages += [(s, "events", t["std_msgs/msg/String"](label)) for s, label in markers]
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with Writer(path) as writer:
        tf = writer.add_connection("/tf", tf_type, typestore=store)
        events = writer.add_connection("/events", "std_msgs/msg/String", typestore=store)
        for s, kind, message in sorted(messages, key=lambda m: m[0]):
            if kind == "tf":
                writer.write(tf, _ns(s), store.serialize_ros1(t[tf_type]([message]), tf_type))
            else:
                writer.write(events, _ns(s), store.serialize_ros1(message, events.msgtype))
    return path


# ------------------------------------------------------------------------------ XDF


def _varlen(n: int) -> bytes:
    if n < 256:
        return struct.pack("<BB", 1, n)
    if n < 2**32:
        return struct.pack("<BI", 4, n)
    return struct.pack("<BQ", 8, n)


def _chunk(tag: int, content: bytes) -> bytes:
    return _varlen(len(content) + 2) + struct.pack("<H", tag) + content


def xdf_stream_header(
    sid: int,
    name: str,
    kind: str,
    rate: float,
    channel_format: str,
    channels: Sequence[tuple[str, str]] = (),
    count: int = 1,
) -> bytes:
    labels = "".join(f"<channel><label>{label}</label><unit>{unit}</unit></channel>"
                     for label, unit in channels)  # fmt: skip
    xml = (f'<?xml version="1.0"?><info><name>{name}</name><type>{kind}</type>'
           f"<channel_count>{len(channels) or count}</channel_count>"
           f"<nominal_srate>{rate}</nominal_srate><channel_format>{channel_format}"
           f"</channel_format><desc><channels>{labels}</channels></desc></info>")  # fmt: skip
    return _chunk(2, struct.pack("<I", sid) + xml.encode())


def xdf_samples(sid: int, times: Sequence[float], rows: Sequence) -> bytes:
    body = struct.pack("<I", sid) + _varlen(len(times))
    for stamp, row in zip(times, rows, strict=True):
        body += b"\x08" + struct.pack("<d", stamp)
        if isinstance(row[0], str):
            for text in row:
                body += _varlen(len(text.encode())) + text.encode()
        else:
            body += struct.pack(f"<{len(row)}d", *row)
    return _chunk(3, body)


def xdf_footer(sid: int, times: Sequence[float]) -> bytes:
    xml = (f'<?xml version="1.0"?><info><first_timestamp>{times[0]}</first_timestamp>'
           f"<last_timestamp>{times[-1]}</last_timestamp><sample_count>{len(times)}"
           "</sample_count></info>")  # fmt: skip
    return _chunk(6, struct.pack("<I", sid) + xml.encode())


XDF_START = 3000.0  # LSL clocks count from the machine's boot


def write_xdf(
    path: Path,
    markers: Sequence[tuple[float, str]] = MARKERS,
    head_times_: np.ndarray | None = None,
) -> Path:
    """An XDF file: ``hand`` (3 channels x, y, z in mm, 100 Hz), ``head`` (roll, pitch, yaw
    in degrees, 30 Hz), ``events`` (a string marker stream), each stream in two chunks of
    samples and with its footer, as LabRecorder writes them."""
    hand_t, head_t = hand_times(), head_times() if head_times_ is None else head_times_
    content = b"XDF:" + _chunk(1, b'<?xml version="1.0"?><info><version>1.0</version></info>')
    content += xdf_stream_header(1, "hand", "Mocap", HAND_HZ, "double64",
                                 [("x", "mm"), ("y", "mm"), ("z", "mm")])  # fmt: skip
    content += xdf_stream_header(2, "head", "HeadPose", HEAD_HZ, "double64",
                                 [("roll", "deg"), ("pitch", "deg"), ("yaw", "deg")])  # fmt: skip
    content += xdf_stream_header(3, "events", "Markers", 0, "string", count=1)
    hand_rows = 1000.0 * hand_at(hand_t)
    head_rows = np.degrees(head_at(head_t))
    half = len(hand_t) // 2
    for part in (slice(0, half), slice(half, None)):
        content += xdf_samples(1, XDF_START + hand_t[part], hand_rows[part].tolist())
    content += xdf_samples(2, (XDF_START + head_t).tolist(), head_rows.tolist())
    if markers:
        content += xdf_samples(3, [XDF_START + s for s, _ in markers],
                               [[label] for _, label in markers])  # fmt: skip
    content += xdf_footer(1, XDF_START + hand_t) + xdf_footer(2, XDF_START + head_t)
    if markers:
        content += xdf_footer(3, [XDF_START + s for s, _ in markers])
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_bytes(content)
    return Path(path)


# ------------------------------------------------------------------------------ C3D


def write_c3d(path: Path, markers: Sequence[tuple[float, str]] = MARKERS,
              seen: np.ndarray | None = None) -> Path:  # fmt: skip
    """A C3D file: the markers ``Subject1:LHAND`` (the hand, in mm) and ``RHAND`` at 100 Hz,
    two analog channels at 1000 Hz (``EMG1`` in V, ``Fz`` in N), and the events."""
    import ezc3d

    c3d = ezc3d.c3d()
    times = hand_times()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [HAND_HZ]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = ("Subject1:LHAND", "RHAND")
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    points = np.ones((4, 2, times.size))
    points[:3, 0, :] = 1000.0 * hand_at(times).T
    points[:3, 1, :] = 1000.0 * (hand_at(times).T + 0.1)
    if seen is not None:
        points[:3, 0, ~seen] = np.nan
    c3d["data"]["points"] = points
    c3d["parameters"]["ANALOG"]["RATE"]["value"] = [10 * HAND_HZ]
    c3d["parameters"]["ANALOG"]["LABELS"]["value"] = ("EMG1", "Fz")
    c3d["parameters"]["ANALOG"]["UNITS"]["value"] = ("V", "N")
    analog_t = np.arange(10 * times.size) / (10 * HAND_HZ)
    c3d["data"]["analogs"] = np.stack([0.001 * analog_t, 5.0 + analog_t])[None]
    if markers:
        c3d.add_parameter("EVENT", "USED", [len(markers)])
        c3d.add_parameter("EVENT", "LABELS", [label for _, label in markers])
        c3d.add_parameter("EVENT", "CONTEXTS", ["General"] * len(markers))
        c3d.add_parameter("EVENT", "TIMES", np.array([[0.0] * len(markers),
                                                      [s for s, _ in markers]]))  # fmt: skip
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    c3d.write(str(path))
    return Path(path)


# ------------------------------------------------------------------------------ YARP


def write_yarp_port(folder: Path, port: str, times: Sequence[float], rows: Sequence,
                    stamp: str = "", nested: bool = False) -> Path:  # fmt: skip
    """One dumper folder: ``data.log`` (``counter time values``; the values in parentheses,
    a nested Bottle, when ``nested``) and ``info.log``."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = []
    for k, (t, row) in enumerate(zip(times, rows, strict=True)):
        values = " ".join(f'"{v}"' if isinstance(v, str) else f"{v:.9f}" for v in row)
        lines.append(f"{k} {t:.6f} " + (f"({values})" if nested else values))
    (folder / "data.log").write_text("\n".join(lines) + "\n")
    info = "Type: Bottle;\n" + (f"Stamp: {stamp};\n" if stamp else "")
    (folder / "info.log").write_text(info + f"[{times[0]:.6f}] {port} [connected]\n")
    return folder


YARP_START = 1_700_000_000.0  # yarp::os::Time::now(): seconds since the epoch


def write_yarp_session(folder: Path, markers: Sequence[tuple[float, str]] = MARKERS,
                       head_duration: float = DURATION) -> Path:  # fmt: skip
    """A dump of three ports: ``left_arm`` (the hand's x, y, z in metres, 100 Hz; the values
    in parentheses like a nested Bottle), ``head`` (roll, pitch, yaw in degrees, 30 Hz),
    ``events`` (text)."""
    arm_t, head_t = hand_times(), head_times(head_duration)
    write_yarp_port(folder / "left_arm", "/icub/left_arm/state:o", YARP_START + arm_t,
                    hand_at(arm_t).tolist(), nested=True)  # fmt: skip
    write_yarp_port(folder / "head", "/partner/head:o", YARP_START + head_t,
                    np.degrees(head_at(head_t)).tolist())  # fmt: skip
    if markers:
        write_yarp_port(folder / "events", "/events:o", [YARP_START + s for s, _ in markers],
                        [[label] for _, label in markers])  # fmt: skip
    return folder


# A dump of several takes per class, in either layout yarpdatadumper's folders come in
# (promp.rigs.yarp_layout): each take's ports at their own rates, the hand nested, the head in
# degrees. ``takes``: {class: {number: {port: (times in s from the take's start, rows)}}}.
YARP_DUMP_PORTS = {"state": ("/icub/left_arm/state:o", True), "head": ("/partner/head:o", False)}


def yarp_dump_folder(root: Path, klass: str, number: str, port: str, numbered: bool) -> Path:
    """Where a port's dump of one take goes: ``<class>/<port>/<port>:o[_NNNNN]`` (numbered
    ports; take 00000 is the port's first, unnumbered dump) or ``<class>/<number>/<port>``
    (take folders)."""
    if not numbered:
        return Path(root) / klass / number / port
    return Path(root) / klass / port / (f"{port}:o" + ("" if number == "00000" else f"_{number}"))


def write_yarp_dump(root: Path, takes, numbered: bool) -> Path:
    """The dump of ``takes`` in one layout (see :func:`yarp_dump_folder`), each take starting
    10 s after the previous one on YARP's clock."""
    start = YARP_START
    for klass, numbers in takes.items():
        for number, ports in numbers.items():
            for port, (times, rows) in ports.items():
                name, nested = YARP_DUMP_PORTS[port]
                folder = yarp_dump_folder(root, klass, number, port, numbered)
                write_yarp_port(folder, name, start + np.asarray(times), rows, nested=nested)
            start += 10.0
    return Path(root)


# ------------------------------------------------------------------------------ an iCub's dump
# An iCub's dataDumper folders as they come: the arm's Cartesian state (x, y, z and the
# axis-angle of the hand, 7 values) and the end effector's wrench (6 values), both at 100 Hz,
# the wrench's dumper connected WRENCH_DELAY later than the state's. In each take the hand
# rests, moves at 20 cm/s during ICUB_MOVES, and rests again; the wrench follows the hand (a
# spring's force), so it moves when the hand moves.
ICUB_PORTS = {
    "state": "/icub/cartesianController/left_arm/state:o",
    "cartesianEndEffectorWrench": "/wholeBodyDynamics/left_arm/cartesianEndEffectorWrench:o",
}
ICUB_TAKE_S = 9.0
ICUB_MOVES = ((1.0, 2.0), (4.0, 5.5), (7.0, 8.0))
ICUB_DIRECTIONS = {"reach": (1.0, 0.0, 0.0), "wave": (0.0, 0.6, 0.8)}
WRENCH_DELAY = 0.037
ICUB_MARKERS = ((0.0, "start reach"), (2.5, "end reach"), (3.5, "start wave"),
                (6.0, "end wave"), (6.5, "start reach"), (8.6, "end reach"))  # fmt: skip


def icub_hand(t: np.ndarray, klass: str) -> np.ndarray:
    """The hand at ``t`` (s from the take's start) in a take of ``klass``: (n, 3) metres,
    piecewise linear (20 cm/s along the class's direction during each of ICUB_MOVES)."""
    t = np.asarray(t, dtype=float)
    travelled = sum(np.clip(t - a, 0.0, b - a) for a, b in ICUB_MOVES) * 0.2
    return np.array([0.3, -0.1, 0.1]) + np.outer(travelled, ICUB_DIRECTIONS[klass])


def icub_wrench(t: np.ndarray, klass: str) -> np.ndarray:
    """The wrench at ``t``: (n, 6), forces in N and moments in N m following the hand."""
    moved = icub_hand(t, klass) - icub_hand(np.zeros(1), klass)
    return np.hstack([2.0 + 40.0 * moved, 0.1 + 4.0 * moved])


def icub_take(klass: str, delay: float = WRENCH_DELAY) -> dict[str, tuple[np.ndarray, list]]:
    """One take's ports: {port: (times in s from the take's start, rows)}; the wrench starts
    ``delay`` s after the state and both stop at once."""
    state_t = np.arange(round(ICUB_TAKE_S * HAND_HZ)) / HAND_HZ
    wrench_t = state_t[state_t + delay <= state_t[-1]] + delay
    pose = np.hstack([icub_hand(state_t, klass), np.tile([0.0, 0.0, 1.0, 0.5], (state_t.size, 1))])
    return {"state": (state_t, pose.tolist()),
            "cartesianEndEffectorWrench": (wrench_t, icub_wrench(wrench_t, klass).tolist())}


def write_icub_dump(root: Path, takes: dict[str, int], delay: float = WRENCH_DELAY) -> Path:
    """A dump in numbered port folders, as the iCub's dumpers leave it:
    ``<class>/<port>/<port>[_NNNNN]/{data,info}.log``, ``takes[class]`` takes per class
    (the first unnumbered), each starting 20 s after the previous one on YARP's clock."""
    start = YARP_START
    for klass, n in takes.items():
        for k in range(n):
            for port, (times, rows) in icub_take(klass, delay).items():
                folder = Path(root) / klass / port / (port + (f"_{k:05d}" if k else ""))
                write_yarp_port(folder, ICUB_PORTS[port], start + times, rows)
            start += 20.0
    return Path(root)


def write_icub_session(folder: Path, delay: float = WRENCH_DELAY) -> Path:
    """One take folder of both ports and an ``events`` port of ICUB_MARKERS (a session cut by
    its markers; each demonstration's hand moves along its class's direction... as a reach:
    the markers give the classes, the movement is the reach take's)."""
    for port, (times, rows) in icub_take("reach", delay).items():
        write_yarp_port(folder / port, ICUB_PORTS[port], YARP_START + times, rows)
    write_yarp_port(folder / "events", "/events:o", [YARP_START + s for s, _ in ICUB_MARKERS],
                    [[label] for _, label in ICUB_MARKERS])  # fmt: skip
    return Path(folder)
