"""Synthetic datasets with the layouts of two real ones the studio is used on, written as CSV
folders (``<primitive>/<take>.csv``) the Data tab and ``--import-dataset`` read.

- :func:`icub_set`: an iCub's left hand in its root frame (z up, the robot faces -x, its left
  is -y), as a lab records it from the robot's joints: three primitives between a base pose, a
  goal in front and a goal on the left (``base_to_left_goal``, ``base_to_front_goal``,
  ``front_to_left``), each take a minimum-jerk movement of the torso (3) and left arm (7)
  joints between jittered configurations, the hand (``l_hand_dh_frame``) by forward
  kinematics. The left goal is low on the robot's left, where the studio's simulated bin
  stands: these paths would cross it. With ``glitch``, one take has a tracking jump: a
  quarter of a second 1.5 m away (an outlier among the 38).
- :func:`handover_set`: another lab's handover: a ``human`` hand in a frame whose origin is
  the partner (x towards the robot, y the partner's left, z up), 8 EMG channels, and the
  robot's hand (x, y, z: the studio's ``hand``) in its own base frame (another robot, out of
  the iCub's reach). The
  handover point varies a lot from take to take (different people, a loose task): the
  human hand's 90 % region is about a metre wide.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robots.icub.ik import solve_ik
from robots.icub.kinematics import load_arm
from robots.icub.motion import minimum_jerk

RATE_HZ = 50.0

# Hand targets of the iCub-like set, root frame (m). The left goal is inside the simulated
# bin (DEFAULT_SCENE.bins[0]: x -0.31..-0.17, y -0.36..-0.22, z -0.06..0.01).
ICUB_TARGETS = {
    "base": (-0.17, -0.13, 0.09),
    "front": (-0.30, -0.05, 0.03),
    "left": (-0.23, -0.30, -0.01),
}
ICUB_PRIMITIVES = {
    "base_to_left_goal": ("base", "left"),
    "base_to_front_goal": ("base", "front"),
    "front_to_left": ("front", "left"),
}
ICUB_TAKES = (13, 13, 12)  # 38 takes


def write_csv(path: Path, times: np.ndarray, columns: tuple[str, ...], values: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = np.column_stack([times, values])
    lines = [",".join(("t", *columns))]
    lines += [",".join(f"{v:.6f}" for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")


GLITCH = (1.2, 0.8, 0.6)  # m: where a glitching take's samples jump to, from the hand
GLITCHED = ("base_to_front_goal", 5, slice(40, 52))  # the take and its samples


def icub_set(
    folder: Path, seed: int = 0, takes: tuple[int, ...] = ICUB_TAKES, glitch: bool = False
) -> Path:
    """The iCub-like set (see the module docstring) written under ``folder``; returns it."""
    rng = np.random.default_rng(seed)
    arm = load_arm()
    poses = {}
    for name, target in ICUB_TARGETS.items():
        result = solve_ik(arm, np.array(target), arm.rest, restarts=5)
        assert result.position_error_m < 1e-3, f"{name} out of reach"
        poses[name] = result.q
    for (primitive, (start, end)), n in zip(ICUB_PRIMITIVES.items(), takes, strict=True):
        for k in range(n):
            q0 = arm.clip(poses[start] + rng.normal(scale=0.03, size=arm.n_joints))
            q1 = arm.clip(poses[end] + rng.normal(scale=0.03, size=arm.n_joints))
            duration = rng.uniform(2.0, 3.5)
            times = np.arange(int(duration * RATE_HZ) + 1) / RATE_HZ
            s = minimum_jerk(times / times[-1])
            joints = q0 + np.outer(s, q1 - q0)
            hand = np.array([arm.position(q) for q in joints])
            hand += rng.normal(scale=2e-4, size=hand.shape)  # the encoders' noise
            if glitch and (primitive, k) == GLITCHED[:2]:
                hand[GLITCHED[2]] += GLITCH
            write_csv(folder / primitive / f"take{k:02d}.csv", times, ("x", "y", "z"), hand)
    return folder


# The handover: where the partner and the other robot stand in one room (m, z up), the
# partner facing the robot along +x.
PARTNER_IN_ROOM = np.array([0.0, 0.0, 1.3])  # the partner's frame origin (their shoulders)
ROBOT_BASE_IN_ROOM = np.array([1.1, 0.0, 0.75])  # the other robot's base, facing -x as the iCub
HANDOVER_POINTS = {"handover_high": (0.55, 0.05, 1.15), "handover_low": (0.55, -0.1, 0.95)}
HUMAN_REST = np.array([0.15, -0.2, -0.35])  # the hand at rest, partner's frame
ROBOT_REST = np.array([-0.25, -0.1, 0.3])  # the robot's hand at rest, its base frame
HUMAN_COLUMNS = ("human_x", "human_y", "human_z")
EMG_COLUMNS = tuple(f"emg{i}" for i in range(8))
ROBOT_COLUMNS = ("x", "y", "z")  # the studio's hand: metres by their names
HANDOVER_MODALITIES = (
    f"hand={','.join(ROBOT_COLUMNS)}; human={','.join(HUMAN_COLUMNS)}; "
    f"emg={','.join(EMG_COLUMNS)}"
)


def robot_frame(room: np.ndarray) -> np.ndarray:
    """Room points (n, 3) in the other robot's base frame (axes as the room's: it faces -x,
    towards the partner, like the iCub)."""
    return np.asarray(room) - ROBOT_BASE_IN_ROOM


def handover_set(folder: Path, seed: int = 0, takes: int = 6) -> Path:
    """The handover set (see the module docstring) written under ``folder``; returns it."""
    rng = np.random.default_rng(seed)
    for primitive, point in HANDOVER_POINTS.items():
        for k in range(takes):
            meet = np.array(point) + rng.normal(scale=0.15, size=3) * (1.0, 1.0, 0.6)
            duration = rng.uniform(2.0, 3.0)
            times = np.arange(int(duration * RATE_HZ) + 1) / RATE_HZ
            s = minimum_jerk(times / times[-1])[:, None]
            # The human reaches from rest to the meeting point, arching a little forward.
            human_end = meet - PARTNER_IN_ROOM
            arch = np.sin(np.pi * s) * np.array([0.08, 0.0, 0.05])
            human = HUMAN_REST + s * (human_end - HUMAN_REST) + arch
            robot_end = robot_frame(meet[None])[0] + np.array([0.06, 0.0, 0.0])  # a hand apart
            robot = ROBOT_REST + s * (robot_end - ROBOT_REST)
            bursts = np.abs(rng.normal(size=(times.size, 8))) * (0.2 + np.sin(np.pi * s))
            values = np.column_stack([human, 1e-3 * bursts, robot])
            values[:, :3] += rng.normal(scale=1e-3, size=human.shape)  # motion capture
            columns = (*HUMAN_COLUMNS, *EMG_COLUMNS, *ROBOT_COLUMNS)
            write_csv(folder / primitive / f"take{k:02d}.csv", times, columns, values)
    return folder
