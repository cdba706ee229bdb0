"""Head orientation from 2D landmarks: PnP fit and the conversion to roll, pitch and yaw.

Frames (see the package docstring for the convention):

- camera (OpenCV): x right, y down, z forward, out of the lens towards the partner;
- head: x forward out of the face, y to the partner's left, z up;
- neutral: the head frame of a partner who faces the camera. For a partner on the optical axis it
  is ``R_CAMERA_FROM_NEUTRAL``: forward = -z_cam, left = +x_cam (the image right, the camera
  not being mirrored), up = -y_cam. With ``line_of_sight=True`` the neutral frame is instead
  turned so that its forward axis points from the head to the camera centre, so that zero means
  "looking at the camera" wherever the face is in the image.

The orientation is ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``, the head frame relative to the
neutral frame: ``R = R_camera_from_neutral.T @ R_camera_from_head``.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from app.headpose.face_model import MODEL_POINTS

#: Columns: the neutral head axes (forward, left, up) in camera coordinates.
R_CAMERA_FROM_NEUTRAL = np.array(
    [
        [0.0, 1.0, 0.0],
        [0.0, 0.0, -1.0],
        [-1.0, 0.0, 0.0],
    ]
)
R_CAMERA_FROM_NEUTRAL.setflags(write=False)


def camera_matrix(width: int, height: int, focal: float | None = None) -> np.ndarray:
    """Approximate pinhole intrinsics for an uncalibrated camera.

    Parameters
    ----------
    width, height : int
        Image size in pixels.
    focal : float, optional
        Focal length in pixels. Default: ``width`` (a horizontal field of view of about 53
        degrees, typical of webcams).

    Returns
    -------
    array, shape (3, 3)
        ``K`` with the principal point at the image centre.
    """
    if width <= 0 or height <= 0:
        raise ValueError(f"image size must be positive, got {width}x{height}")
    f = float(width) if focal is None else float(focal)
    if not np.isfinite(f) or f <= 0:
        raise ValueError(f"focal length must be a positive number of pixels, got {focal}")
    return np.array([[f, 0.0, width / 2.0], [0.0, f, height / 2.0], [0.0, 0.0, 1.0]])


def check_intrinsics(intrinsics: np.ndarray) -> np.ndarray:
    """Validate a user-given camera matrix.

    Parameters
    ----------
    intrinsics : array_like, shape (3, 3)
        ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` in pixels.

    Returns
    -------
    array, shape (3, 3)
        A float64 copy.
    """
    k = np.array(intrinsics, dtype=np.float64)
    if k.shape != (3, 3) or not np.all(np.isfinite(k)):
        raise ValueError(f"intrinsics must be a finite 3x3 camera matrix, got shape {k.shape}")
    if k[0, 0] <= 0 or k[1, 1] <= 0 or not np.allclose(k[2], [0.0, 0.0, 1.0]):
        raise ValueError("intrinsics must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0")
    return k


def rotation_zyx(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Returns
    -------
    array, shape (3, 3)
    """
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx


def euler_zyx(rotation: np.ndarray) -> tuple[float, float, float]:
    """Inverse of :func:`rotation_zyx`.

    Parameters
    ----------
    rotation : array, shape (3, 3)

    Returns
    -------
    roll, pitch, yaw : float
        Radians; pitch in [-pi/2, pi/2], roll and yaw in (-pi, pi].
    """
    r = np.asarray(rotation, dtype=np.float64)
    if r.shape != (3, 3):
        raise ValueError(f"rotation must have shape (3, 3), got {r.shape}")
    pitch = float(np.arctan2(-r[2, 0], np.hypot(r[0, 0], r[1, 0])))
    yaw = float(np.arctan2(r[1, 0], r[0, 0]))
    roll = float(np.arctan2(r[2, 1], r[2, 2]))
    return roll, pitch, yaw


def neutral_frame(translation: np.ndarray | None) -> np.ndarray:
    """The neutral head frame in camera coordinates.

    Parameters
    ----------
    translation : array, shape (3,), optional
        Head position in the camera frame. When given, the neutral forward axis points from the
        head to the camera centre and the neutral up axis is the camera's up (-y) made
        orthogonal to it. When None, :data:`R_CAMERA_FROM_NEUTRAL`.

    Returns
    -------
    array, shape (3, 3)
        Columns: neutral forward, left, up axes in camera coordinates.
    """
    if translation is None:
        return R_CAMERA_FROM_NEUTRAL.copy()
    t = np.asarray(translation, dtype=np.float64).reshape(3)
    norm = np.linalg.norm(t)
    if not np.isfinite(norm) or norm == 0.0:
        return R_CAMERA_FROM_NEUTRAL.copy()
    forward = -t / norm
    up = np.array([0.0, -1.0, 0.0])
    up = up - (up @ forward) * forward
    up_norm = np.linalg.norm(up)
    if up_norm < 1e-6:  # head straight above or below the camera: keep the optical-axis frame
        return R_CAMERA_FROM_NEUTRAL.copy()
    up /= up_norm
    left = np.cross(up, forward)
    return np.column_stack([forward, left, up])


def solve_head_pose(
    image_points: np.ndarray, intrinsics: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """Fit the 3D face model to its landmarks with ``cv2.solvePnP``.

    SQPnP gives the global minimum of its algebraic error without an initial guess; a
    Levenberg-Marquardt refinement then minimises the reprojection error.

    Parameters
    ----------
    image_points : array, shape (n_points, 2)
        Pixel positions of :data:`app.headpose.face_model.MODEL_LANDMARKS`, in that order.
    intrinsics : array, shape (3, 3)
        Camera matrix (no lens distortion).

    Returns
    -------
    rotation : array, shape (3, 3)
        ``R_camera_from_head``.
    translation : array, shape (3,)
        Head-model origin in the camera frame, cm.
    rms_px : float
        Root-mean-square reprojection error in pixels.
    """
    points = np.ascontiguousarray(image_points, dtype=np.float64).reshape(-1, 1, 2)
    if points.shape[0] != MODEL_POINTS.shape[0]:
        raise ValueError(f"expected {MODEL_POINTS.shape[0]} image points, got {points.shape[0]}")
    object_points = np.ascontiguousarray(MODEL_POINTS).reshape(-1, 1, 3)
    ok, rvec, tvec = cv2.solvePnP(object_points, points, intrinsics, None, flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        raise ValueError("solvePnP found no pose for these landmarks")
    rvec, tvec = cv2.solvePnPRefineLM(object_points, points, intrinsics, None, rvec, tvec)
    projected, _ = cv2.projectPoints(object_points, rvec, tvec, intrinsics, None)
    rms = float(np.sqrt(np.mean(np.sum((projected - points) ** 2, axis=-1))))
    rotation, _ = cv2.Rodrigues(rvec)
    return rotation, tvec.reshape(3), rms


#: Reprojection error, as a fraction of the face size, at which the fit's quality falls to 1/e.
FIT_TOLERANCE = 0.06


def fit_confidence(presence: float, rms_px: float, landmarks: np.ndarray) -> float:
    """How much a head pose can be trusted, in [0, 1]: the landmark model's face-presence
    probability times the quality of the PnP fit, ``exp(-(rms / (FIT_TOLERANCE * size))^2)``.

    Parameters
    ----------
    presence : float
        The landmark model's face-presence probability, in [0, 1].
    rms_px : float
        The fit's root-mean-square reprojection error (:func:`solve_head_pose`), pixels.
    landmarks : array, shape (468, 2)
        The face landmarks, pixels: their extent is the face's size.
    """
    face_size = float(np.max(landmarks.max(axis=0) - landmarks.min(axis=0)))
    fit = math.exp(-((rms_px / (FIT_TOLERANCE * face_size)) ** 2))
    return float(np.clip(presence * fit, 0.0, 1.0))
