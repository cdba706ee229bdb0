"""Inverse kinematics of the left arm: reach, limits, torso lock, out of reach, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robots.icub.ik import IKResult, rotation_error, solve_ik
from robots.icub.kinematics import N_TORSO, ArmChain, load_arm
from robots.icub.scene import head_rotation


@pytest.fixture(scope="module")
def arm() -> ArmChain:
    return load_arm()


def _check_result(arm: ArmChain, result: IKResult, target: np.ndarray) -> None:
    assert result.q.shape == (arm.n_joints,)
    assert arm.within_limits(result.q), "the IK left the joint limits"
    assert_allclose(result.position, arm.position(result.q), atol=1e-12)
    assert result.position_error_m == pytest.approx(np.linalg.norm(result.position - target))


@pytest.mark.parametrize("lock_torso", [False, True])
def test_reaches_random_reachable_targets(arm: ArmChain, lock_torso: bool) -> None:
    rng = np.random.default_rng(10)
    configurations = arm.random_configurations(rng, 60)
    if lock_torso:
        configurations[:, :N_TORSO] = arm.rest[:N_TORSO]
    reached = 0
    for q in configurations:
        target = arm.position(q)
        result = solve_ik(arm, target, arm.rest, lock_torso=lock_torso)
        _check_result(arm, result, target)
        if not result.reached:
            result = solve_ik(arm, target, arm.rest, lock_torso=lock_torso, restarts=5)
            _check_result(arm, result, target)
        assert result.reached, f"missed {target} by {1e3 * result.position_error_m:.1f} mm"
        assert result.position_error_m <= 1e-4
        reached += result.iterations < 200
    assert reached == len(configurations)


def test_single_solves_from_the_natural_pose_mostly_succeed(arm: ArmChain) -> None:
    rng = np.random.default_rng(11)
    targets = [arm.position(q) for q in arm.random_configurations(rng, 100)]
    hits = [solve_ik(arm, t, arm.rest).position_error_m <= 1e-3 for t in targets]
    assert np.mean(hits) >= 0.95


def test_reaches_position_and_orientation(arm: ArmChain) -> None:
    rng = np.random.default_rng(12)
    hits = 0
    for q in arm.random_configurations(rng, 30):
        pose = arm.fk(q)
        result = solve_ik(arm, pose[:3, 3], arm.rest, pose[:3, :3], restarts=3)
        _check_result(arm, result, pose[:3, 3])
        if result.reached:
            hits += 1
            achieved = arm.fk(result.q)[:3, :3]
            assert np.linalg.norm(rotation_error(pose[:3, :3], achieved)) <= 1e-2
            assert result.orientation_error_rad <= 1e-2
    assert hits >= 28


def test_orientation_error_is_nan_without_an_orientation_target(arm: ArmChain) -> None:
    result = solve_ik(arm, arm.position(arm.rest) + 0.02, arm.rest)
    assert result.reached and np.isnan(result.orientation_error_rad)


def test_respects_joint_limits_even_when_pushed(arm: ArmChain) -> None:
    rng = np.random.default_rng(13)
    # Far targets in every direction push joints onto their limits.
    for direction in rng.normal(size=(20, 3)):
        target = arm.position(arm.rest) + 0.8 * direction / np.linalg.norm(direction)
        for lock in (False, True):
            result = solve_ik(arm, target, arm.rest, lock_torso=lock)
            _check_result(arm, result, target)
    # A warm start outside the limits is clipped first.
    result = solve_ik(arm, arm.position(arm.rest), np.zeros(arm.n_joints))
    assert arm.within_limits(result.q)


def test_locked_torso_keeps_the_torso_joints(arm: ArmChain) -> None:
    q0 = arm.rest.copy()
    q0[:N_TORSO] = [0.2, -0.1, 0.15]
    target = arm.position(q0) + np.array([-0.05, -0.05, 0.03])
    locked = solve_ik(arm, target, q0, lock_torso=True)
    assert locked.reached
    assert_allclose(locked.q[:N_TORSO], q0[:N_TORSO], atol=0)
    free = solve_ik(arm, target, q0)
    assert free.reached
    assert np.abs(free.q[:N_TORSO] - q0[:N_TORSO]).max() > 1e-4


def test_out_of_reach_returns_the_closest_pose(arm: ArmChain) -> None:
    shoulder_height_far = np.array([-1.2, -0.2, 0.15])
    for lock in (False, True):
        result = solve_ik(arm, shoulder_height_far, arm.rest, lock_torso=lock)
        _check_result(arm, result, shoulder_height_far)
        assert not result.reached
        assert result.position_error_m > 0.3
        assert result.iterations < 200, "the solve should stop once the error stops shrinking"
        # The hand is stretched towards the target: no other start gets meaningfully closer.
        best = solve_ik(arm, shoulder_height_far, arm.rest, lock_torso=lock, restarts=10)
        assert result.position_error_m <= best.position_error_m + 0.01
        # It moved towards the target from the start.
        start = np.linalg.norm(arm.position(arm.rest) - shoulder_height_far)
        assert result.position_error_m < start - 0.05


def test_warm_start_along_a_drag_takes_few_iterations(arm: ArmChain) -> None:
    q = arm.rest.copy()
    start = arm.position(q)
    iterations = []
    for k in range(1, 15):
        target = start + np.array([-0.005, -0.008, 0.0]) * k
        result = solve_ik(arm, target, q)
        assert result.reached
        iterations.append(result.iterations)
        assert np.abs(result.q - q).max() < 0.2, "a 1 cm step should not jump the posture"
        q = result.q
    assert np.median(iterations) <= 4


def test_already_at_the_target_takes_no_iteration(arm: ArmChain) -> None:
    result = solve_ik(arm, arm.position(arm.rest), arm.rest)
    assert result.reached and result.iterations == 0
    assert_allclose(result.q, arm.rest)


@pytest.mark.parametrize("target", [[np.nan, 0.0, 0.0], [0.0, np.inf, 0.0], [0.0, 0.0, -np.inf]])
def test_nan_or_inf_targets_are_errors(arm: ArmChain, target: list[float]) -> None:
    with pytest.raises(ValueError, match="NaN or infinite"):
        solve_ik(arm, np.array(target))


def test_bad_inputs_are_clear_errors(arm: ArmChain) -> None:
    p = arm.position(arm.rest)
    with pytest.raises(ValueError, match=r"target_position must have shape \(3,\)"):
        solve_ik(arm, [0.1, 0.2])
    with pytest.raises(ValueError, match="numeric"):
        solve_ik(arm, ["a", "b", "c"])
    with pytest.raises(ValueError, match="q0"):
        solve_ik(arm, p, np.zeros(3))
    with pytest.raises(ValueError, match="q0.*NaN"):
        solve_ik(arm, p, np.full(arm.n_joints, np.nan))
    with pytest.raises(ValueError, match="rotation matrix"):
        solve_ik(arm, p, target_rotation=2.0 * np.eye(3))
    with pytest.raises(ValueError, match="target_rotation.*NaN"):
        solve_ik(arm, p, target_rotation=np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match="orientation_weight"):
        solve_ik(arm, p, target_rotation=np.eye(3), orientation_weight=0.0)
    with pytest.raises(ValueError, match="position_tolerance"):
        solve_ik(arm, p, position_tolerance=-1.0)
    with pytest.raises(ValueError, match="max_iterations must be an integer >= 1"):
        solve_ik(arm, p, max_iterations=0)
    with pytest.raises(ValueError, match="max_iterations must be an integer"):
        solve_ik(arm, p, max_iterations=2.5)
    with pytest.raises(ValueError, match="restarts"):
        solve_ik(arm, p, restarts=-1)


def test_rotation_error_is_the_rotation_vector() -> None:
    rng = np.random.default_rng(14)
    for _ in range(20):
        roll, pitch, yaw = rng.uniform(-1.0, 1.0, size=3)
        base = head_rotation(roll, pitch, yaw)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(0.0, np.pi - 1e-3)
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        delta = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
        assert_allclose(rotation_error(delta @ base, base), angle * axis, atol=1e-9)
    flip = np.diag([1.0, -1.0, -1.0])  # a half turn about x
    assert_allclose(np.abs(rotation_error(flip, np.eye(3))), [np.pi, 0.0, 0.0], atol=1e-9)
    assert_allclose(rotation_error(np.eye(3), np.eye(3)), np.zeros(3), atol=0)
