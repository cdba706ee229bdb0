"""The head-pose estimator: frame after frame, the face found or tracked
(:mod:`app.headpose.tracker`), its head pose fitted to the landmarks (:mod:`app.headpose.pose`)
relative to the neutral pose (:mod:`app.headpose.neutral`), and smoothed
(:mod:`app.headpose.smoothing`)."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from app.headpose.face_model import MODEL_LANDMARKS
from app.headpose.filter import OneEuroConfig
from app.headpose.landmarks import LandmarkResult
from app.headpose.models import ModelPaths
from app.headpose.neutral import NeutralPose
from app.headpose.pose import camera_matrix, check_intrinsics, fit_confidence, solve_head_pose
from app.headpose.smoothing import DEFAULT_SMOOTHING, AngleSmoothing
from app.headpose.tracker import FaceTracker


@dataclass(frozen=True)
class HeadPoseSample:
    """The partner's head pose in one frame.

    Attributes
    ----------
    t : float
        Seconds (the frame's timestamp, as given to :meth:`HeadPoseEstimator.process`).
    face_found : bool
        False when no face was found: then the angles and confidence are 0.0 and must not be used.
    roll, pitch, yaw : float
        Radians, in the package's head-frame convention (``Rz(yaw) @ Ry(pitch) @ Rx(roll)``).
    confidence : float
        In [0, 1]: the landmark model's face-presence probability times the quality of the
        PnP fit. 0 when no face.
    landmarks : array, shape (468, 2), optional
        The face landmarks in frame pixels when a face was found, else None.
    """

    t: float
    face_found: bool
    roll: float
    pitch: float
    yaw: float
    confidence: float
    landmarks: np.ndarray | None

    @classmethod
    def no_face(cls, t: float) -> HeadPoseSample:
        """The explicit "no face in this frame" sample."""
        return cls(
            t=t, face_found=False, roll=0.0, pitch=0.0, yaw=0.0, confidence=0.0, landmarks=None
        )

    @property
    def angles(self) -> np.ndarray:
        """``(roll, pitch, yaw)``, radians, shape (3,)."""
        return np.array([self.roll, self.pitch, self.yaw])


def check_frame(frame: np.ndarray) -> np.ndarray:
    """Validate a frame and return it as a 3-channel BGR uint8 image.

    Parameters
    ----------
    frame : array, shape (height, width, 3) or (height, width), uint8
    """
    if not isinstance(frame, np.ndarray):
        raise ValueError(f"frame must be a numpy array, got {type(frame).__name__}")
    if frame.dtype != np.uint8:
        raise ValueError(f"frame must be uint8, got {frame.dtype}")
    if frame.ndim == 2:
        frame = np.repeat(frame[:, :, None], 3, axis=2)
    if frame.ndim != 3 or frame.shape[2] != 3 or frame.shape[0] < 8 or frame.shape[1] < 8:
        raise ValueError(
            f"frame must have shape (height, width, 3) with both sides >= 8, got {frame.shape}"
        )
    return frame


class HeadPoseEstimator:
    """Estimate the partner's head roll, pitch and yaw in a sequence of frames.

    The models are loaded once. :meth:`process` takes frames in time order: the
    :class:`~app.headpose.tracker.FaceTracker` (``tracker``) searches for the face on the first
    frame and whenever the face was lost, and tracks it otherwise; the head pose is fitted to
    its landmarks, expressed relative to the :class:`~app.headpose.neutral.NeutralPose`
    (``neutral``) and smoothed (:class:`~app.headpose.smoothing.AngleSmoothing`). The call is
    thread-safe.

    Parameters
    ----------
    smoothing : OneEuroConfig or None
        One-Euro filter settings for the angles; None disables smoothing. The filter is reset
        whenever the face is lost.
    intrinsics : array, shape (3, 3), optional
        Calibrated camera matrix in pixels. Default: :func:`app.headpose.pose.camera_matrix`
        of each frame's size (focal length = image width, principal point at the centre).
    min_presence : float
        Face-presence probability below which tracking is given up.
    min_detection_score : float
        Detector score below which a detection is ignored.
    min_face_size : float
        Faces narrower than this many pixels are reported as "no face": too few pixels for a
        trustworthy pose.
    line_of_sight : bool
        True: zero means facing the camera wherever the face is in the image (the neutral frame
        looks along the line from the head to the camera). False: zero means facing along the
        camera's optical axis.
    search_tiles : bool
        When the whole-frame detection finds no face, also scan overlapping tiles, which finds
        faces down to about 35 pixels wide instead of about 70 in a 640x480 frame (more detector
        runs, only while no face is tracked). See
        :meth:`app.headpose.detector.FaceDetector.detect_tiled`.
    models : ModelPaths, optional
        Model files; default :func:`app.headpose.models.locate_models`.

    Attributes
    ----------
    tracker : FaceTracker
        Where the face is: ``tracking``, ``n_detections`` (frames the detector ran on).
    neutral : NeutralPose
        What zero means.
    n_frames : int
        Frames processed (for diagnostics and tests).
    """

    def __init__(
        self,
        smoothing: OneEuroConfig | None = DEFAULT_SMOOTHING,
        intrinsics: np.ndarray | None = None,
        *,
        min_presence: float = 0.5,
        min_detection_score: float = 0.5,
        min_face_size: float = 32.0,
        line_of_sight: bool = True,
        search_tiles: bool = True,
        models: ModelPaths | None = None,
    ) -> None:
        self.smoothing = AngleSmoothing(smoothing)
        self.tracker = FaceTracker(
            models,
            min_presence=min_presence,
            min_detection_score=min_detection_score,
            min_face_size=min_face_size,
            search_tiles=search_tiles,
        )
        self.intrinsics = None if intrinsics is None else check_intrinsics(intrinsics)
        self.neutral = NeutralPose(line_of_sight)
        self._lock = threading.Lock()
        self._last_output: np.ndarray | None = None  # (roll, pitch, yaw) last returned
        self.n_frames = 0

    # -- state -------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget tracking, smoothing and timing state (a new sequence starts).

        The neutral-pose calibration is kept; see :meth:`clear_neutral`.
        """
        with self._lock:
            self._lose_face()
            self.smoothing.restart()

    def calibrate_neutral(self) -> None:
        """Make the current head pose the zero of roll, pitch and yaw.

        The current pose is the last sample returned (smoothed, if smoothing is on).

        Raises
        ------
        RuntimeError
            When the last processed frame had no face.
        """
        with self._lock:
            if self._last_output is None:
                raise RuntimeError("cannot calibrate the neutral pose: no face in the last frame")
            self.neutral.calibrate(self._last_output)
            self._last_output = np.zeros(3)
            self.smoothing.forget()

    def clear_neutral(self) -> None:
        """Drop the neutral-pose calibration: zero is facing the camera again."""
        with self._lock:
            self.neutral.clear()
            self.smoothing.forget()

    def _lose_face(self) -> None:
        self.tracker.lose()
        self._last_output = None
        self.smoothing.forget()

    # -- processing --------------------------------------------------------------------------

    def process(self, frame_bgr: np.ndarray, t: float) -> HeadPoseSample:
        """Estimate the head pose in the next frame.

        Parameters
        ----------
        frame_bgr : array, shape (height, width, 3), uint8
            BGR frame (a grey (height, width) frame is accepted too).
        t : float
            The frame's time in seconds. With smoothing on, it must increase from frame to frame.

        Returns
        -------
        HeadPoseSample
            With ``face_found=False`` when there is no usable face in this frame.
        """
        frame = check_frame(frame_bgr)
        t = float(t)
        if not math.isfinite(t):
            raise ValueError(f"timestamp must be finite, got {t}")
        with self._lock:
            self.smoothing.admit(t)
            self.n_frames += 1
            result = self.tracker.find(frame)
            if result is None:
                self._lose_face()
                return HeadPoseSample.no_face(t)
            return self._pose(frame, result, t)

    def _pose(self, frame: np.ndarray, result: LandmarkResult, t: float) -> HeadPoseSample:
        height, width = frame.shape[:2]
        intrinsics = self.intrinsics
        if intrinsics is None:
            intrinsics = camera_matrix(width, height)
        landmarks = result.landmarks
        rotation, translation, rms = solve_head_pose(landmarks[MODEL_LANDMARKS], intrinsics)
        angles = self.smoothing(self.neutral.angles(rotation, translation), t)
        self._last_output = angles
        self.tracker.follow(landmarks)
        roll, pitch, yaw = (float(a) for a in angles)
        return HeadPoseSample(
            t=t,
            face_found=True,
            roll=roll,
            pitch=pitch,
            yaw=yaw,
            confidence=fit_confidence(result.presence, rms, landmarks),
            landmarks=landmarks,
        )
