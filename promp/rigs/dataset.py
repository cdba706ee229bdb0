"""A dataset of rig recordings: the recordings found, their demonstrations, their modalities.

Where the demonstrations come from:

* ``DATASET/<class>/<recording>`` (any depth below the class folder): one demonstration per
  recording (``cut="files"``), or several cut at its still periods (``cut="still"``) or by its
  markers (``cut="markers"``; the class folder is the class of markers that name none);
* ``DATASET/<session>``, or the session file itself: a session, cut by its markers
  (``start CLASS`` ... ``end CLASS``, :mod:`promp.rigs.cutting`), whose labels give the classes.

``cut="auto"`` (the default) cuts a recording by its markers when it has a marker stream, and
takes it whole otherwise. A demonstration cut from a recording is named ``<recording>-<k>``
(its rank in the recording) and its file is given with its time span
(``session.xdf [12.350-15.800 s]``, seconds from the recording's start).

Without a mapping, one is guessed from the first recording (:func:`guess`): each numeric stream
(each field group of a ROS message) a modality named after it, at most :data:`MAX_GUESSED`;
the preview says what it left out (:func:`guessed_rig_mapping`: the guess alone).

Each demonstration is put on one clock over the span its streams all cover
(:func:`promp.rigs.streams.common_span`, up to :data:`promp.rigs.streams.CUT_SHARE` of it
cut): the span between its markers, or the whole recording when it is taken whole or cut at
its still periods (cut before the still periods are found). Each cut is said in the notes,
at most :data:`MAX_CUTS_SAID` of them one by one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import numpy as np

from promp.data import Demonstration, Modality
from promp.names import natural_sorted
from promp.rigs import c3d, rosbag, xdf, yarp
from promp.rigs.cutting import marker_spans, still_spans
from promp.rigs.mapping import (
    SourcedModality,
    column_names,
    mapping_text,
    modality_name,
    sourced,
)
from promp.rigs.streams import (
    CUT_SHARE,
    Recording,
    Stream,
    common_span,
    on_one_clock,
    read_stream,
)
from promp.rigs.yarp_layout import NumberedTake, layout_notes

__all__ = [
    "CUTS",
    "find_recordings",
    "guess",
    "guessed_rig_mapping",
    "MAX_CUTS_SAID",
    "MAX_GUESSED",
    "read_rig_dataset",
    "READERS",
    "RIG_FORMATS",
    "RigOptions",
    "RigRead",
    "WHAT",
]

READERS = {"yarp": yarp, "rosbag": rosbag, "xdf": xdf, "c3d": c3d}
RIG_FORMATS = tuple(READERS)
CUTS = ("auto", "markers", "still", "files")
MAX_GUESSED = 8
MAX_CUTS_SAID = 12
WHAT = {
    "yarp": "YARP dumps (<class>/<take>/<port>/data.log or <class>/<port>/<port>_NNNNN/"
            "data.log)",
    "rosbag": "ROS bags (.bag, .mcap, .db3 or a ROS 2 bag folder)",
    "xdf": "XDF files (.xdf, .xdfz)",
    "c3d": "C3D files (.c3d)",
}


@dataclass(frozen=True)
class RigOptions:
    """How a session becomes demonstrations, and on which clock.

    Attributes
    ----------
    cut : {"auto", "markers", "still", "files"}
        See the module docstring.
    rate : float or None
        The time base's rate in Hz; None: the slowest stream's own times.
    markers : str
        The marker stream to cut by ('' : the recording's only one).
    """

    cut: str = "auto"
    rate: float | None = None
    markers: str = ""

    def __post_init__(self) -> None:
        if self.cut not in CUTS:
            raise ValueError(f"unknown cut {self.cut!r}; expected one of {CUTS}")
        if self.rate is not None and not (math.isfinite(self.rate) and self.rate > 0):
            raise ValueError(f"the rate must be a positive number of Hz, got {self.rate}")


@dataclass(frozen=True, eq=False)
class RigRead:
    """What :func:`read_rig_dataset` read: the demonstrations by class, their modalities (the
    columns, units and kinds), the source of each demonstration, the mapping used (in the
    mapping syntax) and notes for the preview (streams, what was left out, the cut, the clock)."""

    dataset: dict[str, list[Demonstration]]
    modalities: tuple[Modality, ...]
    files: dict[tuple[str, str], str]
    mapping: str
    notes: tuple[str, ...]


def find_recordings(root: Path, format: str) -> list[Path | NumberedTake]:
    """The recordings of ``format`` under ``root`` (or ``root`` itself), in natural order."""
    reader = READERS[format]
    root = Path(root)
    if hasattr(reader, "find_recordings"):
        return reader.find_recordings(root)
    if root.is_file():
        return [root] if root.suffix.lower() in reader.SUFFIXES else []
    return natural_sorted(
        (p for p in root.rglob("*")
         if p.is_file() and p.suffix.lower() in reader.SUFFIXES
         and not any(part.startswith(".") for part in p.relative_to(root).parts)),
        key=lambda p: p.relative_to(root),
    )  # fmt: skip


def _place(root: Path, unit: Path | NumberedTake) -> tuple[str, str | None, str]:
    """The label, the class (None for a session) and the name of a recording (a numbered
    YARP take is named as its take folder would be, ``<class>/<number>``)."""
    if isinstance(unit, NumberedTake):
        unit = unit.where
    parts = () if unit == root else unit.relative_to(root).parts
    label = PurePosixPath(*parts).as_posix() if parts else root.name
    below = parts[1:] if len(parts) >= 2 else (parts or (root.name,))
    name = PurePosixPath(*below)
    if unit.is_file():
        name = name.with_suffix("")
    return label, (parts[0] if len(parts) >= 2 else None), name.as_posix()


def guess(recording: Recording) -> tuple[list[SourcedModality], list[str]]:
    """A mapping from ``recording``'s streams, and the streams it leaves out."""
    groups = recording.suggestions()
    if not groups:
        raise ValueError(
            f"{recording.label}: no numeric stream to guess a mapping from"
            + (f" (left out: {', '.join(recording.left_out)})" if recording.left_out else "")
        )
    taken: set[str] = set()
    chosen = [
        SourcedModality(modality_name(name, taken), tuple(fields), unit="", stream=stream)
        for stream, fields, name in groups[:MAX_GUESSED]
    ]
    left = [f"{stream}:{','.join(fields)}" for stream, fields, _ in groups[MAX_GUESSED:]]
    return chosen, left


def guessed_rig_mapping(root: Path, format: str) -> str:
    """The mapping :func:`read_rig_dataset` guesses for ``root`` (:func:`guess`, from its
    first recording), in the mapping syntax.

    Raises
    ------
    ValueError
        No recording, or the first one unreadable or without a numeric stream.
    """
    root = Path(root)
    if format not in READERS:
        raise ValueError(f"unknown recording format {format!r}; expected one of {RIG_FORMATS}")
    units = find_recordings(root, format) if root.exists() else []
    if not units:
        raise ValueError(f"{root}: no {WHAT[format]} found")
    label = _place(root, units[0])[0]
    return mapping_text(guess(READERS[format].open_recording(units[0], label))[0])


def _marker_stream(recording: Recording, wanted: str) -> str:
    streams = recording.marker_streams
    if wanted:
        if wanted not in streams:
            raise ValueError(
                f"{recording.label}: no marker stream {wanted!r}; its marker streams: "
                f"{list(streams) or 'none'}"
            )
        return wanted
    if len(streams) != 1:
        raise ValueError(
            f"{recording.label}: "
            + ("no marker stream to cut it by" if not streams else
               f"several marker streams {list(streams)}: choose one (--markers STREAM)")
        )  # fmt: skip
    return streams[0]


def _whole(streams: Sequence[Stream]) -> tuple[float, float]:
    return min(s.times[0] for s in streams), max(s.times[-1] for s in streams)


def _modality(m: SourcedModality, columns: tuple[str, ...], units: Sequence[str]) -> Modality:
    distinct = list(dict.fromkeys(units))
    unit = "|".join(u for u in distinct if u) if any(distinct) else ""
    kind = "angle" if distinct == ["rad"] else "linear"
    return Modality(m.name, columns, unit=unit, kind=kind)


def read_rig_dataset(
    root: Path,
    format: str,
    modalities: Sequence[Modality] | None = None,
    options: RigOptions | None = None,
) -> RigRead:
    """Read the recordings of ``format`` under ``root`` into demonstrations (see the module
    docstring and :mod:`promp.rigs`).

    Raises
    ------
    ValueError
        Naming the file and the reason: no recording, an unreadable or truncated file, a
        stream or field the mapping names that a recording lacks, a clock that goes back, a
        stream that starts or stops more than ``CUT_SHARE`` of the demonstration away from the
        others or pauses inside it, a bad or unknown marker, or a recording without a class
        (neither in a class folder nor cut by markers naming classes).
    """
    if format not in READERS:
        raise ValueError(f"unknown recording format {format!r}; expected one of {RIG_FORMATS}")
    options = options or RigOptions()
    root = Path(root)
    if not root.exists():
        raise ValueError(f"{root} does not exist")
    units = find_recordings(root, format)
    if not units:
        raise ValueError(f"{root}: no {WHAT[format]} found")
    mapping = [sourced(m) for m in modalities] if modalities else None
    notes: list[str] = layout_notes(units, root) if format == "yarp" else []
    dataset: dict[str, list[Demonstration]] = {}
    files: dict[tuple[str, str], str] = {}
    units_seen: list[tuple[str, ...]] = []
    cuts: list[str] = []  # the spans cut to what every stream covers, said
    for unit in units:
        label, klass, name = _place(root, unit)
        recording = READERS[format].open_recording(unit, label)
        if mapping is None:
            mapping, left = guess(recording)
            notes.append(f"Streams of {label}: {recording.describe_streams()}")
            if left:
                notes.append(f"Left out of the guessed mapping: {'; '.join(left)}")
        if recording.left_out and len(notes) < 40:
            notes.append(f"{label}: left out {', '.join(recording.left_out)}")
        set_aside: list = []
        streams = [read_stream(recording, m, set_aside, ("", name)) for m in mapping]
        for finding in set_aside:
            notes.append(f"{label}: {finding.message}")
        units_here = [s.units for s in streams]
        if not units_seen:
            units_seen = units_here
        elif units_here != units_seen:
            raise ValueError(
                f"{label}: the mapping's units here ({units_here}) are not those of the first "
                f"recording ({units_seen})"
            )
        cut = options.cut
        if cut == "auto":
            cut = "markers" if recording.marker_streams else "files"
        for klass_, demo_name, times, values, source in _demonstrations(
            recording, streams, cut, options, klass, name, label, cuts
        ):
            demo = Demonstration(times, np.hstack(values), _flat_columns(mapping), demo_name)
            dataset.setdefault(klass_, []).append(demo)
            files[(klass_, demo_name)] = source
    columns = column_names(mapping)
    found = (
        f"{len(units)} recording(s), {sum(len(d) for d in dataset.values())} demonstration(s); "
        + ("time base: the slowest stream's samples" if options.rate is None
           else f"time base: {options.rate:g} Hz")
    )  # fmt: skip
    return RigRead(
        dataset,
        tuple(_modality(m, c, u) for m, c, u in zip(mapping, columns, units_seen, strict=True)),
        files,
        mapping_text(mapping),
        (found, *notes, *_cut_notes(cuts)),
    )


def _cut_notes(cuts: Sequence[str], limit: int = MAX_CUTS_SAID) -> list[str]:
    """The notes of the spans cut to what every stream covers: a headline, then each (at
    most ``limit``, then how many more)."""
    if not cuts:
        return []
    return [
        f"One clock: {len(cuts)} span(s) cut to what every stream covers (a stream started "
        f"or stopped later than the others; up to {100 * CUT_SHARE:.0f} % of a demonstration "
        "is cut, more is refused); the demonstrations are learned from as cut:",
        *cuts[:limit],
        *([f"... and {len(cuts) - limit} more"] if len(cuts) > limit else []),
    ]


def _on_one_clock(
    streams: Sequence[Stream],
    start: float,
    end: float,
    rate: float | None,
    label: str,
    cuts: list[str],
    what: str = "demonstration",
) -> tuple[np.ndarray, list[np.ndarray]]:
    """The streams on one clock over the part of ``[start, end]`` they all cover
    (:func:`promp.rigs.streams.common_span`: refused beyond :data:`CUT_SHARE`), the cut said
    in ``cuts``."""
    span = common_span(streams, start, end, label, rate, CUT_SHARE, what)
    if span.cut:
        cuts.append(f"{label}: {span.describe()}")
    return on_one_clock(streams, span.lo, span.hi, rate, label)


def _flat_columns(mapping: Sequence[SourcedModality]) -> tuple[str, ...]:
    return tuple(c for columns in column_names(mapping) for c in columns)


def _demonstrations(
    recording: Recording,
    streams: Sequence[Stream],
    cut: str,
    options: RigOptions,
    klass: str | None,
    name: str,
    label: str,
    cuts: list[str],
):
    """``(class, name, times, values per stream, source)`` of each demonstration of a
    recording; a span cut to what every stream covers is said in ``cuts``."""
    if cut == "markers":
        stream = _marker_stream(recording, options.markers)
        spans = marker_spans(recording.markers(stream), klass, f"{label}: marker stream {stream!r}")
        for k, (class_, start, end) in enumerate(spans, start=1):
            source = f"{label} [{start:.3f}-{end:.3f} s]"
            times, values = _on_one_clock(streams, start, end, options.rate, source, cuts)
            yield class_, f"{name}-{k}", times, values, source
        return
    if klass is None:
        raise ValueError(
            f"{label}: a recording directly in the dataset folder is a session, cut into "
            "demonstrations by its markers ('start CLASS' ... 'end CLASS'), "
            + ("and it has none" if not recording.marker_streams else f"not by {cut!r}")
            + "; or put one recording per demonstration in <class>/ folders"
        )
    start, end = _whole(streams)
    times, values = _on_one_clock(streams, start, end, options.rate, label, cuts, "recording")
    if cut == "files":
        yield klass, name, times, values, label
        return
    # Each stream moves on its own (a position in m, angles in rad, a signal of its own scale).
    blocks = [(v, s.units[0] if len(set(s.units)) == 1 else "")
              for v, s in zip(values, streams, strict=True)]  # fmt: skip
    for k, (a, b) in enumerate(still_spans(times, blocks, label), start=1):
        inside = (times >= a) & (times <= b)
        source = f"{label} [{a:.3f}-{b:.3f} s]"
        yield klass, f"{name}-{k}", times[inside], [v[inside] for v in values], source
