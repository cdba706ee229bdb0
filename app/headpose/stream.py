"""A camera (or video) processed continuously in a background thread, for the studio's GUI."""

from __future__ import annotations

import collections
import os
import threading
import time

import cv2
import numpy as np

from app.headpose.estimator import HeadPoseEstimator, HeadPoseSample
from app.headpose.frames import FrameSource, open_camera, open_video
from app.headpose.overlay import draw_overlay


class CameraStream:
    """Run a :class:`HeadPoseEstimator` on a camera or video in a background thread.

    The estimator is built (and the models loaded) in the constructor, so a missing model fails
    at once; the source is opened in the thread, so a slow camera does not block the caller.
    Any failure of the source or the estimator stops the thread and is kept in :attr:`error`.

    Parameters
    ----------
    source : int or path-like
        A camera index, or a video file.
    estimator : HeadPoseEstimator, optional
        Default: a new one with default settings.
    realtime : bool
        For a video file: pace the frames by their timestamps, as a camera would deliver them.
        False processes the file as fast as possible. Ignored for cameras.
    history : int
        How many samples :meth:`drain` keeps at most between two calls.

    Attributes
    ----------
    error : Exception or None
        Why the stream stopped, when it failed (e.g. ``HeadPoseSourceError``).
    finished : bool
        True once the thread has stopped (end of a video, :meth:`close`, or an error).
    """

    def __init__(
        self,
        source: int | str | os.PathLike,
        estimator: HeadPoseEstimator | None = None,
        *,
        realtime: bool = True,
        history: int = 10_000,
    ) -> None:
        if isinstance(source, bool) or not isinstance(source, int | str | os.PathLike):
            raise ValueError(f"source must be a camera index or a video path, got {source!r}")
        if history < 1:
            raise ValueError(f"history must be >= 1, got {history}")
        self.source = source
        self.estimator = HeadPoseEstimator() if estimator is None else estimator
        self.realtime = bool(realtime)
        self.error: Exception | None = None
        self.finished = False
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._sample: HeadPoseSample | None = None
        self._frame: np.ndarray | None = None
        self._history: collections.deque[HeadPoseSample] = collections.deque(maxlen=history)
        self._thread = threading.Thread(target=self._run, name="headpose-stream", daemon=True)
        self._thread.start()

    # -- the thread --------------------------------------------------------------------------

    def _open(self) -> FrameSource:
        if isinstance(self.source, int):
            return open_camera(self.source)
        return open_video(self.source)

    def _run(self) -> None:
        frames: FrameSource | None = None
        try:
            frames = self._open()
            self.estimator.reset()
            start_wall: float | None = None
            for t, frame in frames:
                if self._stop.is_set():
                    break
                if self.realtime and not frames.is_camera:
                    if start_wall is None:
                        start_wall = time.monotonic() - t
                    delay = start_wall + t - time.monotonic()
                    if delay > 0 and self._stop.wait(delay):
                        break
                sample = self.estimator.process(frame, t)
                with self._lock:
                    self._sample = sample
                    self._frame = frame
                    self._history.append(sample)
        except Exception as error:  # kept for the GUI to show; the thread just stops
            self.error = error
        finally:
            if frames is not None:
                frames.close()
            self.finished = True

    # -- the caller's side -------------------------------------------------------------------

    @property
    def running(self) -> bool:
        """True while the thread is processing frames."""
        return self._thread.is_alive()

    def latest(self) -> HeadPoseSample | None:
        """The most recent sample, or None before the first frame."""
        with self._lock:
            return self._sample

    def latest_preview(self, rgb: bool = True) -> np.ndarray | None:
        """The most recent frame with its landmarks, head axes and angles drawn.

        Parameters
        ----------
        rgb : bool
            True (default) returns RGB, as image widgets expect; False returns BGR.

        Returns
        -------
        array, shape (height, width, 3), uint8, or None
            None before the first frame.
        """
        with self._lock:
            frame, sample = self._frame, self._sample
        if frame is None:
            return None
        image = draw_overlay(frame, sample)
        return cv2.cvtColor(image, cv2.COLOR_BGR2RGB) if rgb else image

    def drain(self) -> list[HeadPoseSample]:
        """All samples since the previous call (at most ``history``), oldest first."""
        with self._lock:
            samples = list(self._history)
            self._history.clear()
        return samples

    def calibrate_neutral(self) -> None:
        """Make the partner's current head pose the zero (see the estimator's method)."""
        self.estimator.calibrate_neutral()

    def close(self, timeout: float = 5.0) -> None:
        """Stop the thread and release the source (idempotent)."""
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout)

    def __enter__(self) -> CameraStream:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
