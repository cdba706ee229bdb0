"""C3D motion capture (Vicon, Qualisys, OptiTrack exports), read with ``ezc3d``.

Each marker (``POINT:LABELS``, e.g. ``Subject1:LHAND``) is a stream with the fields ``x``,
``y``, ``z`` in ``POINT:UNITS`` (``mm`` in most exports), converted to metres; the frames where
the marker was not seen (NaN, or a negative residual) are not samples of it (a short occlusion
is interpolated across, a long one is refused as a stream that stops). The analog channels
(force plates, EMG) are the stream ``ANALOG``, each field named by its ``ANALOG:LABELS`` entry, in
its ``ANALOG:UNITS``, at ``ANALOG:RATE``. Frame ``k`` is at ``k / POINT:RATE`` seconds. The
events (``EVENT:LABELS`` at ``EVENT:TIMES``, as Vicon Nexus writes them) are the marker stream
``EVENT``, timed from the first frame (a time within a thousandth of a frame of one, as float32
stores it, is that frame's).

Refused: not a C3D file, or a file shorter than the frames its header declares (truncated).
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from promp.rigs.streams import Recording, unreadable

__all__ = ["check_size", "needs_ezc3d", "open_recording", "SUFFIXES"]

SUFFIXES = (".c3d",)
ANALOG, EVENT = "ANALOG", "EVENT"


def needs_ezc3d():
    """The ``ezc3d`` module, or the error naming the extra that installs it."""
    try:
        import ezc3d
    except ImportError:
        raise ValueError(
            "reading C3D files needs the optional extra: pip install "
            "'icub-intention-studio[c3d]' (ezc3d)"
        ) from None
    return ezc3d


def _parameter(c3d, group: str, name: str, default=None):
    try:
        return c3d["parameters"][group][name]["value"]
    except KeyError:
        return default


def check_size(content: bytes, label: str) -> None:
    """ValueError when the file is shorter than the frames its header declares (ezc3d reads a
    truncated file's frames silently and lowers the count). Only Intel-ordered files (the
    exports of every current system) are checked; the header's words are those of the C3D
    user guide: points, analog values per frame, first and last frame, scale, data block."""
    if len(content) < 516 or content[512 + 3] != 84:
        return
    points, analogs, first, last, _, scale, start = struct.unpack("<HHHHHfH", content[2:18])
    if last == 0xFFFF or last < first or start < 2:
        return  # a long capture counts its frames elsewhere
    width = 4 if scale < 0 else 2
    expected = (start - 1) * 512 + (last - first + 1) * (4 * points + analogs) * width
    if len(content) < expected:
        raise ValueError(
            f"{label}: truncated: the header declares {last - first + 1} frames "
            f"({expected} bytes), the file has {len(content)} bytes"
        )


def open_recording(path: Path, label: str) -> Recording:
    """The markers, analog channels and events of the C3D file ``path`` (see the module
    docstring).

    Raises
    ------
    ValueError
        ``ezc3d`` missing (naming the extra), not a C3D file, or truncated.
    """
    ezc3d = needs_ezc3d()
    try:
        check_size(Path(path).read_bytes(), label)
        c3d = ezc3d.c3d(str(path))
    except Exception as exc:  # ezc3d raises OSError, RuntimeError, IndexError... on bad files
        raise unreadable(label, "C3D file", exc) from None
    header = c3d["header"]
    points = np.asarray(c3d["data"]["points"], dtype=float)
    analogs = np.asarray(c3d["data"]["analogs"], dtype=float)
    recording = Recording(label, {}, {})
    rate = float(np.ravel(_parameter(c3d, "POINT", "RATE", [header["points"]["frame_rate"]]))[0])
    if points.shape[-1] and not rate > 0:
        raise ValueError(f"{label}: POINT:RATE is {rate}; a rate in Hz is needed")
    unit = str((list(_parameter(c3d, "POINT", "UNITS", [""])) or [""])[0]).strip()
    labels = [str(name).strip() for name in _parameter(c3d, "POINT", "LABELS", [])]
    residuals = np.asarray(c3d["data"]["meta_points"]["residuals"], dtype=float)
    times = np.arange(points.shape[-1]) / rate if points.shape[-1] else np.zeros(0)
    left_out = []
    for j, name in enumerate(labels[: points.shape[1]]):
        xyz = points[:3, j, :].T
        seen = np.all(np.isfinite(xyz), axis=1)
        if residuals.size:
            seen &= residuals[0, j, :] >= 0
        if name in recording.catalogue or not name:
            left_out.append(f"{name or f'point {j}'} (label repeated or empty)")
            continue
        if seen.sum() < 2:
            left_out.append(f"{name} (never seen)")
            continue
        recording.catalogue[name] = ("x", "y", "z")
        recording.units[name] = (unit,) * 3
        recording.tables[name] = (times[seen], xyz[seen])
    if analogs.shape[1] and analogs.shape[-1]:
        analog_rate = float(np.ravel(_parameter(c3d, "ANALOG", "RATE", [0.0]))[0])
        names = [str(n).strip() for n in _parameter(c3d, "ANALOG", "LABELS", [])]
        if len(names) != analogs.shape[1] or len(set(names)) != len(names):
            names = [str(i) for i in range(analogs.shape[1])]
        units = [str(u).strip() for u in _parameter(c3d, "ANALOG", "UNITS", [])]
        if analog_rate > 0:
            recording.catalogue[ANALOG] = tuple(names)
            same = len(units) == len(names)
            recording.units[ANALOG] = tuple(units if same else [""] * len(names))
            recording.tables[ANALOG] = (np.arange(analogs.shape[-1]) / analog_rate, analogs[0].T)
        else:
            left_out.append(f"{ANALOG} (ANALOG:RATE is {analog_rate})")
    event_labels = [str(e).strip() for e in _parameter(c3d, EVENT, "LABELS", [])]
    event_times = np.asarray(_parameter(c3d, EVENT, "TIMES", np.zeros((2, 0))), dtype=float)
    if event_labels and event_times.ndim == 2 and event_times.shape[1] >= len(event_labels):
        first = int(header["points"]["first_frame"]) / rate if rate > 0 else 0.0
        seconds = 60.0 * event_times[0] + event_times[1] - first
        if rate > 0:  # events mark frames; their float32 times are snapped back onto them
            frames = np.round(seconds * rate)
            seconds = np.where(np.abs(seconds * rate - frames) < 1e-3, frames / rate, seconds)
        recording.events[EVENT] = list(zip(seconds.tolist(), event_labels, strict=False))
        recording.marker_streams = (EVENT,)
    recording.left_out = tuple(left_out)
    return recording
