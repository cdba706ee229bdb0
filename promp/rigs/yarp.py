"""YARP ``dataDumper`` logs (``yarpdatadumper``), the iCub's own recordings; no library needed.

A dumper writes one folder per port: ``data.log``, one line per message,
``<counter> <time stamp> <values...>`` (``<counter> <tx stamp> <rx stamp> <values...>`` when
``info.log`` says ``Stamp: tx+rx``: the sender's stamp is used), and ``info.log`` beside it
(``Type: Bottle;`` and ``[time] /port/name [connected]``). A **recording** is a take: a folder
of such port folders (``<class>/<take>/<port>/data.log``; a folder holding ``data.log`` itself
is a recording of one port), or the folders of one number in a class's numbered port folders
(``<class>/<port>/<port name>_NNNNN/data.log``, as ``yarpdatadumper`` numbers its dumps):
:mod:`promp.rigs.yarp_layout` finds them, and refuses a folder matching neither layout. A
port is a stream named by its port folder (or by the port name ``info.log`` gives, or a
numbered folder's stem); its fields are the values' indices ``0, 1, ...`` (nested lists
``(...)`` flattened in order). A port whose values are text (``"start reach"``) is a marker
stream. YARP logs carry no units: state them in the mapping (``@deg`` for the iCub's joint
encoders, converted to radians).

Refused, naming the file and the line: a line with another number of values than the first
(a truncated file), a non-numeric value in a numeric port, a line without a time stamp.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from promp.names import natural_sorted
from promp.rigs.streams import Recording
from promp.rigs.yarp_layout import LAYOUTS, NumberedTake, find_takes

__all__ = ["CONNECTED", "find_recordings", "open_recording", "TOKEN"]

TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"|[()]|[^\s()"]+')
CONNECTED = re.compile(r"^\[[^\]]*\]\s+(\S+)\s+\[connected\]")


def find_recordings(root: Path) -> list[Path | NumberedTake]:
    """The takes under ``root``, in natural order (:func:`promp.rigs.yarp_layout.find_takes`)."""
    return find_takes(root)


def _info(folder: Path) -> tuple[str, int, str]:
    """The type, the number of time stamps per line and the port name of ``info.log``."""
    path = folder / "info.log"
    kind, stamps, port = "Bottle", 1, ""
    if not path.is_file():
        return kind, stamps, port
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise ValueError(f"{path}: cannot be read ({exc})") from None
    for line in text.splitlines():
        if line.startswith("Type:"):
            kind = line.partition(":")[2].strip().rstrip(";").split(";")[0].strip()
        elif line.startswith("Stamp:"):
            stamps = 2 if "+" in line else 1
        elif (match := CONNECTED.match(line)) and not port:
            port = match.group(1)
    return kind, stamps, port


def _parse_lines(text: str, stamps: int, label: str) -> tuple[np.ndarray, list[list[str]]]:
    """The time stamps and value tokens of ``data.log``'s lines."""
    times, rows = [], []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        tokens = [t for t in TOKEN.findall(line) if t not in "()"]
        if len(tokens) < 1 + stamps:
            raise ValueError(f"{label} line {number}: no time stamp ({line[:60]!r})")
        try:
            times.append(float(tokens[1]))  # the first stamp: the sender's when there are two
        except ValueError:
            raise ValueError(
                f"{label} line {number}: the time stamp {tokens[1]!r} is not a number"
            ) from None
        rows.append(tokens[1 + stamps :])
    return np.array(times, dtype=float), rows


def _numeric(rows: list[list[str]], label: str) -> np.ndarray:
    width = len(rows[0])
    for number, row in enumerate(rows, start=1):
        if len(row) != width:
            raise ValueError(
                f"{label} line {number}: {len(row)} values where the first line has {width} "
                "(a truncated or ragged file)"
            )
    try:
        return np.array(rows, dtype=float).reshape(len(rows), width)
    except ValueError as exc:
        raise ValueError(f"{label}: a value is not a number ({exc})") from None


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _ports(take: Path | NumberedTake, label: str) -> list[tuple[str, Path, str]]:
    """(stream name, folder holding data.log, the folder as messages name it) of each port."""
    if isinstance(take, NumberedTake):
        return list(take.ports)
    path = Path(take)
    if (path / "data.log").is_file():
        return [(path.name, path, label)]
    return [(p.name, p, f"{label}/{p.name}") for p in natural_sorted(
        (p for p in path.iterdir() if p.is_dir() and (p / "data.log").is_file()),
        key=lambda p: p.name)]  # fmt: skip


def open_recording(take: Path | NumberedTake, label: str) -> Recording:
    """The ports of the take ``take`` (a take folder, or a numbered take; see the module
    docstring).

    Raises
    ------
    ValueError
        Naming the file and the line, as the module docstring says.
    """
    ports = _ports(take, label)
    recording = Recording(label, {}, {})
    layout = "numbered port folders" if isinstance(take, NumberedTake) else "a take folder"
    recording.hint = (f"{label} was read as {layout}, its ports "
                      f"{', '.join(name for name, _, _ in ports)}; {LAYOUTS}")  # fmt: skip
    if isinstance(take, NumberedTake):
        recording.aliases.update(take.aliases)
    left_out, markers = [], []
    for name, folder, shown in ports:
        where = f"{shown}/data.log"
        kind, stamps, port = _info(folder)
        if port:
            recording.aliases[port] = name
        if not kind.lower().startswith("bottle"):
            left_out.append(f"{name} ({kind})")
            continue
        try:
            text = (folder / "data.log").read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ValueError(f"{where}: cannot be read as text ({exc})") from None
        times, rows = _parse_lines(text, stamps, where)
        if not rows:
            left_out.append(f"{name} (no samples)")
            continue
        if all(_is_number(t) for t in rows[0]):
            values = _numeric(rows, where)
            recording.catalogue[name] = tuple(str(i) for i in range(values.shape[1]))
            recording.units[name] = ("",) * values.shape[1]
            recording.tables[name] = (times, values)
        else:
            texts = [" ".join(t.strip('"') for t in row) for row in rows]
            recording.events[name] = list(zip(times.tolist(), texts, strict=True))
            markers.append(name)
    recording.marker_streams = tuple(markers)
    recording.left_out = tuple(left_out)
    recording.start_at_zero()
    return recording
