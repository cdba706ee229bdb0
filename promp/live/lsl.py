"""The live pipeline's transport over the Lab Streaming Layer: the only module that imports
``pylsl`` (:mod:`promp.live.transport` says what a transport does).

Importing it where ``pylsl`` or its liblsl cannot be loaded raises :class:`LSLUnavailable`
saying what to do. LSL reads its configuration from the file ``LSLAPICFG`` names when it is
loaded: the tests and benches set it to the repository's loopback-only
``tests/lsl_loopback.cfg`` first (``python -m promp.live --lsl-config FILE`` does the same).

Times: a sample's time is its sender's stamp plus the inlet's clock correction
(``time_correction``, LSL's estimate of the offset between the sender's clock and ours), so
every stream is on this machine's ``local_clock``. The correction applied is renewed when the
estimate moves by more than :data:`OFFSET_STEP_S`: a wobble of a few microseconds of the
estimate would otherwise shift the samples of one movement against each other.

Lifetimes: liblsl 1.16-1.18 (pylsl 1.18.6 ships 1.18.0) can crash the process (a segmentation
fault in ``lsl_destroy_outlet``) when an outlet of this process is destroyed while another
thread of this process opens an inlet, the race of sccn/liblsl#220 (fixed upstream by #289, in
no wheel yet). The studio is such a process: its scan opens an inlet on every new stream it
finds, its own outlets included, and a session's stop destroys them. So every inlet's opening
and destruction and every outlet's creation and destruction here hold one lock,
:data:`LIFECYCLE`, and each is destroyed when it is closed, by :func:`release`, never later by
the garbage collector at a moment nobody chose. Code beside the studio in its process (the
tests' senders and readers) makes and releases its own through :func:`new_outlet`,
:func:`open_inlet` and :func:`release`. ``bench/lsl_lifecycle.py`` reproduces the crash
without the lock.
"""

from __future__ import annotations

import ctypes
import threading
import time

import numpy as np

from promp.live.transport import (
    LSLUnavailable,
    OutletSpec,
    StreamDescription,
    StreamLost,
)

__all__ = [
    "CHANNEL_FORMATS",
    "describe",
    "FORGET_S",
    "FORMATS",
    "HOW_TO",
    "LIFECYCLE",
    "local_clock",
    "LslInlet",
    "LslOutlet",
    "LslTransport",
    "MAX_BUFFER_S",
    "new_outlet",
    "OFFSET_STEP_S",
    "open_inlet",
    "OPEN_TIMEOUT_S",
    "release",
]

HOW_TO = (
    "install the live extra (pip install 'icub-intention-studio[live]': pylsl, whose Linux "
    "x86-64 wheel ships liblsl and needs glibc >= 2.35), or install LSL's own liblsl and "
    "point the PYLSL_LIB environment variable at it"
)

try:
    import pylsl
    from pylsl.util import LostError
except ImportError as exc:
    raise LSLUnavailable(
        f"LSL is not available: pylsl is not installed ({exc}); {HOW_TO}"
    ) from None
except (OSError, RuntimeError) as exc:  # pylsl raises RuntimeError when liblsl cannot load
    raise LSLUnavailable(
        f"LSL is not available: pylsl cannot load liblsl ({str(exc).splitlines()[0]}); {HOW_TO}"
    ) from None

OFFSET_STEP_S = 1e-3
FORGET_S = 2.0
OPEN_TIMEOUT_S = 5.0
MAX_BUFFER_S = 360  # what an inlet keeps while the session is busy
FORMATS = {
    pylsl.cf_float32: "float32", pylsl.cf_double64: "double64", pylsl.cf_string: "string",
    pylsl.cf_int32: "int32", pylsl.cf_int16: "int16", pylsl.cf_int8: "int8",
    pylsl.cf_int64: "int64",
}  # fmt: skip
CHANNEL_FORMATS = {"double64": pylsl.cf_double64, "string": pylsl.cf_string}
LIFECYCLE = threading.RLock()  # see the module docstring
_DESTROY = {pylsl.StreamInlet: "lsl_destroy_inlet", pylsl.StreamOutlet: "lsl_destroy_outlet"}


