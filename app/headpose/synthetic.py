"""Synthetic camera frames of a face with a known motion, for tests and benchmarks.

A face photograph is treated as a flat card in front of a pinhole camera. Turning the card in 3D
about axes through the face centre, with the package's head-frame convention, and projecting it
gives a frame in which the face turns by a known yaw and pitch; turning the image in its plane
gives a known roll. A flat card is not a head (the nose does not move against the cheeks), so
landmark-based yaw and pitch follow such turns with the right sign but a smaller magnitude.
"""

from __future__ import annotations

import cv2
import numpy as np

from app.headpose.pose import R_CAMERA_FROM_NEUTRAL, camera_matrix, rotation_zyx

#: Pixel between the eyes and the mouth of ``skimage.data.astronaut()`` (512x512, public domain),
#: the face the tests and the benchmark use.
ASTRONAUT_FACE_CENTRE = (225.0, 125.0)


def place_face(
    image_bgr: np.ndarray,
    face_centre: tuple[float, float],
    frame_size: tuple[int, int] = (640, 480),
    centre: tuple[float, float] | None = None,
    roll_deg: float = 0.0,
    scale: float = 1.0,
) -> np.ndarray:
    """Put a face photograph into a frame, turned in the image plane.

    Parameters
    ----------
    image_bgr : array, shape (height, width, 3), uint8
        The photograph.
    face_centre : (float, float)
        Pixel of the photograph that goes to ``centre``.
    frame_size : (int, int)
        Output ``(width, height)``.
    centre : (float, float), optional
        Where the face centre lands; default the frame centre.
    roll_deg : float
        Counter-clockwise rotation on screen about the face centre, degrees: the head's roll.
    scale : float
        Magnification.

    Returns
    -------
    array, shape (frame_height, frame_width, 3), uint8
    """
    width, height = frame_size
    target = (width / 2.0, height / 2.0) if centre is None else centre
    matrix = cv2.getRotationMatrix2D(face_centre, roll_deg, scale)
    matrix[:, 2] += np.asarray(target, dtype=np.float64) - np.asarray(face_centre)
    return cv2.warpAffine(image_bgr, matrix, (width, height), borderMode=cv2.BORDER_REPLICATE)


def turn_face(
    frame_bgr: np.ndarray,
    face_centre: tuple[float, float],
    yaw_deg: float = 0.0,
    pitch_deg: float = 0.0,
    focal: float | None = None,
) -> np.ndarray:
    """Turn a frontal face card in 3D about its centre and reproject it.

    Parameters
    ----------
    frame_bgr : array, shape (height, width, 3), uint8
        A frame whose face is frontal (the card faces the camera).
    face_centre : (float, float)
        The card's pivot in pixels.
    yaw_deg, pitch_deg : float
        The turn in the head-frame convention, degrees: positive yaw turns the face to its left
        (its right half, on the image left, comes closer), positive pitch tips it down.
    focal : float, optional
        Focal length in pixels; default the frame width. The card sits at the depth where one
        card unit is one pixel.

    Returns
    -------
    array, shape (height, width, 3), uint8
    """
    height, width = frame_bgr.shape[:2]
    k = camera_matrix(width, height, focal)
    depth = k[0, 0]
    turn = R_CAMERA_FROM_NEUTRAL @ rotation_zyx(0.0, np.radians(pitch_deg), np.radians(yaw_deg))
    turn = turn @ R_CAMERA_FROM_NEUTRAL.T
    corners = np.array([[0, 0], [width, 0], [width, height], [0, height]], dtype=np.float64)
    k_inv = np.linalg.inv(k)
    rays = np.column_stack([corners, np.ones(4)]) @ k_inv.T
    pivot = depth * (k_inv @ np.array([face_centre[0], face_centre[1], 1.0]))
    points = pivot + (depth * rays - pivot) @ turn.T
    if np.any(points[:, 2] <= 0):
        raise ValueError("the turn puts part of the frame behind the camera: use a smaller angle")
    projected = (points @ k.T)[:, :2] / points[:, 2:3]
    homography = cv2.getPerspectiveTransform(
        corners.astype(np.float32), projected.astype(np.float32)
    )
    return cv2.warpPerspective(
        frame_bgr,
        homography,
        (width, height),
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=(128, 128, 128),
    )
