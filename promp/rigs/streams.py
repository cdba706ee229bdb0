"""Several streams, one clock: a recording's streams as its reader opened them, and the
demonstration they make once put on one time base by their timestamps (never by sample index).

A :class:`Recording` is one file (or one YARP dump folder) as a reader of :mod:`promp.rigs`
opened it: its numeric streams and their fields, its marker streams, and the samples of any of
them, timed in seconds from the recording's start on the recording's own clock.
:func:`read_stream` takes the fields of one modality from it (units converted,
:mod:`promp.rigs.mapping`), and :func:`on_one_clock` puts several such streams on one time base:
by default the times of the slowest stream (the others interpolated linearly at them; angles
across +-pi unwrapped first), or a regular grid at a chosen rate.

The streams of a recording start and stop one after the other, so a demonstration is put on
one clock over the span every stream covers (:func:`common_span`): a stream that starts after
the demonstration's start or stops before its end by a few steps (:data:`STOP_STEPS`) is cut
unsaid; further, the cut is said (:meth:`Span.describe`) while it leaves out at most
:data:`CUT_SHARE` of the demonstration, and beyond that the demonstration is refused naming
the stream. "The demonstration" is the span the reader asks for: the span between a start
and an end marker, or, for a recording taken whole or cut at its still periods, the whole
recording (from its mapped streams' first sample to their last). A stream that pauses
(:data:`promp.gaps.GAP_FACTOR` times its own step, and over the tolerance) inside a
demonstration cannot be interpolated there: that is an error naming it.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from promp.data import check_values
from promp.gaps import GAP_FACTOR
from promp.quality import Finding, increasing_samples, timestamp_finding
from promp.rigs.mapping import SourcedModality, si_unit

__all__ = ["common_span", "CUT_SHARE", "on_one_clock", "read_stream", "Recording", "Span",
           "STOP_STEPS", "Stream", "unreadable"]  # fmt: skip

# A stream may begin or end this many steps of the slowest stream away from the others (the
# streams of a recording are started and stopped one after the other, not at one instant).
STOP_STEPS = 3.0
# Further away, the demonstration is cut to the span every stream covers when that leaves out
# at most this share of it (a dumper's second port connected 37 ms after the first); beyond,
# the stream is taken to stop mid-demonstration and the demonstration is refused.
CUT_SHARE = 0.1


@dataclass(frozen=True, eq=False)
class Stream:
    """Some fields of one stream, at their own times.

    Attributes
    ----------
    name : str
        The stream as the mapping names it.
    times : array, shape (n_samples,)
        Seconds from the recording's start, strictly increasing.
    values : array, shape (n_samples, n_fields)
        In ``units`` (converted: metres, radians).
    units : tuple of str, length n_fields
    """

    name: str
    times: np.ndarray
    values: np.ndarray
    units: tuple[str, ...]

    @functools.cached_property
    def step(self) -> float:
        """Median time between samples, in seconds (computed once: a reader and the live time
        base ask it several times of each stream)."""
        return float(np.median(np.diff(self.times)))


@dataclass(eq=False)
class Recording:
    """One recording as its reader opened it (see the module docstring).

    Attributes
    ----------
    label : str
        The file as messages name it (relative to the dataset).
    catalogue : dict of str to tuple of str
        Every numeric stream and its fields.
    units : dict of str to tuple of str
        The unit of each field as recorded ('' when the file does not say).
    marker_streams : tuple of str
        The streams of text events (``start CLASS`` / ``end CLASS``).
    aliases : dict of str to str
        Other names of streams (a YARP dump folder's port name).
    left_out : tuple of str
        Streams that are neither numeric nor markers, with why (images, empty...).
    tables : dict of str to (times, values)
        The samples of in-memory readers; a reader that reads on demand overrides
        :meth:`samples` instead.
    events : dict of str to list of (time, label)
    hint : str
        How the reader found the recording's streams, said when a stream the mapping names
        is missing (a YARP dump's layout).
    """

    label: str
    catalogue: dict[str, tuple[str, ...]]
    units: dict[str, tuple[str, ...]]
    marker_streams: tuple[str, ...] = ()
    aliases: dict[str, str] = field(default_factory=dict)
    left_out: tuple[str, ...] = ()
    tables: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    events: dict[str, list[tuple[float, str]]] = field(default_factory=dict)
    hint: str = ""

    def describe_streams(self) -> str:
        listed = [f"{name} ({', '.join(fields[:6])}{', ...' if len(fields) > 6 else ''})"
                  for name, fields in self.catalogue.items()]  # fmt: skip
        return "; ".join(listed) or "none"

    def stream_of(self, modality: SourcedModality) -> str:
        """The stream ``modality`` takes its fields from: the one it names (or an alias of
        it), else the one stream that has all its fields.

        Raises
        ------
        ValueError
            No such stream, or (without a stream) none or several that have the fields.
        """
        stream = self.aliases.get(modality.stream, modality.stream)
        if stream:
            if stream not in self.catalogue:
                markers = " (a marker stream)" if stream in self.marker_streams else ""
                raise ValueError(
                    f"{self.label}: no numeric stream {modality.stream!r}{markers} for "
                    f"modality {modality.name!r}; its streams: {self.describe_streams()}"
                    + (f" ({self.hint})" if self.hint else "")
                )
            return stream
        having = [s for s in self.catalogue if self.has_fields(s, modality.fields)]
        if len(having) != 1:
            which = "no stream has" if not having else f"streams {having} all have"
            raise ValueError(
                f"{self.label}: {which} the fields {list(modality.fields)} of modality "
                f"{modality.name!r}; name the stream: {modality.name}=STREAM:"
                f"{','.join(modality.fields)} (its streams: {self.describe_streams()})"
            )
        return having[0]

    def suggestions(self) -> list[tuple[str, tuple[str, ...], str]]:
        """``(stream, fields, name)`` of each modality a guess may propose: every numeric
        stream whole, named after it."""
        return [(stream, fields, stream) for stream, fields in self.catalogue.items()]

    def start_at_zero(self) -> None:
        """Count every time from the recording's first sample or event."""
        starts = [t[0].min() for t in self.tables.values() if t[0].size]
        starts += [min(t for t, _ in e) for e in self.events.values() if e]
        start = float(min(starts, default=0.0))
        self.tables = {k: (t - start, v) for k, (t, v) in self.tables.items()}
        self.events = {k: [(t - start, s) for t, s in e] for k, e in self.events.items()}

    def field_index(self, stream: str, name: str) -> int | None:
        """The column of field ``name`` in an in-memory stream (a label, or an index)."""
        fields = self.catalogue[stream]
        if name in fields:
            return fields.index(name)
        if name.isdigit() and int(name) < len(fields):
            return int(name)
        return None

    def has_fields(self, stream: str, fields: Sequence[str]) -> bool:
        return all(self.field_index(stream, f) is not None for f in fields)

    def field_units(self, stream: str, fields: Sequence[str]) -> tuple[str, ...]:
        units = self.units.get(stream, ())
        out = []
        for name in fields:
            index = self.field_index(stream, name)
            out.append(units[index] if index is not None and index < len(units) else "")
        return tuple(out)

    def stream_title(self, stream: str) -> str:
        """The stream as messages name it."""
        return f"stream {stream!r}"

    def require_fields(self, stream: str, fields: Sequence[str]) -> None:
        """ValueError naming the fields of ``fields`` that ``stream`` lacks, if any."""
        missing = [f for f in fields if self.field_index(stream, f) is None]
        if missing:
            listed = list(self.catalogue[stream][:12])
            raise ValueError(
                f"{self.label}: {self.stream_title(stream)} has no field(s) {missing}; its "
                f"fields are {listed}{' and more' if len(self.catalogue[stream]) > 12 else ''}"
            )

    def samples(self, stream: str, fields: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """The times (n,) and values (n, k) of ``fields`` of ``stream``, as recorded."""
        self.require_fields(stream, fields)
        times, values = self.tables[stream]
        return times, values[:, [self.field_index(stream, f) for f in fields]]

    def markers(self, stream: str) -> list[tuple[float, str]]:
        """The events (time in seconds from the start, label) of a marker stream."""
        return list(self.events.get(stream, []))


def unreadable(label: str, what: str, exc: BaseException) -> ValueError:
    """The error to raise when reading ``label`` as ``what`` failed with ``exc``: ``exc``
    itself when it is already ours (a ValueError naming ``label``), else one that names the
    file and says what the reader library said (it may raise anything, a UnicodeDecodeError
    on random bytes too)."""
    if isinstance(exc, ValueError) and str(exc).startswith(label):
        return exc
    return ValueError(f"{label}: not a readable {what} ({type(exc).__name__}: {exc})")


def read_stream(
    recording: Recording, modality: SourcedModality, findings: list[Finding], key: tuple[str, str]
) -> Stream:
    """The fields of ``modality`` from ``recording``, in metres and radians where the file or
    the mapping says the unit. Samples that repeat an earlier time stamp are set aside with a
    ``timestamps`` finding (for the demonstration ``key``) in ``findings``.

    Raises
    ------
    ValueError
        Naming the file and the stream: no such stream or field, fewer than two samples,
        NaN or infinite values, or times that go back (a non-monotonic clock).
    """
    stream = recording.stream_of(modality)
    times, values = recording.samples(stream, modality.fields)
    label = f"{recording.label}: stream {stream!r}"
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float).reshape(times.shape[0], -1)
    if times.shape[0] < 2:
        raise ValueError(f"{label} has {times.shape[0]} sample(s); at least 2 are needed")
    check_values(times, values, label)
    back = np.flatnonzero(np.diff(times) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise ValueError(
            f"{label}: time stamps not monotonic: sample {i} at {times[i]:.6f} s goes back "
            f"from {times[i - 1]:.6f} s ({back.size} time(s) in all); the recording's clock "
            "cannot place it"
        )
    keep = increasing_samples(times)
    finding = timestamp_finding(times, keep, *key, recording.label)
    if finding is not None:
        findings.append(finding)
        times, values = times[keep], values[keep]
    recorded = modality.stated_unit and (modality.stated_unit,) * len(modality.fields)
    units, scales = zip(
        *(si_unit(u) for u in (recorded or recording.field_units(stream, modality.fields))),
        strict=True,
    )
    return Stream(stream, times, values * np.array(scales), tuple(units))


def _interpolate(stream: Stream, times: np.ndarray) -> np.ndarray:
    """``stream``'s values at ``times`` (linear; angles through their unwrapped path)."""
    out = np.empty((times.shape[0], stream.values.shape[1]))
    for j, unit in enumerate(stream.units):
        column = stream.values[:, j]
        if unit == "rad":
            path = np.interp(times, stream.times, np.unwrap(column))
            out[:, j] = np.angle(np.exp(1j * path))
        else:
            out[:, j] = np.interp(times, stream.times, column)
    return out


@dataclass(frozen=True)
class Span:
    """The part of a demonstration that every stream covers (:func:`common_span`).

    Attributes
    ----------
    start, end : float
        The demonstration asked for, in seconds from the recording's start.
    lo, hi : float
        The span every stream covers inside it.
    late : tuple of (str, float)
        The stream that starts last and its first time, when it starts more than the
        tolerance after ``start`` (empty otherwise).
    early : tuple of (str, float)
        The stream that stops first and its last time, when it stops more than the
        tolerance before ``end`` (empty otherwise).
    what : str
        What ``[start, end]`` is, in messages: ``"demonstration"`` (a marker span) or
        ``"recording"`` (a recording taken whole).
    """

    start: float
    end: float
    lo: float
    hi: float
    late: tuple = ()
    early: tuple = ()
    what: str = "demonstration"

    @property
    def cut(self) -> bool:
        """Whether a stream starts or stops beyond the tolerance (the cut is said)."""
        return bool(self.late or self.early)

    @property
    def share(self) -> float:
        """The part of ``[start, end]`` left out, a fraction of ``end - start``."""
        length = self.end - self.start
        return ((self.lo - self.start) + (self.end - self.hi)) / length if length > 0 else 0.0

    def streams_said(self) -> str:
        """Which stream starts late and which stops early, with the span asked for."""
        said = []
        if self.late:
            said.append(f"stream {self.late[0]!r} starts at {self.late[1]:.3f} s, "
                        f"{self.late[1] - self.start:.3f} s into the {self.what}")  # fmt: skip
        if self.early:
            said.append(f"stream {self.early[0]!r} stops at {self.early[1]:.3f} s, "
                        f"mid-{self.what}, {self.end - self.early[1]:.3f} s before its "
                        "end")  # fmt: skip
        return f"{' and '.join(said)} ({self.start:.3f}-{self.end:.3f} s)"

    def describe(self) -> str:
        """The cut in words: which stream, the span kept and the share left out."""
        return (
            f"{self.streams_said()}: cut to the span every stream covers, "
            f"{self.lo:.3f}-{self.hi:.3f} s ({100 * self.share:.1f} % of the {self.what} left "
            "out)"
        )


def _tolerance(streams: Sequence[Stream], rate: float | None) -> float:
    """How far a stream may start or stop from the others unsaid, in seconds:
    :data:`STOP_STEPS` steps of the slowest stream (or of the time base's grid)."""
    return STOP_STEPS * max(max(s.step for s in streams), 1.0 / rate if rate else 0.0)


def common_span(
    streams: Sequence[Stream],
    start: float,
    end: float,
    label: str,
    rate: float | None = None,
    share: float = CUT_SHARE,
    what: str = "demonstration",
) -> Span:
    """The part of ``[start, end]`` (seconds from the recording's start) that every stream
    covers.

    The streams of one recording start and stop one after the other (a YARP dumper connects
    its ports in turn). Within :data:`STOP_STEPS` steps of the slowest stream that is
    ordinary, and the span is cut unsaid; beyond, it is cut when that leaves out at most
    ``share`` of ``[start, end]``, and the :class:`Span` says it (:attr:`Span.cut`,
    :meth:`Span.describe`).

    Parameters
    ----------
    streams : sequence of Stream
    start, end : float
        The demonstration: a span between markers, or a whole recording (from its streams'
        first sample to their last).
    label : str
        The demonstration as messages name it.
    rate : float, optional
        The time base's rate in Hz (its step widens the tolerance).
    share : float
        The largest part of ``[start, end]`` that may be left out (0: nothing beyond the
        tolerance, as :func:`on_one_clock` and the live time base ask).
    what : str
        What ``[start, end]`` is, in messages (:attr:`Span.what`).

    Raises
    ------
    ValueError
        Naming ``label`` and the stream: one that starts after ``start`` or stops before
        ``end`` by more than the tolerance, when the span every stream covers leaves out more
        than ``share`` of ``[start, end]``.
    """
    tolerance = _tolerance(streams, rate)
    lo = max(start, *(s.times[0] for s in streams))
    hi = min(end, *(s.times[-1] for s in streams))
    first = max(streams, key=lambda s: s.times[0])
    last = min(streams, key=lambda s: s.times[-1])
    span = Span(
        start, end, lo, hi,
        (first.name, float(first.times[0])) if first.times[0] > start + tolerance else (),
        (last.name, float(last.times[-1])) if last.times[-1] < end - tolerance else (),
        what,
    )  # fmt: skip
    if span.cut and (hi <= lo or span.share > share):
        if share <= 0:
            raise ValueError(f"{label}: {span.streams_said()}")
        raise ValueError(
            f"{label}: {span.streams_said()}: the span every stream covers would leave out "
            f"{100 * min(span.share, 1.0):.1f} % of the {what}, over the {100 * share:.0f} % "
            "that may be cut (map the streams recorded all along, or cut by markers)"
        )
    return span


def on_one_clock(
    streams: Sequence[Stream],
    start: float,
    end: float,
    rate: float | None,
    label: str,
    base: int | None = None,
    gaps: bool = True,
) -> tuple[np.ndarray, list[np.ndarray]]:
    """The streams' values on one time base over ``[start, end]`` (seconds from the
    recording's start): the slowest stream's own times there (``rate`` None), or a grid at
    ``rate`` Hz from the first time every stream has a sample. ``base``: the index of the
    stream whose times are the time base when ``rate`` is None (default: the slowest; a live
    time base fixes it once, :mod:`promp.live.timebase`, as a short slice of each stream may
    not tell which is the slowest). Every stream must cover ``[start, end]`` within the
    tolerance (:func:`common_span` with no share: a reader cuts the demonstration to its
    :func:`common_span` first). ``gaps`` False: the caller has judged the streams' pauses
    itself (the live time base, which knows a late sender's lateness): none is refused here.

    Returns
    -------
    times : array, shape (n,)
    values : list of arrays, shape (n, n_fields) each, one per stream

    Raises
    ------
    ValueError
        Naming ``label`` and the stream: one that starts after ``start`` or stops before
        ``end`` (by more than :data:`STOP_STEPS` steps of the slowest stream), one that pauses
        inside the span, or a span with fewer than two samples on the time base.
    """
    steps = [s.step for s in streams]
    slowest = int(np.argmax(steps)) if base is None else int(base)
    tolerance = _tolerance(streams, rate)
    span = common_span(streams, start, end, label, rate, share=0.0)
    lo, hi = span.lo, span.hi
    if rate is None:
        base = streams[slowest].times
        times = base[(base >= lo) & (base <= hi)]
    else:
        times = lo + np.arange(int(np.floor((hi - lo) * rate + 1e-9)) + 1) / rate
    if times.shape[0] < 2:
        raise ValueError(
            f"{label}: {times.shape[0]} sample(s) on the time base from {lo:.3f} to {hi:.3f} s; "
            "a demonstration needs at least 2"
        )
    values = []
    for k, s in enumerate(streams):
        if rate is None and k == slowest:
            inside = (s.times >= lo) & (s.times <= hi)
            values.append(s.values[inside])
            continue
        first = max(int(np.searchsorted(s.times, lo, side="right")) - 1, 0)
        last = int(np.searchsorted(s.times, hi, side="left"))
        spans = np.diff(s.times[first : last + 1])
        if gaps and spans.size and spans.max() > max(GAP_FACTOR * s.step, tolerance):
            i = first + int(np.argmax(spans))
            raise ValueError(
                f"{label}: stream {s.name!r} stops at {s.times[i]:.3f} s and resumes at "
                f"{s.times[i + 1]:.3f} s, mid-demonstration ({start:.3f}-{end:.3f} s)"
            )
        values.append(_interpolate(s, times))
    return times, values
