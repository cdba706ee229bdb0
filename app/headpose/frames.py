"""Frame sources (webcam, video file) and head-pose tracks of whole videos.

Timestamps: a video frame's time is its index divided by the file's frame rate (exact and
strictly increasing), or OpenCV's ``CAP_PROP_POS_MSEC`` when the file reports no usable frame
rate; a webcam frame's time is ``time.monotonic()`` when the frame was grabbed.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from app.headpose.estimator import HeadPoseEstimator


class HeadPoseSourceError(RuntimeError):
    """A camera or video cannot be opened or read. The message starts with the source's name."""


class FrameSource:
    """Frames from an opened ``cv2.VideoCapture``; iterate to get ``(t, frame_bgr)`` pairs.

    Use :func:`open_camera` or :func:`open_video` to make one. Closing releases the device or
    file; the source is also a context manager.

    Attributes
    ----------
    name : str
        ``"camera N"`` or ``"video PATH"``, used in error messages.
    is_camera : bool
    fps : float
        Frames per second reported by the source (0 when unknown).
    frame_count : int
        Number of frames of a video (0 when unknown, and for cameras).
    """

    def __init__(self, capture: cv2.VideoCapture, name: str, is_camera: bool) -> None:
        self._capture = capture
        self.name = name
        self.is_camera = is_camera
        fps = float(capture.get(cv2.CAP_PROP_FPS))
        self.fps = fps if math.isfinite(fps) and 0 < fps < 10_000 else 0.0
        count = 0 if is_camera else capture.get(cv2.CAP_PROP_FRAME_COUNT)
        self.frame_count = int(count) if math.isfinite(count) and count > 0 else 0
        self._index = 0
        self._last_t: float | None = None
        self._first: tuple[float, np.ndarray] | None = None

    def _read(self) -> tuple[float, np.ndarray] | None:
        if self._capture is None:
            raise HeadPoseSourceError(f"{self.name}: the source is closed")
        if self.is_camera:
            if not self._capture.grab():
                raise HeadPoseSourceError(f"{self.name}: no frame (camera disconnected or busy)")
            t = time.monotonic()
            ok, frame = self._capture.retrieve()
            if not ok or frame is None:
                raise HeadPoseSourceError(f"{self.name}: a grabbed frame could not be decoded")
            return t, frame
        ok, frame = self._capture.read()
        if not ok or frame is None:
            return None
        if self.fps > 0:
            t = self._index / self.fps
        else:  # no frame rate: the container's time stamps, kept strictly increasing
            t = float(self._capture.get(cv2.CAP_PROP_POS_MSEC)) / 1000.0
            if self._last_t is not None and not t > self._last_t:
                t = self._last_t + 1e-3
        self._index += 1
        self._last_t = t
        return t, frame

    def _check_first(self) -> None:
        """Read one frame now, so that an undecodable source fails when opened."""
        first = self._read()
        if first is None:
            self.close()
            raise HeadPoseSourceError(
                f"{self.name}: no frame can be decoded (corrupt or unsupported video)"
            )
        self._first = first

    def read(self) -> tuple[float, np.ndarray] | None:
        """The next ``(t, frame_bgr)``, or None at the end of a video.

        Raises
        ------
        HeadPoseSourceError
            When a camera stops delivering frames, or the source is closed.
        """
        if self._first is not None:
            first, self._first = self._first, None
            return first
        return self._read()

    def __iter__(self) -> Iterator[tuple[float, np.ndarray]]:
        while True:
            item = self.read()
            if item is None:
                return
            yield item

    def close(self) -> None:
        """Release the camera or file (idempotent)."""
        if self._capture is not None:
            self._capture.release()
            self._capture = None

    @property
    def closed(self) -> bool:
        return self._capture is None

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_camera(index: int, width: int | None = 640, height: int | None = 480) -> FrameSource:
    """Open a webcam.

    Parameters
    ----------
    index : int
        OpenCV camera index (0 is the first camera, ``/dev/video0`` on Linux).
    width, height : int, optional
        Requested frame size; the camera may choose another. None keeps its default.

    Returns
    -------
    FrameSource

    Raises
    ------
    HeadPoseSourceError
        When the camera cannot be opened or delivers no frame.
    """
    if isinstance(index, bool) or not isinstance(index, int | np.integer) or index < 0:
        raise ValueError(f"camera index must be an integer >= 0, got {index!r}")
    name = f"camera {int(index)}"
    capture = cv2.VideoCapture(int(index))
    if not capture.isOpened():
        capture.release()
        raise HeadPoseSourceError(f"{name}: cannot be opened (no such camera, or it is busy)")
    if width is not None:
        capture.set(cv2.CAP_PROP_FRAME_WIDTH, width)
    if height is not None:
        capture.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
    source = FrameSource(capture, name, is_camera=True)
    source._check_first()
    return source


