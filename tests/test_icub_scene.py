"""The collaborative scene and the partner's head-orientation convention."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robots.icub.ik import solve_ik
from robots.icub.kinematics import load_arm
from robots.icub.model import ground_height, load_urdf, natural_pose
from robots.icub.scene import (
    DEFAULT_SCENE,
    PARTNER_HEAD,
    ROBOT_EYES,
    Box,
    gaze_direction,
    head_angles,
    head_orientation_looking_at,
    head_rotation,
    neutral_rotation,
)

# Head positions to check the convention from: the scene's partner, a jittered one, one off to
# the side and higher, one lower than the robot's eyes.
HEADS = [
    np.array(PARTNER_HEAD),
    np.array(PARTNER_HEAD) + [0.01, -0.008, 0.012],
    np.array([-1.2, 0.3, 0.7]),
    np.array([-0.8, -0.2, 0.1]),
]


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
    # Looking straight at the robot (at its eyes) is the neutral head orientation.
    assert_allclose(head_orientation_looking_at(ROBOT_EYES, head), (0, 0, 0), atol=1e-12)


def test_robot_eyes_are_in_front_of_the_head_link() -> None:
    urdf = load_urdf(load_meshes=False)
    urdf.update_cfg(natural_pose(urdf))
    head_link = urdf.get_transform("head", "root_link")[:3, 3]
    offset = np.array(ROBOT_EYES) - head_link
    assert 0.04 < -offset[0] < 0.08, "the face front is ~6 cm in front (-x) of the head link"
    assert offset[1] == pytest.approx(0.0, abs=1e-6)
    assert 0.0 < offset[2] < 0.04
    # The partner's head is above the robot's eyes, so the neutral gaze looks down a little.
    assert 0.2 < PARTNER_HEAD[2] - ROBOT_EYES[2] < 0.35


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


def rx(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_neutral_frame_looks_from_the_head_at_the_robot_eyes() -> None:
    for head in HEADS:
        neutral = neutral_rotation(head)
        assert_allclose(neutral.T @ neutral, np.eye(3), atol=1e-12)
        assert np.linalg.det(neutral) == pytest.approx(1.0)
        to_eyes = np.array(ROBOT_EYES) - head
        assert_allclose(neutral[:, 0], to_eyes / np.linalg.norm(to_eyes), atol=1e-12)
        forward, left, up = neutral.T
        assert left[2] == pytest.approx(0.0, abs=1e-12), "y is horizontal"
        assert left[1] > 0.8, "y is the partner's left, the root frame's +y when facing the robot"
        assert up[2] > 0.8, "z is up-ish"
        assert_allclose(np.cross(forward, left), up, atol=1e-12)
    # Another target: the neutral frame looks at it.
    assert_allclose(
        neutral_rotation(HEADS[2], np.zeros(3))[:, 0], -HEADS[2] / np.linalg.norm(HEADS[2])
    )
    # The default partner is 0.265 m above the eyes and 0.935 m in front: the neutral frame is the
    # root frame pitched 15.8 deg down about y.
    down = np.arctan2(PARTNER_HEAD[2] - ROBOT_EYES[2], ROBOT_EYES[0] - PARTNER_HEAD[0])
    assert np.rad2deg(down) == pytest.approx(15.8, abs=0.05)
    assert_allclose(neutral_rotation(), ry(down), atol=1e-12)
    assert_allclose(neutral_rotation(PARTNER_HEAD, ROBOT_EYES), ry(down), atol=1e-12)


def test_zero_angles_look_at_the_robot_eyes_from_any_head_position() -> None:
    for head in HEADS:
        to_eyes = np.array(ROBOT_EYES) - head
        assert_allclose(head_rotation(0.0, 0.0, 0.0, head), neutral_rotation(head), atol=0)
        assert_allclose(gaze_direction(0.0, 0.0, 0.0, head), to_eyes / np.linalg.norm(to_eyes))
        assert_allclose(head_orientation_looking_at(ROBOT_EYES, head), (0, 0, 0), atol=1e-12)
        assert_allclose(head_angles(neutral_rotation(head), head), (0, 0, 0), atol=1e-12)
    # Defaults: the scene's partner.
    assert_allclose(head_rotation(0.0, 0.0, 0.0), neutral_rotation(PARTNER_HEAD), atol=0)
    assert_allclose(head_orientation_looking_at(ROBOT_EYES), (0, 0, 0), atol=1e-12)
    # Looking horizontally along +x (the old zero) is looking 15.8 deg up from the neutral.
    down = np.arctan2(PARTNER_HEAD[2] - ROBOT_EYES[2], ROBOT_EYES[0] - PARTNER_HEAD[0])
    horizontal = head_orientation_looking_at(np.array(PARTNER_HEAD) + [1.0, 0.0, 0.0])
    assert_allclose(horizontal, (0.0, -down, 0.0), atol=1e-12)
    assert_allclose(head_rotation(0.0, -down, 0.0), np.eye(3), atol=1e-12)
    assert_allclose(head_angles(np.eye(3)), (0.0, -down, 0.0), atol=1e-12)


def test_signs_of_the_angles() -> None:
    head = np.array([-1.0, 0.0, 0.5])
    eyes = np.array(ROBOT_EYES)
    # A point on the partner's left (+y) is a positive yaw.
    _, _, yaw = head_orientation_looking_at(head + [1.0, 0.3, 0.0], head)
    assert yaw > 0.0
    roll, pitch, yaw = head_orientation_looking_at(eyes + [0.0, 0.2, 0.0], head)
    assert yaw > 0.0 and abs(pitch) < 0.02 and roll == 0.0
    _, _, yaw = head_orientation_looking_at(eyes + [0.0, -0.2, 0.0], head)
    assert yaw < 0.0
    # A point below the robot's eyes (the table) is a positive pitch: looking down.
    _, pitch, _ = head_orientation_looking_at(head + [0.7, 0.0, -0.5], head)
    assert pitch > 0.0
    _, pitch, yaw = head_orientation_looking_at(eyes + [0.0, 0.0, -0.2], head)
    assert pitch > 0.0 and yaw == pytest.approx(0.0, abs=1e-12)
    _, pitch, _ = head_orientation_looking_at(eyes + [0.0, 0.0, 0.2], head)
    assert pitch < 0.0
    neutral_gaze = gaze_direction(0.0, 0.0, 0.0, head)
    assert gaze_direction(0.0, 0.3, 0.0, head)[2] < neutral_gaze[2] < 0.0
    assert gaze_direction(0.0, 0.0, 0.3, head)[1] > 0.0
    assert gaze_direction(0.0, 0.0, -0.3, head)[1] < 0.0
    # Positive roll tilts the top of the head towards the partner's right shoulder (-y).
    up = head_rotation(0.3, 0.0, 0.0, head)[:, 2]
    assert up[1] < 0.0 and up[2] > 0.0
    up = head_rotation(-0.3, 0.0, 0.0, head)[:, 2]
    assert up[1] > 0.0 and up[2] > 0.0
    # Gaze is R[:, 0]; roll does not move it.
    assert_allclose(gaze_direction(0.4, 0.2, -0.3), head_rotation(0.4, 0.2, -0.3)[:, 0])
    assert_allclose(gaze_direction(0.4, 0.2, -0.3), gaze_direction(0.0, 0.2, -0.3))
    assert_allclose(gaze_direction(0.4, 0.2, -0.3, head), head_rotation(0.4, 0.2, -0.3, head)[:, 0])


def test_the_scene_is_seen_below_and_around_the_robot_eyes() -> None:
    # Watching the hand on the table the partner looks down (positive pitch), towards the first
    # bin on the robot's left (the partner's right: negative yaw), the second near the middle.
    angles = {
        name: head_orientation_looking_at(t) for name, t in DEFAULT_SCENE.hand_targets().items()
    }
    for name, (_, pitch, _) in angles.items():
        assert np.deg2rad(8.0) < pitch < np.deg2rad(25.0), name
    assert angles["drop0"][2] < np.deg2rad(-10.0)
    assert abs(angles["drop1"][2]) < np.deg2rad(5.0)


def test_rotation_is_the_neutral_frame_times_rz_ry_rx() -> None:
    rng = np.random.default_rng(20)
    for head in HEADS:
        neutral = neutral_rotation(head)
        for roll, pitch, yaw in rng.uniform(-1.5, 1.5, size=(20, 3)):
            expected = neutral @ rz(yaw) @ ry(pitch) @ rx(roll)
            assert_allclose(head_rotation(roll, pitch, yaw, head), expected, atol=1e-12)
            assert_allclose(head_angles(expected, head), (roll, pitch, yaw), atol=1e-9)
    roll, pitch, yaw = 0.2, -0.3, 0.5
    assert_allclose(
        head_rotation(roll, pitch, yaw),
        neutral_rotation() @ rz(yaw) @ ry(pitch) @ rx(roll),
        atol=1e-12,
    )
    assert_allclose(head_angles(head_rotation(roll, pitch, yaw)), (roll, pitch, yaw), atol=1e-12)
    # Angles are relative to the head position given: another head reads other angles.
    rotation = head_rotation(roll, pitch, yaw, HEADS[0])
    assert np.abs(np.subtract(head_angles(rotation, HEADS[2]), (roll, pitch, yaw))).max() > 0.05
    for head in (None, HEADS[2]):
        kwargs = {} if head is None else {"head_position": head}
        pitches = np.linspace(-1, 1, 4)
        batch = head_rotation(np.zeros(4), pitches, np.ones(4), **kwargs)
        assert batch.shape == (4, 3, 3)
        for i in range(4):
            assert_allclose(batch[i], head_rotation(0.0, pitches[i], 1.0, **kwargs), atol=1e-12)
        gaze = gaze_direction(np.zeros(4), pitches, np.ones(4), **kwargs)
        assert gaze.shape == (4, 3)
        assert_allclose(gaze, batch[:, :, 0], atol=1e-12)
    assert head_rotation(0.1, np.zeros((2, 5)), 0.3).shape == (2, 5, 3, 3)


def test_look_at_round_trip_points_the_gaze_at_the_point() -> None:
    rng = np.random.default_rng(21)
    for head in HEADS:
        points = head + rng.uniform(-1.0, 1.0, size=(50, 3))
        roll, pitch, yaw = head_orientation_looking_at(points, head)
        assert roll.shape == (50,) and np.all(roll == 0.0)
        directions = (points - head) / np.linalg.norm(points - head, axis=1, keepdims=True)
        assert_allclose(gaze_direction(roll, pitch, yaw, head), directions, atol=1e-12)
        for i in range(5):
            single = head_orientation_looking_at(points[i], head)
            assert isinstance(single[1], float)
            assert_allclose(single, (roll[i], pitch[i], yaw[i]))
            rotation = head_rotation(*single, head_position=head)
            assert_allclose(rotation[:, 0], directions[i], atol=1e-12)
            assert_allclose(head_angles(rotation, head), single, atol=1e-9)
    # Default head position: the scene's partner.
    head = np.array(PARTNER_HEAD)
    target = np.array([-0.3, -0.1, 0.0])
    d = target - head
    assert_allclose(gaze_direction(*head_orientation_looking_at(target)), d / np.linalg.norm(d))


def test_head_angles_looking_straight_down() -> None:
    for head in (PARTNER_HEAD, HEADS[2]):
        rotation = head_rotation(0.0, np.pi / 2, 0.4, head)
        roll, pitch, yaw = head_angles(rotation, head)
        assert pitch == pytest.approx(np.pi / 2)
        assert_allclose(head_rotation(roll, pitch, yaw, head), rotation, atol=1e-9)


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
    # The head position: a finite 3-vector, not at the target nor straight above/below it.
    for bad, message in (([np.nan, 0.0, 0.5], "finite"), ([-1.0, 0.5], r"shape \(3,\)")):
        with pytest.raises(ValueError, match=message):
            neutral_rotation(bad)
        with pytest.raises(ValueError, match=message):
            head_rotation(0.0, 0.0, 0.0, bad)
        with pytest.raises(ValueError, match=message):
            gaze_direction(0.0, 0.0, 0.0, bad)
        with pytest.raises(ValueError, match=message):
            head_angles(np.eye(3), bad)
        with pytest.raises(ValueError, match=message):
            head_orientation_looking_at(ROBOT_EYES, bad)
    with pytest.raises(ValueError, match="finite"):
        neutral_rotation(PARTNER_HEAD, [0.0, np.inf, 0.0])
    with pytest.raises(ValueError, match="head position"):
        neutral_rotation(ROBOT_EYES)
    above_the_eyes = np.array(ROBOT_EYES) + [0.0, 0.0, 0.3]
    with pytest.raises(ValueError, match="straight above or below"):
        head_rotation(0.0, 0.0, 0.0, above_the_eyes)
    with pytest.raises(ValueError, match="straight above or below"):
        head_orientation_looking_at([-0.3, 0.0, 0.0], above_the_eyes)
