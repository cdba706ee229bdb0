"""Demonstrations from a session: the spans a recording is cut into.

* **Markers**: a marker stream (an XDF string stream, a ROS ``std_msgs/String`` topic, a YARP
  port of text, a C3D's events) holds ``start CLASS`` and ``end CLASS`` (``begin``/``stop`` too;
  the keyword and the class separated by a space, ``:``, ``/`` or ``_``). Each pair is one
  demonstration of CLASS from the start's time to the end's. In a recording inside a class
  folder the class may be left out (``start`` ... ``end``: the folder's class). Any other
  label, an end without a start, a start inside another demonstration, an end of another
  class or a start never ended is an error naming the file, the time and the label.
* **Stillness**: the movements of the recording (:func:`promp.stillness.moving_spans`), each a
  demonstration of the recording's class folder.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from promp.stillness import moving_spans

__all__ = ["MARKER", "marker_spans", "parse_marker", "still_spans"]

START, END = ("start", "begin"), ("end", "stop")
MARKER = re.compile(r"^\s*([A-Za-z]+)(?:[\s:/_]+(.*?))?\s*$")


def parse_marker(label: str) -> tuple[str, str] | None:
    """``("start" | "end", class)`` of a marker label (class '' when not given); None when the
    label is neither."""
    match = MARKER.match(str(label))
    if not match:
        return None
    keyword = match.group(1).lower()
    kind = "start" if keyword in START else "end" if keyword in END else None
    return None if kind is None else (kind, (match.group(2) or "").strip())


def marker_spans(
    markers: Sequence[tuple[float, str]], default_class: str | None, where: str
) -> list[tuple[str, float, float]]:
    """The demonstrations ``(class, start, end)`` that ``markers`` (time, label) delimit.

    Raises
    ------
    ValueError
        Naming ``where`` (the file and the marker stream), the time and the label: see the
        module docstring.
    """
    spans: list[tuple[str, float, float]] = []
    open_: tuple[str, float, str] | None = None
    for time, label in sorted(markers, key=lambda m: m[0]):
        parsed = parse_marker(label)
        if parsed is None:
            raise ValueError(
                f"{where}: unknown marker {label!r} at {time:.3f} s; markers are 'start CLASS' "
                "and 'end CLASS'"
            )
        kind, name = parsed
        name = name or default_class or ""
        if not name:
            raise ValueError(
                f"{where}: the marker {label!r} at {time:.3f} s names no class, and the "
                "recording is not in a class folder: write 'start CLASS' / 'end CLASS'"
            )
        if kind == "start":
            if open_ is not None:
                raise ValueError(
                    f"{where}: {label!r} at {time:.3f} s starts a demonstration inside the one "
                    f"started by {open_[2]!r} at {open_[1]:.3f} s"
                )
            open_ = (name, time, label)
            continue
        if open_ is None:
            raise ValueError(f"{where}: {label!r} at {time:.3f} s ends no demonstration")
        if open_[0] != name:
            raise ValueError(
                f"{where}: {label!r} at {time:.3f} s ends the demonstration of {open_[0]!r} "
                f"started by {open_[2]!r} at {open_[1]:.3f} s"
            )
        spans.append((name, open_[1], time))
        open_ = None
    if open_ is not None:
        raise ValueError(f"{where}: {open_[2]!r} at {open_[1]:.3f} s is never ended")
    if not spans:
        raise ValueError(f"{where}: no 'start CLASS' ... 'end CLASS' markers")
    return spans


def still_spans(
    times: np.ndarray, blocks: Sequence[tuple[np.ndarray, str]], where: str
) -> list[tuple[float, float]]:
    """The movements of a recording on one clock, ``(start, end)`` in its seconds.

    Raises
    ------
    ValueError
        Nothing moves in ``where``.
    """
    spans = moving_spans(times, blocks)
    if not spans:
        raise ValueError(f"{where}: nothing moves; no demonstration to cut at its still periods")
    return [(float(times[a]), float(times[b - 1])) for a, b in spans]
