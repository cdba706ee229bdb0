"""The partner's head: where its pose comes from while teaching (a simulated partner, a webcam,
a video file, or a head-pose track computed from an uploaded video), and the source in use with
its latest reading (:class:`HeadInput`).

Every source answers :meth:`HeadSource.read` with the latest head orientation (roll, pitch,
yaw in the convention of :mod:`robots.icub.scene`) or ``None`` when there is no face, never a
stale or invented angle; camera-backed sources also give a preview image with the landmarks
drawn. A source that fails keeps its error message in :attr:`HeadSource.error` and reads
``None``; the rest of the studio keeps working.

The Teach tab's *Head source* chooses the source (:meth:`HeadInput.use`, from any thread); the
studio's loop reads it once per iteration (:meth:`HeadInput.read`); the recorder, the live
stream and the partner's avatar take :attr:`HeadInput.angles`, that latest reading.
"""

from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass

import numpy as np

from app.live.history import StateHistory
from robots.icub.scene import DEFAULT_SCENE, head_orientation_looking_at

# A camera sample older than this is "no face" rather than a stale angle.
STALE_AFTER_S = 0.5


@dataclass(frozen=True)
class HeadReading:
    """The head orientation at time ``t`` (monotonic seconds); ``angles`` None = no face."""

    t: float
    angles: np.ndarray | None
    confidence: float = 0.0


class HeadSource:
    """Interface of head-pose sources."""

    name = "head source"
    error: str | None = None

    def read(self, hand_position: np.ndarray) -> HeadReading:
        raise NotImplementedError

    def preview(self) -> np.ndarray | None:
        """An RGB image of what the source sees (None when it has no camera)."""
        return None

    def close(self) -> None:
        """Release the camera or file."""


class SimulatedPartner(HeadSource):
    """A partner who looks where the robot's hand is going.

    The gaze leads the hand: it aims at the hand's position extrapolated ``lead_s`` seconds
    ahead from its recent velocity, as people look ahead of a moving object; the head follows
    that target with a first-order lag of ``lag_s``. No noise is added: live teaching should
    show the partner's intent cleanly (recorded datasets from :mod:`robots.icub.scenario` add
    webcam-like noise).
    """

    name = "simulated partner"

    def __init__(self, lead_s: float = 0.6, lag_s: float = 0.15, head_position=None):
        self.lead_s = lead_s
        self.lag_s = lag_s
        self.head_position = np.asarray(
            DEFAULT_SCENE.partner_head if head_position is None else head_position, dtype=float
        )
        self._history: collections.deque[tuple[float, np.ndarray]] = collections.deque(maxlen=8)
        self._angles: np.ndarray | None = None
        self._last_t: float | None = None
        self._lock = threading.Lock()

    def read(self, hand_position: np.ndarray) -> HeadReading:
        now = time.monotonic()
        hand = np.asarray(hand_position, dtype=float)
        with self._lock:
            self._history.append((now, hand.copy()))
            t0, p0 = self._history[0]
            velocity = (hand - p0) / (now - t0) if now - t0 > 1e-3 else np.zeros(3)
            target = hand + self.lead_s * velocity
            desired = np.array(head_orientation_looking_at(target, self.head_position))
            if self._angles is None or self._last_t is None:
                self._angles = desired
            else:
                gain = 1.0 - np.exp(-(now - self._last_t) / self.lag_s)
                self._angles = self._angles + gain * (desired - self._angles)
            self._last_t = now
            return HeadReading(now, self._angles.copy(), 1.0)


class StreamHeadSource(HeadSource):
    """A webcam (by index) or a video file, processed by the OpenCV head-pose estimator in a
    background thread (:class:`app.headpose.CameraStream`)."""

    def __init__(self, source: int | str):
        from app.headpose import CameraStream, HeadPoseModelError

        self.name = f"camera {source}" if isinstance(source, int) else f"video {source}"
        self.stream = None
        self.error = None
        self._last_sample = None
        self._last_change = time.monotonic()
        try:
            self.stream = CameraStream(source)
        except (HeadPoseModelError, ValueError, OSError) as exc:
            self.error = str(exc)

    def _check(self) -> None:
        if self.stream is not None and self.stream.error is not None and self.error is None:
            reason = str(self.stream.error)  # the stream's errors usually name the source
            self.error = reason if reason.startswith(self.name) else f"{self.name}: {reason}"

    def read(self, hand_position: np.ndarray) -> HeadReading:
        now = time.monotonic()
        self._check()
        sample = None if self.stream is None else self.stream.latest()
        if sample is not self._last_sample:
            self._last_sample, self._last_change = sample, now
        stale = now - self._last_change > STALE_AFTER_S  # the stream stopped delivering
        if sample is None or not sample.face_found or stale:
            return HeadReading(now, None, 0.0)
        angles = np.array([sample.roll, sample.pitch, sample.yaw])
        return HeadReading(now, angles, float(sample.confidence))

    def preview(self) -> np.ndarray | None:
        self._check()
        return None if self.stream is None else self.stream.latest_preview()

    def calibrate_neutral(self) -> None:
        if self.stream is not None:
            self.stream.calibrate_neutral()

    def close(self) -> None:
        if self.stream is not None:
            self.stream.close()


class TrackHeadSource(HeadSource):
    """Plays back a head-pose track (e.g. from an uploaded video) in real time, looping."""

    def __init__(self, times: np.ndarray, angles: np.ndarray, valid: np.ndarray, name: str):
        if times.shape[0] < 2:
            raise ValueError("a head-pose track needs at least two samples")
        self.name = f"uploaded video {name}"
        self.times = np.asarray(times, dtype=float) - float(times[0])
        self.angles = np.asarray(angles, dtype=float)
        self.valid = np.asarray(valid, dtype=bool)
        self.start = time.monotonic()

    def read(self, hand_position: np.ndarray) -> HeadReading:
        now = time.monotonic()
        t = (now - self.start) % max(self.times[-1], 1e-3)
        i = int(np.searchsorted(self.times, t, side="right")) - 1
        if not self.valid[i]:
            return HeadReading(now, None, 0.0)
        return HeadReading(now, self.angles[i].copy(), 1.0)


class HeadInput:
    """The current head source and its latest reading (see the module docstring)."""

    def __init__(self, source: HeadSource):
        self._lock = threading.Lock()
        self._source = source
        self.reading = HeadReading(time.monotonic(), None)
        # The angles of each reading, from the moment it was read (the recorder's ticks).
        self.history: StateHistory[np.ndarray | None] = StateHistory()
        self.history.record(None)

    @property
    def source(self) -> HeadSource:
        return self._source

    @property
    def angles(self) -> np.ndarray | None:
        """Roll, pitch, yaw (rad) of the latest reading, None when it saw no face."""
        return self.reading.angles

    def angles_at(self, t: float) -> np.ndarray | None:
        """The head angles (3,) of the reading current at monotonic time ``t`` (None: no
        face); ``LookupError`` when ``t`` is older than what is kept."""
        return self.history.at(t)

    def use(self, source: HeadSource) -> None:
        """Read the head from ``source`` from now on; the previous one is closed."""
        with self._lock:
            old, self._source = self._source, source
        if old is not source:
            old.close()

    def read(self, hand_position: np.ndarray) -> HeadReading:
        """Read the source (the simulated partner looks where the hand goes)."""
        with self._lock:
            source = self._source
        reading = source.read(hand_position)
        self.reading = reading
        self.history.record(reading.angles)
        return reading

    def close(self) -> None:
        self._source.close()