def new_outlet(info: pylsl.StreamInfo, **options) -> pylsl.StreamOutlet:
    """A ``pylsl.StreamOutlet(info, **options)`` made under :data:`LIFECYCLE`; close it with
    :func:`release`."""
    with LIFECYCLE:
        return pylsl.StreamOutlet(info, **options)


def open_inlet(info: pylsl.StreamInfo, timeout: float, **options) -> pylsl.StreamInlet:
    """A ``pylsl.StreamInlet(info, **options)`` whose stream is opened (waiting up to
    ``timeout`` s), under :data:`LIFECYCLE`; close it with :func:`release`.

    Raises
    ------
    pylsl.util.LostError, pylsl.util.TimeoutError
        As ``open_stream`` does; the inlet is released first.
    """
    with LIFECYCLE:
        inlet = pylsl.StreamInlet(info, **options)
        try:
            inlet.open_stream(timeout)
        except BaseException:
            release(inlet)
            raise
        return inlet


def release(handle: pylsl.StreamInlet | pylsl.StreamOutlet) -> None:
    """Destroy ``handle`` (an inlet or an outlet) now, under :data:`LIFECYCLE`; its later
    ``__del__`` does nothing (liblsl deletes a null handle as nothing). An inlet is not closed
    first: closing breaks the connection before liblsl's destructor raises its shutdown flag
    (mne-tools/mne-lsl#565). Releasing twice does nothing."""
    destroy = getattr(pylsl.lib.lib, _DESTROY[type(handle)])
    with LIFECYCLE:
        obj, handle.obj = handle.obj, ctypes.c_void_p()
        if obj:
            destroy(obj)


def _channels(info: pylsl.StreamInfo) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Labels and units of ``info``'s channels (``desc/channels/channel``), '' when absent."""
    n = info.channel_count()
    labels, units = [], []
    channel = info.desc().child("channels").child("channel")
    while not channel.empty() and len(labels) < n:
        labels.append(channel.child_value("label"))
        units.append(channel.child_value("unit"))
        channel = channel.next_sibling("channel")
    if len(labels) != n:
        labels, units = [""] * n, [""] * n
    return tuple(labels), tuple(units)


def describe(info: pylsl.StreamInfo) -> StreamDescription:
    labels, units = _channels(info)
    return StreamDescription(
        name=info.name(), type=info.type(), source_id=info.source_id(), uid=info.uid(),
        host=info.hostname(), rate=float(info.nominal_srate()), labels=labels, units=units,
        format=FORMATS.get(info.channel_format(), "undefined"),
    )  # fmt: skip


class LslInlet:
    """An inlet on the session's clock (see the module docstring)."""

    def __init__(self, info: pylsl.StreamInfo):
        markers = info.channel_format() == pylsl.cf_string
        try:
            with LIFECYCLE:
                self._inlet = open_inlet(info, OPEN_TIMEOUT_S, max_buflen=MAX_BUFFER_S,
                                         recover=False, as_numpy=not markers)  # fmt: skip
                try:
                    self.description = describe(self._inlet.info(OPEN_TIMEOUT_S))
                    self._offset = float(self._inlet.time_correction(OPEN_TIMEOUT_S))
                except BaseException:
                    release(self._inlet)
                    raise
        except LostError:
            raise StreamLost(f"stream {info.name()!r} vanished while it was opened") from None
        except pylsl.util.TimeoutError:
            raise StreamLost(f"stream {info.name()!r} did not answer in time") from None
        self._markers = markers
        self._n = self.description.n_channels

    def offset(self) -> float:
        return self._offset

    def pull(self) -> tuple[np.ndarray, np.ndarray | list[str]]:
        if not self._inlet.obj:
            raise StreamLost(f"stream {self.description.name!r}: its inlet is closed")
        try:
            estimate = float(self._inlet.time_correction(0.0))
            if abs(estimate - self._offset) > OFFSET_STEP_S:
                self._offset = estimate
            chunks, stamps = [], []
            while True:
                samples, times = self._inlet.pull_chunk(timeout=0.0, max_samples=4096)
                if len(times) == 0:
                    break
                chunks.append(samples)
                stamps.extend(times)
                if len(times) < 4096:
                    break
        except (LostError, pylsl.util.TimeoutError):
            raise StreamLost(f"stream {self.description.name!r} is gone") from None
        times = np.asarray(stamps, dtype=float) + self._offset
        if self._markers:
            return times, [str(row[0]) if len(row) else "" for c in chunks for row in c]
        if not chunks:
            return times, np.zeros((0, self._n))
        return times, np.concatenate([np.asarray(c, dtype=float) for c in chunks])

    def close(self) -> None:
        release(self._inlet)


