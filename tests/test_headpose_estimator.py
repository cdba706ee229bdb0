"""The estimator on a real face with known motions, and on frames without a usable face.

The face is scikit-image's ``astronaut`` (public domain). Roll: the frame is rotated in its plane
by known angles. Yaw and pitch: the face, as a flat card, is turned in 3D about axes through its
centre and reprojected (a homography); a card is not a head, so only the direction and the order
of the estimates are checked, not their size.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.headpose import HeadPoseEstimator, OneEuroConfig, draw_overlay
from app.headpose.pose import camera_matrix
from app.headpose.synthetic import ASTRONAUT_FACE_CENTRE, place_face, turn_face

CENTRE = (320.0, 240.0)


@pytest.fixture(scope="module")
def astronaut() -> np.ndarray:
    from skimage.data import astronaut

    return np.ascontiguousarray(astronaut()[:, :, ::-1])  # BGR


def frontal(astronaut: np.ndarray, **kwargs) -> np.ndarray:
    return place_face(astronaut, ASTRONAUT_FACE_CENTRE, (640, 480), **kwargs)


def settled(estimator: HeadPoseEstimator, frame: np.ndarray, t0: float = 0.0):
    """Process a still frame twice: detection, then one tracked frame."""
    estimator.process(frame, t0)
    return estimator.process(frame, t0 + 0.033)


def test_frontal_face_is_found(installed, astronaut):
    estimator = HeadPoseEstimator(smoothing=None)
    sample = settled(estimator, frontal(astronaut, scale=1.5))
    assert sample.face_found
    assert sample.landmarks.shape == (468, 2)
    assert 0.3 < sample.confidence <= 1.0
    assert np.all(np.abs(np.degrees(sample.angles)) < 8)  # a nearly frontal photograph
    nose = sample.landmarks[1]
    assert np.all(np.abs(nose - CENTRE) < 40)


def test_roll_from_in_plane_rotation(installed, astronaut):
    estimator = HeadPoseEstimator(smoothing=None)
    settled(estimator, frontal(astronaut, scale=1.5))
    estimator.calibrate_neutral()
    errors = []
    for roll_deg in np.arange(-30, 31, 5):
        estimator.reset()  # each angle from a fresh detection; the calibration stays
        sample = settled(estimator, frontal(astronaut, scale=1.5, roll_deg=float(roll_deg)))
        assert sample.face_found, roll_deg
        errors.append(np.degrees(sample.roll) - roll_deg)
        assert abs(np.degrees(sample.pitch)) < 5 and abs(np.degrees(sample.yaw)) < 5
    assert np.max(np.abs(errors)) < 3.0, np.round(errors, 2)


@pytest.mark.parametrize("axis", ["yaw", "pitch"])
def test_turning_the_face_changes_yaw_and_pitch_with_the_right_sign(installed, astronaut, axis):
    focal = 320.0  # a wide lens, so that the card's perspective is strong
    base = frontal(astronaut, scale=2.0)
    angles = [-40, -30, -20, -10, 0, 10, 20, 30, 40]
    estimates = []
    for angle in angles:
        frame = turn_face(base, CENTRE, focal=focal, **{f"{axis}_deg": angle})
        estimator = HeadPoseEstimator(smoothing=None, intrinsics=camera_matrix(640, 480, focal))
        sample = settled(estimator, frame)
        assert sample.face_found, angle
        estimates.append(np.degrees(getattr(sample, axis)))
    estimates = np.array(estimates)
    assert np.all(np.diff(estimates) > 0), np.round(estimates, 2)
    frontal_estimate = estimates[angles.index(0)]
    assert estimates[0] < frontal_estimate - 3 and estimates[-1] > frontal_estimate + 3


def test_no_face_in_blank_noise_and_tiny_faces(installed, astronaut):
    rng = np.random.default_rng(0)
    frames = {
        "black": np.zeros((480, 640, 3), np.uint8),
        "grey": np.full((480, 640, 3), 128, np.uint8),
        "noise": rng.integers(0, 256, size=(480, 640, 3), dtype=np.uint8),
        "tiny face": frontal(astronaut, scale=0.15),  # a face about 15 pixels wide
        "small image": np.zeros((16, 16, 3), np.uint8),
    }
    estimator = HeadPoseEstimator()
    for i, (name, frame) in enumerate(frames.items()):
        sample = estimator.process(frame, float(i))
        assert not sample.face_found, name
        assert (sample.roll, sample.pitch, sample.yaw, sample.confidence) == (0, 0, 0, 0)
        assert sample.landmarks is None
        assert not estimator.tracker.tracking
        assert draw_overlay(frame, sample).shape == frame.shape


def test_small_faces_are_found_by_the_tile_search(installed, astronaut):
    frame = frontal(astronaut, scale=0.5, centre=(120.0, 100.0))  # a face about 45 pixels wide
    assert not HeadPoseEstimator(search_tiles=False).process(frame, 0.0).face_found
    assert HeadPoseEstimator().process(frame, 0.0).face_found


def test_tracking_runs_the_detector_once_and_redetects_after_loss(installed, astronaut):
    estimator = HeadPoseEstimator()
    blank = np.zeros((480, 640, 3), np.uint8)
    t = 0.0
    for i in range(20):  # the face drifts and tilts
        frame = frontal(astronaut, scale=1.5, centre=(300.0 + 3 * i, 240.0), roll_deg=0.5 * i)
        t += 1 / 30
        assert estimator.process(frame, t).face_found
    assert estimator.tracker.n_detections == 1
    assert estimator.tracker.tracking
    t += 1 / 30
    lost = estimator.process(blank, t)  # no stale angle once the face is gone
    assert not lost.face_found and lost.landmarks is None and not estimator.tracker.tracking
    with pytest.raises(RuntimeError, match="no face"):
        estimator.calibrate_neutral()
    t += 1 / 30
    again = estimator.process(frontal(astronaut, scale=1.5), t)
    assert again.face_found
    assert estimator.tracker.n_detections == 3  # the blank frame and the frame after it


def test_smoothing_is_reset_when_the_face_is_lost(installed, astronaut):
    smooth = HeadPoseEstimator(smoothing=OneEuroConfig(min_cutoff=0.05, beta=0.0))
    raw = HeadPoseEstimator(smoothing=None)
    tilted = frontal(astronaut, scale=1.5, roll_deg=25.0)
    level = frontal(astronaut, scale=1.5)
    blank = np.zeros((480, 640, 3), np.uint8)
    for i, frame in enumerate([tilted, tilted, blank, level, level]):
        s, r = smooth.process(frame, i / 30), raw.process(frame, i / 30)
    # after the loss the heavily smoothed estimate starts afresh at the level face
    assert abs(np.degrees(s.roll - r.roll)) < 2.0


def test_calibrate_neutral_makes_the_current_pose_zero(installed, astronaut):
    estimator = HeadPoseEstimator(smoothing=None)
    tilted = frontal(astronaut, scale=1.5, roll_deg=12.0)
    first = settled(estimator, tilted)
    estimator.calibrate_neutral()
    after = estimator.process(tilted, 0.1)
    assert_allclose(after.angles, 0.0, atol=np.radians(1.0))
    estimator.clear_neutral()
    assert_allclose(estimator.process(tilted, 0.2).angles, first.angles, atol=np.radians(1.0))


def test_bad_frames_and_timestamps_are_rejected(installed, astronaut):
    estimator = HeadPoseEstimator()
    with pytest.raises(ValueError, match="uint8"):
        estimator.process(np.zeros((480, 640, 3), np.float32), 0.0)
    with pytest.raises(ValueError, match="shape"):
        estimator.process(np.zeros((480, 640, 4), np.uint8), 0.0)
    with pytest.raises(ValueError, match="numpy array"):
        estimator.process([[0]], 0.0)
    estimator.process(frontal(astronaut), 1.0)
    with pytest.raises(ValueError, match="timestamps must increase"):
        estimator.process(frontal(astronaut), 1.0)
    with pytest.raises(ValueError, match="intrinsics"):
        HeadPoseEstimator(intrinsics=np.eye(2))
    with pytest.raises(ValueError, match="smoothing"):
        HeadPoseEstimator(smoothing=0.5)
