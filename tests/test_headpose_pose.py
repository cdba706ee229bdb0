"""Head-frame convention: Euler angles, the neutral frame, and PnP on exact projections.

No networks here: the 3D face model is projected with known poses and the fit must recover them,
with the signs of the package convention (positive yaw: nose to the image right; positive pitch:
nose down; positive roll: face counter-clockwise on screen).
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.headpose.face_model import MODEL_LANDMARKS, MODEL_POINTS, NOSE_TIP
from app.headpose.pose import (
    R_CAMERA_FROM_NEUTRAL,
    camera_matrix,
    check_intrinsics,
    euler_zyx,
    neutral_frame,
    rotation_zyx,
    solve_head_pose,
)

K = camera_matrix(640, 480)
HEAD_AT = np.array([0.0, 0.0, 80.0])  # cm in front of the camera, on the optical axis


def project(roll: float, pitch: float, yaw: float, position=HEAD_AT) -> np.ndarray:
    """Image points of the face model for a head pose relative to the optical-axis neutral."""
    rotation = R_CAMERA_FROM_NEUTRAL @ rotation_zyx(roll, pitch, yaw)
    rvec, _ = cv2.Rodrigues(rotation)
    points, _ = cv2.projectPoints(MODEL_POINTS.reshape(-1, 1, 3), rvec, position, K, None)
    return points.reshape(-1, 2)


def nose(points: np.ndarray) -> np.ndarray:
    return points[list(MODEL_LANDMARKS).index(NOSE_TIP)]


def test_euler_round_trip():
    rng = np.random.default_rng(1)
    for roll, pitch, yaw in rng.uniform([-3, -1.5, -3], [3, 1.5, 3], size=(200, 3)):
        assert_allclose(euler_zyx(rotation_zyx(roll, pitch, yaw)), [roll, pitch, yaw], atol=1e-9)


def test_neutral_axes_in_the_camera():
    forward, left, up = R_CAMERA_FROM_NEUTRAL.T
    assert_allclose(forward, [0, 0, -1])  # towards the camera
    assert_allclose(left, [1, 0, 0])  # the partner's left is the image right
    assert_allclose(up, [0, -1, 0])
    assert np.isclose(np.linalg.det(R_CAMERA_FROM_NEUTRAL), 1.0)
    assert_allclose(neutral_frame(HEAD_AT), R_CAMERA_FROM_NEUTRAL, atol=1e-12)
    assert_allclose(neutral_frame(None), R_CAMERA_FROM_NEUTRAL)


def test_line_of_sight_frame_looks_at_the_camera():
    position = np.array([30.0, -10.0, 90.0])
    frame = neutral_frame(position)
    assert_allclose(frame.T @ frame, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(frame), 1.0)
    assert_allclose(frame[:, 0], -position / np.linalg.norm(position))
    assert frame[0, 1] > 0.9  # left still towards the image right


def test_signs_in_the_image():
    frontal = nose(project(0, 0, 0))
    assert nose(project(0, 0, np.radians(20)))[0] > frontal[0] + 5  # yaw: nose to the right
    assert nose(project(0, np.radians(20), 0))[1] > frontal[1] + 5  # pitch: nose down
    points = project(np.radians(20), 0, 0)
    right_eye, left_eye = (points[list(MODEL_LANDMARKS).index(i)] for i in (33, 263))
    assert left_eye[0] > right_eye[0]  # the face's left eye is on the image right
    assert left_eye[1] < right_eye[1] - 3  # roll: the left side goes up (counter-clockwise)


@pytest.mark.parametrize(
    "angles_deg",
    [
        (0, 0, 0),
        (25, 0, 0),
        (-25, 0, 0),
        (0, 20, 0),
        (0, -20, 0),
        (0, 0, 35),
        (0, 0, -35),
        (10, -15, 20),
    ],
)
def test_pnp_recovers_the_pose(angles_deg):
    angles = np.radians(angles_deg)
    rotation, translation, rms = solve_head_pose(project(*angles), K)
    assert rms < 1e-3
    assert_allclose(translation, HEAD_AT, atol=1e-3)
    relative = R_CAMERA_FROM_NEUTRAL.T @ rotation
    assert_allclose(euler_zyx(relative), angles, atol=1e-5)


def test_intrinsics_are_checked():
    with pytest.raises(ValueError, match="3x3"):
        check_intrinsics(np.eye(2))
    with pytest.raises(ValueError, match="fx, fy > 0"):
        check_intrinsics(np.diag([-1.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match="image size"):
        camera_matrix(0, 480)
    with pytest.raises(ValueError, match="image points"):
        solve_head_pose(np.zeros((5, 2)), K)
