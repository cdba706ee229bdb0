"""The head-pose estimator: detection, landmark tracking, PnP and smoothing, frame by frame."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from app.headpose.detector import FaceDetector
from app.headpose.face_model import MODEL_LANDMARKS
from app.headpose.filter import OneEuroConfig, OneEuroFilter
from app.headpose.landmarks import (
    FaceLandmarker,
    FaceRoi,
    LandmarkResult,
    roi_from_detection,
    roi_from_landmarks,
)
from app.headpose.models import ModelPaths, locate_models
from app.headpose.pose import (
    camera_matrix,
    check_intrinsics,
    euler_zyx,
    neutral_frame,
    rotation_zyx,
    solve_head_pose,
)

#: Smoothing used when the caller does not choose: tuned for 30-60 fps, angles in radians.
DEFAULT_SMOOTHING = OneEuroConfig(min_cutoff=1.0, beta=4.0, d_cutoff=1.0)
#: Reprojection error, as a fraction of the face size, at which the confidence falls to 1/e.
FIT_TOLERANCE = 0.06


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

    The models are loaded once. :meth:`process` takes frames in time order: after a face is
    found, the next frame's landmark ROI comes from this frame's landmarks (tracking); the
    detector runs only on the first frame and whenever the landmark model's face-presence score
    drops below ``min_presence`` (the face was lost). The call is thread-safe.

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
        runs, only while no face is tracked). See :meth:`FaceDetector.detect_tiled`.
    models : ModelPaths, optional
        Model files; default :func:`app.headpose.models.locate_models`.
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
        if smoothing is not None and not isinstance(smoothing, OneEuroConfig):
            raise ValueError(f"smoothing must be a OneEuroConfig or None, got {smoothing!r}")
        if not 0.0 < min_presence < 1.0:
            raise ValueError(f"min_presence must be in (0, 1), got {min_presence}")
        if not (math.isfinite(min_face_size) and min_face_size >= 0):
            raise ValueError(f"min_face_size must be >= 0 pixels, got {min_face_size}")
        paths = locate_models() if models is None else models
        self.detector = FaceDetector(paths.detector, min_score=min_detection_score)
        self.landmarker = FaceLandmarker(paths.landmarks)
        self.intrinsics = None if intrinsics is None else check_intrinsics(intrinsics)
        self.min_presence = float(min_presence)
        self.min_face_size = float(min_face_size)
        self.line_of_sight = bool(line_of_sight)
        self.search_tiles = bool(search_tiles)
        self._filter = None if smoothing is None else OneEuroFilter(smoothing)
        self._lock = threading.Lock()
        self._roi: FaceRoi | None = None
        self._last_t: float | None = None
        self._neutral = np.eye(3)  # calibrated neutral, relative to the geometric neutral frame
        self._last_output: np.ndarray | None = None  # (roll, pitch, yaw) last returned
        #: Frames on which the detector ran, and frames processed (for diagnostics and tests).
        self.n_detections = 0
        self.n_frames = 0

    # -- state -------------------------------------------------------------------------------

    @property
    def tracking(self) -> bool:
        """True when the next frame will be tracked from the last landmarks."""
        return self._roi is not None

    def reset(self) -> None:
        """Forget tracking, smoothing and timing state (a new sequence starts).

        The neutral-pose calibration is kept; see :meth:`clear_neutral`.
        """
        with self._lock:
            self._lose_face()
            self._last_t = None

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
            self._neutral = self._neutral @ rotation_zyx(*self._last_output)
            self._last_output = np.zeros(3)
            if self._filter is not None:
                self._filter.reset()

    def clear_neutral(self) -> None:
        """Drop the neutral-pose calibration: zero is facing the camera again."""
        with self._lock:
            self._neutral = np.eye(3)
            if self._filter is not None:
                self._filter.reset()

    def _lose_face(self) -> None:
        self._roi = None
        self._last_output = None
        if self._filter is not None:
            self._filter.reset()

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
            if self._filter is not None and self._last_t is not None and t <= self._last_t:
                raise ValueError(
                    f"timestamps must increase when smoothing is on: got t={t} after "
                    f"t={self._last_t} (call reset() to start a new sequence)"
                )
            self._last_t = t
            self.n_frames += 1
            result = self._find_landmarks(frame)
            if result is None:
                self._lose_face()
                return HeadPoseSample.no_face(t)
            return self._pose(frame, result, t)

    def _find_landmarks(self, frame: np.ndarray) -> LandmarkResult | None:
        if self._roi is not None:
            result = self.landmarker.run(frame, self._roi)
            if result.presence >= self.min_presence and self._large_enough(result):
                return result
            self._roi = None
        self.n_detections += 1
        detections = self.detector.detect(frame)
        if not detections and self.search_tiles:
            detections = self.detector.detect_tiled(frame)
        for detection in detections:
            if max(detection.box[2], detection.box[3]) < self.min_face_size:
                continue
            result = self.landmarker.run(frame, roi_from_detection(detection))
            if result.presence >= self.min_presence and self._large_enough(result):
                return result
            break  # only the best detection gets a landmark pass: keep the cost bounded
        return None

    def _large_enough(self, result: LandmarkResult) -> bool:
        extent = result.landmarks.max(axis=0) - result.landmarks.min(axis=0)
        return float(np.max(extent)) >= self.min_face_size

    def _pose(self, frame: np.ndarray, result: LandmarkResult, t: float) -> HeadPoseSample:
        height, width = frame.shape[:2]
        intrinsics = self.intrinsics
        if intrinsics is None:
            intrinsics = camera_matrix(width, height)
        landmarks = result.landmarks
        rotation, translation, rms = solve_head_pose(landmarks[MODEL_LANDMARKS], intrinsics)
        neutral = neutral_frame(translation if self.line_of_sight else None)
        relative = self._neutral.T @ neutral.T @ rotation
        angles = np.array(euler_zyx(relative))
        if self._filter is not None:
            angles = self._filter(angles, t)
        self._last_output = angles
        self._roi = roi_from_landmarks(landmarks)
        face_size = float(np.max(landmarks.max(axis=0) - landmarks.min(axis=0)))
        fit = math.exp(-((rms / (FIT_TOLERANCE * face_size)) ** 2))
        confidence = float(np.clip(result.presence * fit, 0.0, 1.0))
        roll, pitch, yaw = (float(a) for a in angles)
        return HeadPoseSample(
            t=t,
            face_found=True,
            roll=roll,
            pitch=pitch,
            yaw=yaw,
            confidence=confidence,
            landmarks=landmarks,
        )
