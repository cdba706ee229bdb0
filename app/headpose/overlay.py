"""Preview drawing: the landmarks, the head axes and the angles on a copy of the frame."""

from __future__ import annotations

import cv2
import numpy as np

from app.headpose.estimator import HeadPoseSample, check_frame
from app.headpose.face_model import NOSE_TIP
from app.headpose.pose import R_CAMERA_FROM_NEUTRAL, rotation_zyx

#: BGR colours of the head axes: forward red, left green, up blue.
AXIS_COLOURS = ((0, 0, 255), (0, 200, 0), (255, 64, 0))
LANDMARK_COLOUR = (80, 255, 255)


def draw_overlay(frame_bgr: np.ndarray, sample: HeadPoseSample | None) -> np.ndarray:
    """Draw a head-pose sample on a copy of its frame.

    The landmarks are dots; the head axes (x forward red, y left green, z up blue) start at the
    nose tip, drawn as the reported roll, pitch and yaw seen from the camera (orthographic, half
    a face long: the forward axis is a dot when the partner faces the camera). The angles are
    written in degrees at the top left, or "no face".

    Parameters
    ----------
    frame_bgr : array, shape (height, width, 3), uint8
    sample : HeadPoseSample or None
        None (nothing estimated yet) draws "no face" too.

    Returns
    -------
    array, shape (height, width, 3), uint8
        A new BGR image; the input is not modified.
    """
    image = check_frame(frame_bgr).copy()
    height, width = image.shape[:2]
    scale = max(0.4, min(width, height) / 800)
    if sample is None or not sample.face_found or sample.landmarks is None:
        _label(image, "no face", scale)
        return image
    points = np.rint(sample.landmarks).astype(np.intp)
    inside = (
        (points[:, 0] >= 0)
        & (points[:, 0] < width - 1)
        & (points[:, 1] >= 0)
        & (points[:, 1] < height - 1)
    )
    xs, ys = points[inside, 0], points[inside, 1]
    for dx in (0, 1):
        for dy in (0, 1):
            image[ys + dy, xs + dx] = LANDMARK_COLOUR
    extent = sample.landmarks.max(axis=0) - sample.landmarks.min(axis=0)
    length = 0.5 * float(np.max(extent))
    axes = R_CAMERA_FROM_NEUTRAL @ rotation_zyx(sample.roll, sample.pitch, sample.yaw)
    origin = sample.landmarks[NOSE_TIP]
    thickness = max(1, round(2 * scale))
    for k in (2, 1, 0):  # forward last, on top
        tip = origin + length * axes[:2, k]
        cv2.line(image, _pt(origin), _pt(tip), AXIS_COLOURS[k], thickness, cv2.LINE_AA)
    text = (
        f"roll {np.degrees(sample.roll):+5.1f}  pitch {np.degrees(sample.pitch):+5.1f}  "
        f"yaw {np.degrees(sample.yaw):+5.1f} deg  conf {sample.confidence:.2f}"
    )
    _label(image, text, scale)
    return image


def _pt(xy: np.ndarray) -> tuple[int, int]:
    return int(round(float(xy[0]))), int(round(float(xy[1])))


def _label(image: np.ndarray, text: str, scale: float) -> None:
    x, y = 8, int(8 + 22 * scale)
    thickness = max(1, round(2 * scale))
    # a dark outline from shifted copies: a thicker stroke would change the glyph advance
    for dx, dy in ((-1, -1), (1, -1), (-1, 1), (1, 1), (0, 2), (2, 0)):
        cv2.putText(
            image,
            text,
            (x + dx, y + dy),
            cv2.FONT_HERSHEY_SIMPLEX,
            scale,
            (0, 0, 0),
            thickness,
            cv2.LINE_AA,
        )
    cv2.putText(
        image,
        text,
        (x, y),
        cv2.FONT_HERSHEY_SIMPLEX,
        scale,
        (255, 255, 255),
        thickness,
        cv2.LINE_AA,
    )