class LslOutlet:
    """An outlet: the rows of a push handed to liblsl at once, each with the push's stamp."""

    def __init__(self, spec: OutletSpec):
        if spec.format not in CHANNEL_FORMATS:
            raise ValueError(f"an outlet is double64 or string, not {spec.format!r}")
        info = pylsl.StreamInfo(
            spec.name, spec.type, len(spec.labels), spec.rate, CHANNEL_FORMATS[spec.format],
            spec.source_id,
        )  # fmt: skip
        channels = info.desc().append_child("channels")
        for label, unit in zip(spec.labels, spec.units, strict=True):
            channel = channels.append_child("channel")
            channel.append_child_value("label", label)
            channel.append_child_value("unit", unit)
        info.desc().append_child_value("producer", "promp.live")
        self._outlet = new_outlet(info, chunk_size=0, max_buffered=MAX_BUFFER_S)
        self._strings = spec.format == "string"
        self._name = spec.name
        self._using = threading.Lock()  # a sink's thread pushes, another may close

    def push(self, rows, stamp: float) -> None:
        """Push ``rows`` (each with ``stamp``) in one call to liblsl, through at once.

        One call, not one per row: each call into liblsl gives up Python's interpreter lock,
        and getting it back from a session thread that is inferring waits up to the
        interpreter's switch interval (5 ms), so a remainder of 50 rows pushed row by row
        reached the readers tens of ms late (``bench/live.py``)."""
        rows = [[str(r)] for r in rows] if self._strings else np.asarray(rows, dtype=float)
        with self._using:
            if not self._outlet.obj:
                raise ValueError(f"the outlet {self._name!r} is closed")
            if len(rows):
                self._outlet.push_chunk(rows, [float(stamp)] * len(rows), pushthrough=True)

    def wait_for_consumers(self, timeout: float) -> bool:
        """Whether a reader connected within ``timeout`` seconds (False once closed); waits
        in slices, so that a close never waits long for it."""
        deadline = time.monotonic() + timeout
        while True:
            with self._using:
                left = max(deadline - time.monotonic(), 0.0)
                if not self._outlet.obj:
                    return False
                if self._outlet.wait_for_consumers(min(left, 0.05)):
                    return True
            if left <= 0.05:
                return False

    def close(self) -> None:
        with self._using:
            release(self._outlet)


class LslTransport:
    """The Lab Streaming Layer as a :class:`promp.live.transport.Transport`.

    Streams are found by a continuous resolver (LSL's own: it keeps asking the network in the
    background, and a stream gone for :data:`FORGET_S` is forgotten); a one-off resolve with
    a short wait may miss some of the streams that are there."""

    def __init__(self) -> None:
        self._resolver = pylsl.ContinuousResolver(forget_after=FORGET_S)
        self._since = pylsl.local_clock()
        self._found: dict[str, pylsl.StreamInfo] = {}  # by uid, from the last find

    def clock(self) -> float:
        return float(pylsl.local_clock())

    def find(self, wait: float) -> list[StreamDescription]:
        """The streams seen lately; the first look waits up to ``wait`` seconds for the
        resolver's first answers."""
        left = self._since + max(wait, 0.0) - pylsl.local_clock()
        if left > 0:
            time.sleep(left)
        infos = self._resolver.results()
        self._found = {info.uid(): info for info in infos}
        return [describe(info) for info in infos]

    def open(self, stream: StreamDescription) -> LslInlet:
        info = self._found.get(stream.uid)
        if info is None:
            found = pylsl.resolve_bypred(f"uid='{stream.uid}'", 1, OPEN_TIMEOUT_S)
            if not found:
                raise StreamLost(f"stream {stream.name!r} vanished before it was opened")
            info = found[0]
        return LslInlet(info)

    def outlet(self, spec: OutletSpec) -> LslOutlet:
        return LslOutlet(spec)


def local_clock() -> float:
    """LSL's clock (seconds), the session's."""
    return float(pylsl.local_clock())
