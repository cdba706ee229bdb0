"""MediaPipe's 468-point face landmark model on OpenCV's DNN module, and its regions of interest.

The network takes a 192x192 RGB crop scaled to [0, 1], centred on the face and rotated so that the
eyes are level, and returns 468 landmarks ``(x, y, z)`` in crop pixels (z: relative depth, unused
here) and a face-presence logit. The crop (the ROI) comes either from a detection (box centre,
1.5 x the longer box side, eye key points for the angle) or, while tracking, from the previous
frame's landmarks (their bounding box in the eye-aligned frame, 1.5 x its longer side), as in
MediaPipe's face mesh graph.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from app.headpose.detector import FaceDetection
from app.headpose.face_model import LEFT_EYE_OUTER, RIGHT_EYE_OUTER
from app.headpose.models import LANDMARK_OUTPUTS, load_network

INPUT_SIZE = 192
N_LANDMARKS = 468
#: ROI side / face size, from MediaPipe's face mesh graph.
ROI_SCALE = 1.5


@dataclass(frozen=True)
class FaceRoi:
    """A square, rotated region of a frame.

    Attributes
    ----------
    centre : array, shape (2,)
        Pixels.
    size : float
        Side length in pixels.
    angle : float
        Radians; the ROI's x axis is ``(cos angle, sin angle)`` in image coordinates (y down), so
        a positive angle is a clockwise turn on screen.
    """

    centre: np.ndarray
    size: float
    angle: float

    def crop_to_frame(self) -> np.ndarray:
        """Affine map from crop pixels to frame pixels.

        Returns
        -------
        array, shape (2, 3)
        """
        c, s = np.cos(self.angle), np.sin(self.angle)
        linear = (self.size / INPUT_SIZE) * np.array([[c, -s], [s, c]])
        offset = self.centre - linear @ np.array([INPUT_SIZE / 2, INPUT_SIZE / 2])
        return np.column_stack([linear, offset])


def roi_from_detection(detection: FaceDetection) -> FaceRoi:
    """The landmark model's ROI for a detected face."""
    right_eye, left_eye = detection.keypoints[0], detection.keypoints[1]
    dx, dy = left_eye - right_eye
    size = ROI_SCALE * float(max(detection.box[2], detection.box[3]))
    return FaceRoi(centre=detection.box[:2].copy(), size=size, angle=float(np.arctan2(dy, dx)))


def roi_from_landmarks(landmarks: np.ndarray) -> FaceRoi:
    """The next frame's ROI from this frame's landmarks.

    Parameters
    ----------
    landmarks : array, shape (468, 2)
        Pixels.
    """
    dx, dy = landmarks[LEFT_EYE_OUTER] - landmarks[RIGHT_EYE_OUTER]
    angle = float(np.arctan2(dy, dx))
    c, s = np.cos(angle), np.sin(angle)
    to_roi = np.array([[c, s], [-s, c]])  # frame -> eye-aligned axes
    aligned = landmarks @ to_roi.T
    lo, hi = aligned.min(axis=0), aligned.max(axis=0)
    centre = to_roi.T @ ((lo + hi) / 2)
    size = ROI_SCALE * float(np.max(hi - lo))
    return FaceRoi(centre=centre, size=size, angle=angle)


@dataclass(frozen=True)
class LandmarkResult:
    """Landmarks of one face.

    Attributes
    ----------
    landmarks : array, shape (468, 2)
        Frame pixels.
    presence : float
        Face-presence probability in [0, 1].
    """

    landmarks: np.ndarray
    presence: float


class FaceLandmarker:
    """Run the face landmark model on an ROI of a BGR frame.

    Parameters
    ----------
    model_path : path-like
        The ``face_landmark.tflite`` file.
    """

    def __init__(self, model_path) -> None:
        self.net = load_network(model_path, LANDMARK_OUTPUTS)

    def crop(self, frame_bgr: np.ndarray, roi: FaceRoi) -> np.ndarray:
        """The model's input crop, BGR, shape (192, 192, 3)."""
        return cv2.warpAffine(
            frame_bgr,
            roi.crop_to_frame(),
            (INPUT_SIZE, INPUT_SIZE),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(0, 0, 0),
        )

    def run(self, frame_bgr: np.ndarray, roi: FaceRoi) -> LandmarkResult:
        """Landmarks of the face in ``roi``.

        Parameters
        ----------
        frame_bgr : array, shape (height, width, 3), uint8
        roi : FaceRoi

        Returns
        -------
        LandmarkResult
        """
        blob = cv2.dnn.blobFromImage(self.crop(frame_bgr, roi), scalefactor=1 / 255.0, swapRB=True)
        self.net.setInput(blob)
        raw, logit = self.net.forward(list(LANDMARK_OUTPUTS))
        crop_xy = raw.reshape(N_LANDMARKS, 3)[:, :2].astype(np.float64)
        affine = roi.crop_to_frame()
        landmarks = crop_xy @ affine[:, :2].T + affine[:, 2]
        z = float(np.clip(logit.reshape(-1)[0], -100.0, 100.0))
        return LandmarkResult(landmarks=landmarks, presence=float(1.0 / (1.0 + np.exp(-z))))
