"""Dragging the iCub's left hand: a transform gizmo on ``l_hand_dh_frame`` driving the arm by IK.

The gizmo's callback only records the latest target pose; :meth:`ArmController.step`, called
by the studio's loop, solves the IK from that latest target alone (warm-started from the current
pose), so a fast drag never queues stale targets and the arm follows smoothly. One frame solves
at most :data:`ITERATIONS_PER_FRAME` iterations; a target not reached yet is solved on at the
next frames (:data:`FRAMES_PER_AIM` at most, then left), so that a pose the arm cannot take
never holds up the loop.
"""

from __future__ import annotations

import threading

import numpy as np
import viser
import viser.transforms as vtf

from app.live.history import StateHistory
from app.scene.robot import RobotView
from robots.icub.ik import IKResult, solve_ik
from robots.icub.kinematics import ArmChain

GIZMO_NODE = "/hand_gizmo"
GIZMO_SCALE = 0.12  # length of the gizmo's arrows, metres
MAX_IK_STEP_M = 0.03  # longest straight move solved in one IK call, metres
ITERATIONS_PER_FRAME = 15  # IK iterations the loop spends on a drag in one frame
FRAMES_PER_AIM = 4  # frames one target may take (60 iterations in all)


class ArmController:
    """The left arm of the displayed robot, moved by dragging its hand (see module docstring).

    Attributes
    ----------
    q : array, shape (n_arm_joints,)
        Current arm configuration (torso + left arm), in the chain's joint order.
    last : IKResult or None
        Outcome of the latest solve (``reached`` False when the target is out of reach).
    """

    def __init__(
        self, server: viser.ViserServer, robot: RobotView, arm: ArmChain, lock_torso: bool = True
    ):
        self.server = server
        self.robot = robot
        self.arm = arm
        self.lock_torso = lock_torso
        self.q = arm.from_full(robot.q)
        # The hand's position each time the arm moved (the recorder samples it at its ticks).
        self.hand_history: StateHistory[np.ndarray] = StateHistory()
        self.hand_history.record(arm.position(self.q))
        self.last: IKResult | None = None
        self._lock = threading.Lock()
        self._target: tuple[np.ndarray, np.ndarray, int] | None = None  # and frames spent
        pose = arm.fk(self.q)
        self.gizmo = server.scene.add_transform_controls(
            GIZMO_NODE,
            scale=GIZMO_SCALE,
            line_width=3.0,
            position=pose[:3, 3],
            wxyz=vtf.SO3.from_matrix(pose[:3, :3]).wxyz,
            depth_test=False,
        )
        robot.props.append(self.gizmo)  # no hand to drag where the robot is hidden
        self.dragging = False
        self._snap_pending = False

        @self.gizmo.on_update
        def _(event) -> None:
            self.aim(self.gizmo.position, self.gizmo.wxyz)
            phase = getattr(event, "phase", "update")
            if phase == "start":
                self.dragging = True
            elif phase == "end":
                self.dragging = False
                self._snap_pending = True

    def aim(self, position, wxyz) -> None:
        """The hand is dragged towards ``position`` (3,) with orientation ``wxyz`` (4,): the
        next :meth:`step` solves for the latest aim alone (from any thread)."""
        target = (np.array(position, dtype=float), vtf.SO3(np.array(wxyz)).as_matrix(), 0)
        with self._lock:
            self._target = target

    def hand_pose(self) -> np.ndarray:
        """Homogeneous pose of the hand frame in the root frame, shape (4, 4)."""
        return self.arm.fk(self.q)

    def hand_position(self) -> np.ndarray:
        return self.arm.position(self.q)

    def hand_at(self, t: float) -> np.ndarray:
        """The hand's position (3,) at monotonic time ``t`` (recent; see
        :class:`app.live.history.StateHistory`, whose ``LookupError`` it raises)."""
        return self.hand_history.at(t)

    def step(self) -> bool:
        """Solve for the latest gizmo target, if any; True when the arm moved."""
        with self._lock:
            target, self._target = self._target, None
        if target is None:
            if self._snap_pending:  # after a drag the gizmo returns onto the reached hand
                self._snap_pending = False
                self.snap_gizmo()
            return False
        position, rotation, frames = target
        try:
            result = solve_ik(
                self.arm,
                position,
                self.q,
                target_rotation=rotation,
                lock_torso=self.lock_torso,
                max_iterations=ITERATIONS_PER_FRAME,
            )
        except ValueError:
            return False
        if not result.reached and frames + 1 < FRAMES_PER_AIM:
            with self._lock:  # solved on at the next frame, unless a newer aim came
                if self._target is None:
                    self._target = (position, rotation, frames + 1)
        self.last = result
        self.set_q(result.q, move_gizmo=False)
        return True

    def set_q(self, q: np.ndarray, move_gizmo: bool = True) -> None:
        """Show the arm configuration ``q`` (e.g. during a replay)."""
        self.q = self.arm.clip(np.asarray(q, dtype=float))
        self.hand_history.record(self.arm.position(self.q))
        self.robot.set_configuration(self.arm.into_full(self.q, self.robot.q))
        if move_gizmo:
            self.snap_gizmo()

    def snap_gizmo(self) -> None:
        """Put the gizmo back on the hand (after an out-of-reach drag, or a replay)."""
        pose = self.hand_pose()
        self.gizmo.position = pose[:3, 3]
        self.gizmo.wxyz = vtf.SO3.from_matrix(pose[:3, :3]).wxyz

    def move_hand_to(self, position: np.ndarray) -> IKResult:
        """Solve and show the arm reaching ``position`` (position only); gizmo follows.

        A long move (a replay step after the loop stalled, a jump to a new path) is solved as
        a chain of short ones along the straight line, each warm-started from the previous, as
        if the hand had been dragged there: one long jump can end in a joint-limit corner that
        short steps never visit.
        """
        position = np.asarray(position, dtype=float)
        start = self.hand_position()
        n_steps = max(1, int(np.ceil(np.linalg.norm(position - start) / MAX_IK_STEP_M)))
        q = self.q
        for k in range(1, n_steps + 1):
            target = start + (position - start) * (k / n_steps)
            result = solve_ik(self.arm, target, q, lock_torso=self.lock_torso)
            q = result.q
        self.last = result
        self.set_q(result.q)
        return result
