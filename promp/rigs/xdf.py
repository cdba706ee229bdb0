"""XDF files of the Lab Streaming Layer (LabRecorder), read with ``pyxdf``.

A stream is an LSL stream, named by its ``name``; its fields are its channels' labels
(``desc/channels/channel/label``) or their indices ``0, 1, ...``; a channel's ``unit``
(``mm``, ``deg``...) is converted to metres and radians. A stream of ``string`` samples is a
marker stream (its first channel). Times are the recorded time stamps, synchronised across
machines with the file's clock offsets (pyxdf's ``synchronize_clocks``) and not de-jittered
(the stamps are kept as recorded), counted from the first sample of any stream.

The chunk structure is checked first: a file that ends inside a chunk (a recording cut short,
a truncated copy), or is not XDF at all, is refused (pyxdf itself reads what it can and only
logs the rest).
"""

from __future__ import annotations

import gzip
import logging
import struct
import zlib
from pathlib import Path

import numpy as np

from promp.rigs.streams import Recording, unreadable

__all__ = ["check_chunks", "needs_pyxdf", "open_recording", "SUFFIXES", "TAGS"]

SUFFIXES = (".xdf", ".xdfz")
TAGS = range(1, 7)  # FileHeader, StreamHeader, Samples, ClockOffset, Boundary, StreamFooter


def needs_pyxdf():
    """The ``pyxdf`` module, or the error naming the extra that installs it."""
    try:
        import pyxdf
    except ImportError:
        raise ValueError(
            "reading XDF files needs the optional extra: pip install "
            "'icub-intention-studio[xdf]' (pyxdf)"
        ) from None
    return pyxdf


def check_chunks(content: bytes, label: str) -> None:
    """ValueError unless ``content`` is ``XDF:`` followed by whole chunks of known tags."""
    if content[:4] != b"XDF:":
        raise ValueError(f"{label}: not an XDF file (it does not start with 'XDF:')")
    offset = 4
    while offset < len(content):
        width = content[offset]
        if width not in (1, 4, 8) or offset + 1 + width > len(content):
            raise ValueError(f"{label}: corrupt or truncated at byte {offset} (a chunk's length)")
        length = int.from_bytes(content[offset + 1 : offset + 1 + width], "little")
        start = offset + 1 + width
        if length < 2 or start + length > len(content):
            raise ValueError(
                f"{label}: truncated: a chunk at byte {offset} declares {length} bytes, "
                f"{len(content) - start} remain"
            )
        (tag,) = struct.unpack("<H", content[start : start + 2])
        if tag not in TAGS:
            raise ValueError(f"{label}: corrupt at byte {offset}: unknown chunk tag {tag}")
        offset = start + length


def _channels(info: dict, count: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The labels (indices when absent or repeated) and units of a stream's channels."""
    try:
        channels = info["desc"][0]["channels"][0]["channel"]
    except (KeyError, IndexError, TypeError):
        channels = []
    labels = [str((c.get("label") or [""])[0] or "") for c in channels if isinstance(c, dict)]
    units = [str((c.get("unit") or [""])[0] or "") for c in channels if isinstance(c, dict)]
    if len(labels) != count or len(set(labels)) != count or not all(labels):
        labels = [str(i) for i in range(count)]
    if len(units) != count:
        units = [""] * count
    return tuple(labels), tuple(units)


def open_recording(path: Path, label: str) -> Recording:
    """The streams of the XDF file ``path`` (see the module docstring).

    Raises
    ------
    ValueError
        ``pyxdf`` missing (naming the extra), not XDF, truncated or corrupt.
    """
    pyxdf = needs_pyxdf()
    try:
        content = Path(path).read_bytes()
        if Path(path).suffix.lower() == ".xdfz":
            content = gzip.decompress(content)
    except (OSError, EOFError, zlib.error) as exc:  # gzip.BadGzipFile is an OSError
        raise ValueError(f"{label}: cannot be read ({exc})") from None
    check_chunks(content, label)
    quiet = logging.getLogger("pyxdf.pyxdf")
    level = quiet.level
    quiet.setLevel(logging.ERROR)  # pyxdf logs every clock-segment remark as a warning
    try:
        streams, _ = pyxdf.load_xdf(
            str(path), synchronize_clocks=True, dejitter_timestamps=False, verbose=None
        )
    except Exception as exc:  # pyxdf raises what its parsers raise on a corrupt file
        raise unreadable(label, "XDF file", exc) from None
    finally:
        quiet.setLevel(level)
    recording = Recording(label, {}, {})
    names = [str(s["info"]["name"][0]) for s in streams]
    left_out, markers = [], []
    for stream, name in zip(streams, names, strict=True):
        info = stream["info"]
        if names.count(name) > 1:
            name = f"{name}#{info['stream_id']}"
        stamps = np.asarray(stream["time_stamps"], dtype=float)
        if stamps.size == 0:
            left_out.append(f"{name} (no samples)")
            continue
        if info["channel_format"][0] == "string":
            labels = [str(row[0]) if len(row) else "" for row in stream["time_series"]]
            recording.events[name] = list(zip(stamps.tolist(), labels, strict=True))
            markers.append(name)
            continue
        values = np.asarray(stream["time_series"], dtype=float).reshape(stamps.size, -1)
        fields, units = _channels(info, values.shape[1])
        recording.catalogue[name] = fields
        recording.units[name] = units
        recording.tables[name] = (stamps, values)
    recording.start_at_zero()
    recording.marker_streams = tuple(markers)
    recording.left_out = tuple(left_out)
    return recording
