"""Recording a demonstration: the hand and the partner's head sampled at a fixed rate.

A :class:`Recorder` runs its own thread that wakes on a fixed schedule (default 50 Hz, the
schedule does not drift: tick ``k`` is due at ``start + k / rate``) and stores, per tick, its
time (monotonic seconds), the hand position and the head angles of the head reading current
at that time, or no angles when the head source saw no face. The values come from the studio's
histories (:class:`app.live.history.StateHistory`: the hand each time the loop moved the arm,
the head at each reading), so a thread that wakes late on a loaded machine samples every
missed tick as it was, not a gap in the take (which the checks would flag, leaving the take
out of learning) nor a burst of identical values. Only a tick older than the histories keep
is skipped, and counted.

Samples without a face
----------------------
The engine needs finite values in every column, but a head angle is never invented silently.
:meth:`Recording.values` therefore:

- refuses a recording without a single head reading (``ValueError``: nothing is saved);
- refuses one where the face was missing for longer than ``max_gap_s`` (0.5 s) in one stretch,
  naming when, since a long gap is guesswork: the partner turned away or the camera lost them;
- fills shorter gaps between two readings by linear interpolation of the angles on either side,
  and a short gap at the very start or end by holding the nearest reading;
- reports how many samples were filled (:attr:`HeadFill.n_filled`), and the studio says so.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from promp.data import Layout
from robots.icub.layout import HAND, HEAD, STUDIO_LAYOUT

RECORD_RATE_HZ = 50.0  # the studio records takes at this rate (the simulated scenario has its own)
MAX_GAP_S = 0.5

Sampler = Callable[[float], tuple[np.ndarray, np.ndarray | None]]


@dataclass(frozen=True)
class HeadFill:
    """How the head columns of a recording were completed (see the module docstring)."""

    n_samples: int
    n_filled: int
    longest_gap_s: float

    @property
    def message(self) -> str:
        if self.n_filled == 0:
            return "face seen in every sample"
        return (
            f"no face in {self.n_filled} of {self.n_samples} samples "
            f"(longest gap {self.longest_gap_s:.2f} s): angles interpolated"
        )


@dataclass(frozen=True)
class Recording:
    """What a :class:`Recorder` captured.

    Attributes
    ----------
    times : array, shape (n,)
        Seconds from the first sample, increasing.
    hand : array, shape (n, 3)
        Hand position x, y, z (m) in the robot's root frame.
    head : array, shape (n, 3)
        Head roll, pitch, yaw (rad); NaN rows where there was no face.
    """

    times: np.ndarray
    hand: np.ndarray
    head: np.ndarray

    @property
    def n_samples(self) -> int:
        return int(self.times.shape[0])

    @property
    def duration(self) -> float:
        return float(self.times[-1]) if self.n_samples else 0.0

    @property
    def face(self) -> np.ndarray:
        """Which samples have a head reading, bool array of shape (n,)."""
        return np.all(np.isfinite(self.head), axis=1)

    def values(
        self, layout: Layout = STUDIO_LAYOUT, max_gap_s: float = MAX_GAP_S
    ) -> tuple[np.ndarray, HeadFill]:
        """The demonstration's columns in ``layout``'s order (the studio's: x, y, z, roll,
        pitch, yaw), shape (n, D), all finite.

        Raises
        ------
        ValueError
            Fewer than two samples, a modality the studio cannot record (see
            :func:`unrecordable`), or, when the head is recorded, no head reading at all or
            the face missing for longer than ``max_gap_s`` in one stretch (the message says
            when).
        """
        n = self.n_samples
        if n < 2:
            raise ValueError(
                f"the recording has {n} sample(s); at least 2 are needed: record for longer"
            )
        missing = unrecordable(layout)
        if missing:
            raise ValueError(
                f"the studio cannot record {', '.join(missing)}: this workspace's "
                "demonstrations have modalities only an imported dataset provides"
            )
        head, fill = None, HeadFill(n, 0, 0.0)
        if HEAD.name in layout.names:
            head, fill = self._filled_head(max_gap_s)
        blocks = {HAND.name: self.hand, HEAD.name: head}
        return np.column_stack([blocks[name] for name in layout.names]), fill

    def _filled_head(self, max_gap_s: float) -> tuple[np.ndarray, HeadFill]:
        n = self.n_samples
        face = self.face
        if not face.any():
            raise ValueError(
                "the head source saw no face during the whole recording, so there are no head "
                "angles to save: check the camera (or use the simulated partner) and record again"
            )
        gaps = _runs(~face)
        head = self.head.copy()
        longest = 0.0
        for start, stop in gaps:  # samples start..stop-1 have no face
            t0 = self.times[start - 1] if start > 0 else self.times[start]
            t1 = self.times[stop] if stop < n else self.times[stop - 1]
            length = float(t1 - t0)
            longest = max(longest, length)
            if length > max_gap_s:
                raise ValueError(
                    f"the face was lost for {length:.1f} s (from {t0:.1f} s to {t1:.1f} s of the "
                    f"recording), more than the {max_gap_s:g} s that can be filled in: "
                    "record again facing the camera"
                )
        valid = np.flatnonzero(face)
        for j in range(3):  # np.interp holds the end values beyond the first/last reading
            head[:, j] = np.interp(self.times, self.times[valid], self.head[valid, j])
        return head, HeadFill(n, int((~face).sum()), longest)


def unrecordable(layout: Layout) -> list[str]:
    """The modalities of ``layout`` the studio cannot sample: any but the hand and the head
    (with the studio's columns)."""
    recordable = {HAND.name: HAND, HEAD.name: HEAD}
    return [m.name for m in layout.modalities if recordable.get(m.name) != m]


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the runs of True in ``mask``."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


class Recorder:
    """Samples ``sample()`` at a fixed rate in a background thread (see the module docstring).

    Parameters
    ----------
    sample : callable
        ``sample(t)`` returns ``(hand (3,), head angles (3,) or None)`` as they were at the
        monotonic time ``t`` (a tick, now or a little earlier), or raises ``LookupError`` when
        ``t`` is too old to know; called from the recorder's thread, so it must be thread-safe
        (the studio's histories are).
    rate_hz : float
        Sampling rate, 1 to 1000 Hz.
    clock : callable
        Monotonic seconds (injectable for tests).
    """

    def __init__(
        self,
        sample: Sampler,
        rate_hz: float = RECORD_RATE_HZ,
        clock: Callable[[], float] = time.monotonic,
    ):
        if not np.isfinite(rate_hz) or not 1.0 <= rate_hz <= 1000.0:
            raise ValueError(f"the sampling rate must be within 1-1000 Hz, got {rate_hz}")
        self.sample = sample
        self.rate_hz = float(rate_hz)
        self.clock = clock
        self._times: list[float] = []
        self._hand: list[np.ndarray] = []
        self._head: list[np.ndarray] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: str | None = None
        self.skipped = 0  # ticks too old to sample when the thread got to them

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @property
    def n_samples(self) -> int:
        with self._lock:
            return len(self._times)

    def start(self) -> None:
        """Start sampling (a Recorder records once)."""
        if self._thread is not None:
            raise ValueError("this recorder has already been started")
        self._thread = threading.Thread(target=self._run, name="recorder", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        period = 1.0 / self.rate_hz
        start = self.clock()
        k = 0  # the next tick, due at start + k * period
        while True:
            now = self.clock()
            while start + k * period <= now:  # every tick due by now, late ones too
                try:
                    self._take(start + k * period)
                except LookupError:  # older than the histories keep: nothing to sample
                    self.skipped += 1
                except Exception as exc:  # a failing sampler ends the recording with its reason
                    self.error = f"{type(exc).__name__}: {exc}"
                    return
                k += 1
            if self._stop.wait(max(0.0, start + k * period - self.clock())):
                return

    def _take(self, t: float) -> None:
        hand, head = self.sample(t)
        hand = np.array(hand, dtype=float).reshape(3)
        head = np.full(3, np.nan) if head is None else np.array(head, dtype=float).reshape(3)
        with self._lock:
            self._times.append(t)
            self._hand.append(hand)
            self._head.append(head)

    def snapshot(self) -> Recording:
        """The samples so far (e.g. for a live plot), times from the first sample."""
        with self._lock:
            times = np.array(self._times, dtype=float)
            hand = np.array(self._hand, dtype=float).reshape(-1, 3)
            head = np.array(self._head, dtype=float).reshape(-1, 3)
        if times.size:
            times = times - times[0]
        return Recording(times, hand, head)

    def stop(self) -> Recording:
        """Stop sampling and return everything recorded."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        return self.snapshot()
