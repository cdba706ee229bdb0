"""The left-arm chain: forward kinematics and Jacobian against yourdfpy and finite differences."""

from __future__ import annotations

import io

import numpy as np
import pytest
import yourdfpy
from numpy.testing import assert_allclose

from robots.icub.kinematics import ARM_JOINTS, HAND_FRAME, N_TORSO, ArmChain, load_arm
from robots.icub.model import load_urdf, natural_pose


@pytest.fixture(scope="module")
def urdf() -> yourdfpy.URDF:
    return load_urdf(load_meshes=False)


@pytest.fixture(scope="module")
def arm() -> ArmChain:
    return load_arm()


def test_chain_joints_and_limits_come_from_the_urdf(arm: ArmChain, urdf: yourdfpy.URDF) -> None:
    assert arm.joint_names == ARM_JOINTS
    assert arm.joint_names[:N_TORSO] == ("torso_pitch", "torso_roll", "torso_yaw")
    assert arm.tip_frame == HAND_FRAME and arm.base_frame == urdf.base_link
    for i, name in enumerate(arm.joint_names):
        limit = urdf.joint_map[name].limit
        assert arm.lower[i] == limit.lower and arm.upper[i] == limit.upper
    elbow = arm.joint_names.index("l_elbow")
    assert_allclose([arm.lower[elbow], arm.upper[elbow]], [0.096, 1.85], atol=1e-3)
    assert arm.within_limits(arm.rest)
    assert not arm.within_limits(np.zeros(arm.n_joints)), "the zero pose violates the elbow limit"


def test_fk_matches_yourdfpy_on_random_configurations(arm: ArmChain, urdf: yourdfpy.URDF) -> None:
    rng = np.random.default_rng(0)
    q_full0 = natural_pose(urdf)
    for q in arm.random_configurations(rng, 60):
        urdf.update_cfg(arm.into_full(q, q_full0))
        expected = urdf.get_transform(HAND_FRAME, urdf.base_link)
        assert_allclose(arm.fk(q), expected, atol=1e-9, rtol=0)
        assert_allclose(arm.position(q), expected[:3, 3], atol=1e-9, rtol=0)


def test_natural_pose_puts_the_hand_above_the_table(arm: ArmChain) -> None:
    assert_allclose(arm.position(arm.rest), [-0.28, -0.155, 0.03], atol=0.01)


def test_jacobian_matches_finite_differences(arm: ArmChain) -> None:
    rng = np.random.default_rng(1)
    h = 1e-6
    for q in arm.random_configurations(rng, 10):
        pose, jac = arm.fk_jacobian(q)
        assert jac.shape == (6, arm.n_joints)
        assert_allclose(arm.jacobian(q), jac)
        assert_allclose(arm.fk(q), pose)
        numeric = np.empty((6, arm.n_joints))
        for i in range(arm.n_joints):
            dq = np.zeros(arm.n_joints)
            dq[i] = h
            plus, minus = arm.fk(q + dq), arm.fk(q - dq)
            numeric[:3, i] = (plus[:3, 3] - minus[:3, 3]) / (2 * h)
            # Angular velocity: skew(omega) = dR/dq R^T.
            omega = (plus[:3, :3] - minus[:3, :3]) / (2 * h) @ pose[:3, :3].T
            numeric[3:, i] = [omega[2, 1], omega[0, 2], omega[1, 0]]
        assert_allclose(jac, numeric, atol=1e-8, rtol=0)


def test_full_vector_mapping_round_trip(arm: ArmChain, urdf: yourdfpy.URDF) -> None:
    rng = np.random.default_rng(2)
    q_full = rng.uniform(-0.5, 0.5, size=len(urdf.actuated_joint_names))
    q = arm.random_configurations(rng, 1)[0]
    merged = arm.into_full(q, q_full)
    assert_allclose(arm.from_full(merged), q)
    others = np.setdiff1d(np.arange(len(q_full)), arm.full_index)
    assert_allclose(merged[others], q_full[others])
    for i, name in enumerate(ARM_JOINTS):
        assert merged[urdf.actuated_joint_names.index(name)] == q[i]
    assert_allclose(arm.from_full(natural_pose(urdf)), arm.rest)
    with pytest.raises(ValueError, match="full configuration"):
        arm.from_full(np.zeros(5))
    with pytest.raises(ValueError, match="full configuration"):
        arm.into_full(q, np.zeros(5))


def test_bad_configurations_are_clear_errors(arm: ArmChain) -> None:
    with pytest.raises(ValueError, match=r"shape \(10,\)"):
        arm.fk(np.zeros(7))
    with pytest.raises(ValueError, match="NaN"):
        arm.fk(np.full(10, np.nan))
    with pytest.raises(ValueError, match="NaN"):
        arm.jacobian(np.r_[np.zeros(9), np.inf])


def test_the_chain_is_immutable(arm: ArmChain) -> None:
    with pytest.raises(ValueError):
        arm.lower[0] = 0.0
    q = arm.rest.copy()
    pose = arm.fk(q)
    pose[0, 3] = 99.0
    assert arm.fk(q)[0, 3] != 99.0


_NO_ARM_URDF = """<?xml version="1.0"?>
<robot name="stick">
  <link name="root_link"/>
  <link name="chest"/>
  <link name="l_upper_arm"/>
  <joint name="torso_pitch" type="revolute">
    <parent link="root_link"/><child link="chest"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="l_shoulder_pitch" type="revolute">
    <parent link="chest"/><child link="l_upper_arm"/>
    <origin xyz="0 -0.1 0.2" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_urdf_without_the_arm_chain_is_a_clear_error() -> None:
    urdf = yourdfpy.URDF.load(io.StringIO(_NO_ARM_URDF), load_meshes=False)
    with pytest.raises(ValueError, match="no tip link 'l_hand_dh_frame'"):
        ArmChain.from_urdf(urdf)
    # A tip that exists but a chain that lacks the arm's joints.
    with pytest.raises(ValueError, match="missing"):
        ArmChain.from_urdf(urdf, tip_frame="l_upper_arm")


def test_icub_models_entries_without_the_arm_are_clear_errors() -> None:
    with pytest.raises(ValueError, match="unknown robot 'iCubNowhere'"):
        load_arm("iCubNowhere")
    with pytest.raises(ValueError, match="no tip link 'l_hand_dh_frame'"):
        load_arm("left_hand_mk3")


def test_a_chain_needs_joints(urdf: yourdfpy.URDF) -> None:
    with pytest.raises(ValueError, match="at least one movable joint"):
        ArmChain.from_urdf(urdf, joint_names=())
    with pytest.raises(ValueError, match="no base link 'nowhere'"):
        ArmChain.from_urdf(urdf, base_frame="nowhere")
    with pytest.raises(ValueError, match="not below"):
        ArmChain.from_urdf(urdf, base_frame="r_hand")
