"""The collaborative scene and the partner's head-orientation convention."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robots.icub.ik import solve_ik
from robots.icub.kinematics import load_arm
from robots.icub.model import ground_height, load_urdf
from robots.icub.scene import (
    DEFAULT_SCENE,
    PARTNER_HEAD,
    Box,
    gaze_direction,
    head_angles,
    head_orientation_looking_at,
    head_rotation,
)


def test_table_object_and_bins_stand_in_front_of_the_robot() -> None:
    scene = DEFAULT_SCENE
    table = scene.table
    assert table.top == pytest.approx(-0.06)
    assert table.center[0] + table.size[0] / 2 < -0.1, "the table is in front (-x) of the robot"
    corners = scene.table_corners()
    assert corners.shape == (4, 3) and np.all(corners[:, 2] == table.top)
    on_table = [scene.object, *(b.box for b in scene.bins)]
    for box in on_table:
        assert box.bottom == pytest.approx(table.top), "objects stand on the table"
        inner = Box(table.center, (table.size[0], table.size[1], 10.0))
        assert inner.contains(np.array(box.center), margin=-min(box.size[:2]) / 2)
    # Nothing overlaps on the table.
    for a, b in itertools.combinations(on_table, 2):
        gap = np.abs(np.subtract(a.center, b.center))[:2] - (np.add(a.size, b.size)[:2] / 2)
        assert gap.max() > 0.02
    # The grasp is just above the object, the drops above the bins' rims.
    assert_allclose(scene.pick_position[:2], scene.object.center[:2])
    assert 0.0 < scene.pick_position[2] - scene.object.top < 0.03
    for b in scene.bins:
        assert b.drop_position[2] - b.rim > 0.05
        assert len(b.parts()) == 5 and all(b.box.contains(p.center) for p in b.parts())
    # The first bin is on the robot's left (-y), the second on its right.
    assert scene.bins[0].box.center[1] < scene.pick_position[1] < scene.bins[1].box.center[1]


def test_partner_sits_across_the_table_facing_the_robot() -> None:
    head = np.array(DEFAULT_SCENE.partner_head)
    assert_allclose(head, PARTNER_HEAD)
    assert -1.1 <= head[0] <= -0.9
    assert head[0] < DEFAULT_SCENE.table.center[0] - DEFAULT_SCENE.table.size[0] / 2
    floor = ground_height(load_urdf(load_meshes=False))
    assert floor == pytest.approx(-0.623, abs=0.01)
    assert 1.0 <= head[2] - floor <= 1.3, "a seated adult's head is 1.0-1.3 m above the floor"
    # Looking straight at the robot is (about) the neutral head orientation.
    roll, pitch, yaw = head_orientation_looking_at(np.zeros(3), head)
    assert abs(yaw) < 0.05 and abs(roll) == 0.0


def test_scene_targets_are_reachable_by_the_arm_alone_with_a_margin() -> None:
    arm = load_arm()
    offsets = np.array(list(itertools.product([-0.03, 0.0, 0.03], repeat=3)))
    for name, target in DEFAULT_SCENE.hand_targets().items():
        for offset in offsets:
            result = solve_ik(arm, target + offset, arm.rest, lock_torso=True, restarts=3)
            assert result.reached, f"{name} + {offset} is out of reach"
            assert_allclose(result.q[:3], arm.rest[:3])


def test_box_rejects_bad_geometry() -> None:
    with pytest.raises(ValueError, match="positive sizes"):
        Box((0.0, 0.0, 0.0), (0.1, -0.1, 0.1))
    with pytest.raises(ValueError, match="finite"):
        Box((np.nan, 0.0, 0.0), (0.1, 0.1, 0.1))
    with pytest.raises(ValueError, match="3-D"):
        Box((0.0, 0.0), (0.1, 0.1, 0.1))


# ---------------------------------------------------------------------- head convention


def test_zero_angles_look_straight_at_the_robot_along_plus_x() -> None:
    assert_allclose(head_rotation(0.0, 0.0, 0.0), np.eye(3))
    assert_allclose(gaze_direction(0.0, 0.0, 0.0), [1.0, 0.0, 0.0])
    assert_allclose(head_orientation_looking_at([0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]), (0, 0, 0))


def test_signs_of_the_angles() -> None:
    head = np.array([-1.0, 0.0, 0.5])
    # A point on the partner's left (+y) is a positive yaw.
    _, _, yaw = head_orientation_looking_at(head + [1.0, 0.3, 0.0], head)
    assert yaw > 0.0
    # A point below the eyes (the table) is a positive pitch: looking down.
    _, pitch, _ = head_orientation_looking_at(head + [0.7, 0.0, -0.5], head)
    assert pitch > 0.0
    assert gaze_direction(0.0, 0.3, 0.0)[2] < 0.0
    assert gaze_direction(0.0, 0.0, 0.3)[1] > 0.0
    # Positive roll tilts the top of the head towards the partner's right shoulder (-y).
    up = head_rotation(0.3, 0.0, 0.0)[:, 2]
    assert up[1] < 0.0 and up[2] > 0.0
    # Gaze is R[:, 0]; roll does not move it.
    assert_allclose(gaze_direction(0.4, 0.2, -0.3), head_rotation(0.4, 0.2, -0.3)[:, 0])
    assert_allclose(gaze_direction(0.4, 0.2, -0.3), gaze_direction(0.0, 0.2, -0.3))


def test_rotation_is_rz_ry_rx() -> None:
    def rx(a: float) -> np.ndarray:
        c, s = np.cos(a), np.sin(a)
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])

    def ry(a: float) -> np.ndarray:
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])

    def rz(a: float) -> np.ndarray:
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    rng = np.random.default_rng(20)
    for roll, pitch, yaw in rng.uniform(-1.5, 1.5, size=(20, 3)):
        expected = rz(yaw) @ ry(pitch) @ rx(roll)
        assert_allclose(head_rotation(roll, pitch, yaw), expected, atol=1e-12)
        assert_allclose(head_angles(expected), (roll, pitch, yaw), atol=1e-9)
    batch = head_rotation(np.zeros(4), np.linspace(-1, 1, 4), np.ones(4))
    assert batch.shape == (4, 3, 3)
    assert_allclose(batch[2], head_rotation(0.0, np.linspace(-1, 1, 4)[2], 1.0))


def test_look_at_round_trip_points_the_gaze_at_the_point() -> None:
    rng = np.random.default_rng(21)
    head = np.array(PARTNER_HEAD)
    points = head + rng.uniform(-1.0, 1.0, size=(50, 3))
    roll, pitch, yaw = head_orientation_looking_at(points, head)
    assert roll.shape == (50,) and np.all(roll == 0.0)
    directions = (points - head) / np.linalg.norm(points - head, axis=1, keepdims=True)
    assert_allclose(gaze_direction(roll, pitch, yaw), directions, atol=1e-12)
    for i in range(5):
        single = head_orientation_looking_at(points[i], head)
        assert isinstance(single[1], float)
        assert_allclose(single, (roll[i], pitch[i], yaw[i]))
        rotation = head_rotation(*single)
        assert_allclose(rotation[:, 0], directions[i], atol=1e-12)
    # Default head position: the scene's partner.
    target = np.array([-0.3, -0.1, 0.0])
    d = target - head
    assert_allclose(gaze_direction(*head_orientation_looking_at(target)), d / np.linalg.norm(d))


def test_head_angles_looking_straight_down() -> None:
    roll, pitch, yaw = head_angles(head_rotation(0.0, np.pi / 2, 0.4))
    assert pitch == pytest.approx(np.pi / 2)
    assert_allclose(head_rotation(roll, pitch, yaw), head_rotation(0.0, np.pi / 2, 0.4), atol=1e-9)


def test_head_convention_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="NaN"):
        head_rotation(np.nan, 0.0, 0.0)
    with pytest.raises(ValueError, match="NaN"):
        gaze_direction(0.0, np.inf, 0.0)
    with pytest.raises(ValueError, match="finite"):
        head_orientation_looking_at([np.nan, 0.0, 0.0])
    with pytest.raises(ValueError, match="head position"):
        head_orientation_looking_at(PARTNER_HEAD)
    with pytest.raises(ValueError, match="shape"):
        head_orientation_looking_at([1.0, 2.0])
    with pytest.raises(ValueError, match="rotation matrix"):
        head_angles(2.0 * np.eye(3))
