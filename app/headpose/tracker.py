"""The face tracker: where the face is, frame after frame.

The detector searches the whole frame (and, when that finds nothing, overlapping tiles) only
while no face is tracked; once the landmark model has found a face, the next frame's landmark
crop comes from this frame's landmarks, and the search starts again only when the model's
face-presence score drops below ``min_presence`` (the face was lost).
"""

from __future__ import annotations

import math

import numpy as np

from app.headpose.detector import FaceDetector
from app.headpose.landmarks import (
    FaceLandmarker,
    FaceRoi,
    LandmarkResult,
    roi_from_detection,
    roi_from_landmarks,
)
from app.headpose.models import ModelPaths, locate_models


class FaceTracker:
    """Find the face's landmarks in a sequence of frames: search, then track.

    Not thread-safe: :class:`app.headpose.estimator.HeadPoseEstimator` calls it under its lock.

    Parameters
    ----------
    models : ModelPaths, optional
        Model files; default :func:`app.headpose.models.locate_models`.
    min_presence : float
        Face-presence probability below which tracking is given up.
    min_detection_score : float
        Detector score below which a detection is ignored.
    min_face_size : float
        Faces narrower than this many pixels are not found: too few pixels for a trustworthy
        pose.
    search_tiles : bool
        When the whole-frame detection finds no face, also scan overlapping tiles, which finds
        faces down to about 35 pixels wide instead of about 70 in a 640x480 frame (more detector
        runs, only while no face is tracked). See :meth:`FaceDetector.detect_tiled`.

    Attributes
    ----------
    n_detections : int
        Frames on which the detector ran (for diagnostics and tests).
    """

    def __init__(
        self,
        models: ModelPaths | None = None,
        *,
        min_presence: float = 0.5,
        min_detection_score: float = 0.5,
        min_face_size: float = 32.0,
        search_tiles: bool = True,
    ) -> None:
        if not 0.0 < min_presence < 1.0:
            raise ValueError(f"min_presence must be in (0, 1), got {min_presence}")
        if not (math.isfinite(min_face_size) and min_face_size >= 0):
            raise ValueError(f"min_face_size must be >= 0 pixels, got {min_face_size}")
        paths = locate_models() if models is None else models
        self.detector = FaceDetector(paths.detector, min_score=min_detection_score)
        self.landmarker = FaceLandmarker(paths.landmarks)
        self.min_presence = float(min_presence)
        self.min_face_size = float(min_face_size)
        self.search_tiles = bool(search_tiles)
        self.n_detections = 0
        self._roi: FaceRoi | None = None  # where the next frame's landmarks are looked for

    @property
    def tracking(self) -> bool:
        """True when the next frame will be tracked from the last landmarks."""
        return self._roi is not None

    def find(self, frame: np.ndarray) -> LandmarkResult | None:
        """The face's landmarks in ``frame`` (BGR, uint8), tracked from the last ones when the
        face is tracked, else searched for; None when no large enough face is present.

        The tracking follows this frame's landmarks once :meth:`follow` is told them.
        """
        if self._roi is not None:
            result = self.landmarker.run(frame, self._roi)
            if self._usable(result):
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
            if self._usable(result):
                return result
            break  # only the best detection gets a landmark pass: keep the cost bounded
        return None

    def follow(self, landmarks: np.ndarray) -> None:
        """Track the next frame from these landmarks, shape (468, 2), frame pixels."""
        self._roi = roi_from_landmarks(landmarks)

    def lose(self) -> None:
        """The face is lost: the next frame is searched."""
        self._roi = None

    def _usable(self, result: LandmarkResult) -> bool:
        """A face present, and large enough."""
        extent = result.landmarks.max(axis=0) - result.landmarks.min(axis=0)
        return result.presence >= self.min_presence and float(np.max(extent)) >= self.min_face_size