def open_video(path: str | os.PathLike, name: str | None = None) -> FrameSource:
    """Open a video file.

    Parameters
    ----------
    path : path-like
    name : str, optional
        How errors name the source; default ``"video PATH"``.

    Returns
    -------
    FrameSource

    Raises
    ------
    HeadPoseSourceError
        When the file does not exist, cannot be opened, or has no decodable frame.
    """
    path = Path(path)
    name = f"video {path}" if name is None else name
    if not path.is_file():
        raise HeadPoseSourceError(f"{name}: no such file")
    capture = cv2.VideoCapture(str(path))
    if not capture.isOpened():
        capture.release()
        raise HeadPoseSourceError(f"{name}: cannot be opened (corrupt or unsupported format)")
    source = FrameSource(capture, name, is_camera=False)
    source._check_first()
    return source


@dataclass(frozen=True)
class HeadPoseTrack:
    """A timestamped head-pose track, one entry per video frame.

    Attributes
    ----------
    t : array, shape (n_samples,)
        Seconds from the start of the video, increasing.
    roll, pitch, yaw : array, shape (n_samples,)
        Radians; 0 where ``face_found`` is False.
    confidence : array, shape (n_samples,)
        In [0, 1]; 0 where no face.
    face_found : array of bool, shape (n_samples,)
    source : str
        Name of the video.
    """

    t: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    yaw: np.ndarray
    confidence: np.ndarray
    face_found: np.ndarray
    source: str = field(default="")

    def __post_init__(self) -> None:
        n = len(self.t)
        for name in ("roll", "pitch", "yaw", "confidence", "face_found"):
            if np.shape(getattr(self, name)) != (n,):
                shape = np.shape(getattr(self, name))
                raise ValueError(f"{name} must have shape ({n},), got {shape}")

    def __len__(self) -> int:
        return len(self.t)

    @property
    def angles(self) -> np.ndarray:
        """``(roll, pitch, yaw)`` per sample, radians, shape (n_samples, 3)."""
        return np.column_stack([self.roll, self.pitch, self.yaw])


def track_video(
    video: str | os.PathLike | bytes,
    progress: Callable[[float], None] | None = None,
    estimator: HeadPoseEstimator | None = None,
    suffix: str = ".mp4",
) -> HeadPoseTrack:
    """Estimate the head pose in every frame of a video file, e.g. one uploaded in the studio.

    Parameters
    ----------
    video : path-like or bytes
        The file, or its content (written to a temporary file, removed afterwards).
    progress : callable, optional
        Called with the fraction done in [0, 1] as frames are processed (at most about 100
        times, and once with 1.0 at the end).
    estimator : HeadPoseEstimator, optional
        Default: a new one with default settings. It is :meth:`~HeadPoseEstimator.reset` first.
    suffix : str
        File name suffix for ``bytes`` content (it helps OpenCV pick the demuxer).

    Returns
    -------
    HeadPoseTrack

    Raises
    ------
    HeadPoseSourceError
        When the video cannot be opened or decoded.
    """
    estimator = HeadPoseEstimator() if estimator is None else estimator
    if isinstance(video, bytes | bytearray | memoryview):
        if not re.fullmatch(r"\.[A-Za-z0-9]{1,8}", suffix):
            raise ValueError(f"suffix must look like '.mp4', got {suffix!r}")
        with tempfile.TemporaryDirectory(prefix="headpose-") as folder:
            path = Path(folder) / f"upload{suffix}"
            path.write_bytes(bytes(video))
            source = open_video(path, name=f"uploaded video ({len(video)} bytes)")
            return _track(source, progress, estimator)
    return _track(open_video(video), progress, estimator)


def _track(
    source: FrameSource,
    progress: Callable[[float], None] | None,
    estimator: HeadPoseEstimator,
) -> HeadPoseTrack:
    estimator.reset()
    keys = ("t", "roll", "pitch", "yaw", "confidence", "face_found")
    columns: dict[str, list] = {key: [] for key in keys}
    total = source.frame_count
    every = max(1, total // 100) if total else 1
    with source:
        for index, (t, frame) in enumerate(source):
            sample = estimator.process(frame, t)
            for key in columns:
                columns[key].append(getattr(sample, key))
            if progress is not None and total and (index + 1) % every == 0:
                progress(min(1.0, (index + 1) / total))
    if progress is not None:
        progress(1.0)
    return HeadPoseTrack(
        t=np.asarray(columns["t"], dtype=np.float64),
        roll=np.asarray(columns["roll"], dtype=np.float64),
        pitch=np.asarray(columns["pitch"], dtype=np.float64),
        yaw=np.asarray(columns["yaw"], dtype=np.float64),
        confidence=np.asarray(columns["confidence"], dtype=np.float64),
        face_found=np.asarray(columns["face_found"], dtype=bool),
        source=source.name,
    )
