"""Inverse kinematics of the left arm: damped least squares with joint limits.

One solve is a Levenberg-Marquardt style iteration on the hand's position error (and, when a target
orientation is given, its weighted orientation error):

    dq = W J^T (J W J^T + mu I)^-1 e  +  (I - W J^T (J W J^T + mu I)^-1 J) k (q_rest - q)

- ``mu`` (the damping) grows with the squared error and adapts: a step that does not reduce the
  error is retried with more damping, so the iteration never diverges near singularities.
- Joint limits: every step is clipped into the limits, and a joint sitting on a limit that the
  step would push further out is taken out of the step (``W`` = 0 for it), so the other joints
  take over instead of the solve stalling against the limit.
- The second term pulls the arm towards a natural rest posture inside the null space of the task,
  which keeps it away from its limits and makes the solutions look human.
- Warm start from the current configuration: when the target moves little (dragging a gizmo),
  a solve takes a few iterations.

Out of reach, the iteration converges to the closest configuration it finds; the result says so
(``reached=False``) and reports the remaining error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robots.icub.kinematics import N_TORSO, ArmChain

# Damping mu = scale * (1e-6 + _DAMPING * |e|^2), in m^2: strong far from the target, vanishing
# near it (fast final convergence); the scale adapts to rejected and accepted steps.
_DAMPING = 0.1
# Stop when the task error has shrunk by less than _STALL_M over the last _STALL_WINDOW steps
# (out of reach: the closest configuration has been found).
_STALL_M = 1e-6
_STALL_WINDOW = 5
# A target counts as reached this close (the default ``position_tolerance``), metres.
POSITION_TOLERANCE_M = 1e-4


@dataclass(frozen=True, eq=False)
class IKResult:
    """Outcome of :func:`solve_ik`.

    Attributes
    ----------
    q : array, shape (n_joints,)
        The best configuration found (inside the joint limits), arm-joint order.
    reached : bool
        True if the position error is within the position tolerance and, when a target
        orientation was given, the orientation error within the orientation tolerance.
    position_error_m : float
        Distance from the hand to the target position, in metres.
    orientation_error_rad : float
        Angle between the hand's orientation and the target orientation, in radians; NaN when no
        target orientation was given.
    iterations : int
        Number of iterations run.
    position : array, shape (3,)
        The hand position reached, in the root frame.
    """

    q: np.ndarray
    reached: bool
    position_error_m: float
    orientation_error_rad: float
    iterations: int
    position: np.ndarray


def rotation_error(target: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Rotation vector, shape (3,), of ``target @ rotation.T`` (both shape (3, 3)).

    The axis-angle rotation (in the base frame) that takes ``rotation`` onto ``target``; its norm
    is the angle between them, in [0, pi].
    """
    r = target @ rotation.T
    v = 0.5 * np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    s = float(np.linalg.norm(v))
    c = 0.5 * (r[0, 0] + r[1, 1] + r[2, 2] - 1.0)
    angle = float(np.arctan2(s, c))
    if s > 1e-9:
        return v * (angle / s)
    if c > 0.0:
        return v  # angle ~ 0: the first-order rotation vector
    # angle ~ pi: the axis is the column of (R + I) / 2 with the largest norm.
    m = 0.5 * (r + np.eye(3))
    k = int(np.argmax(np.diag(m)))
    axis = m[:, k] / np.sqrt(max(m[k, k], 1e-300))
    return axis / np.linalg.norm(axis) * angle


def _check_vector(value: object, shape: tuple[int, ...], what: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{what} must be a numeric array of shape {shape}: {exc}") from exc
    if arr.shape != shape:
        raise ValueError(f"{what} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} contains NaN or infinite values: {arr.tolist()}")
    return arr


def _check_rotation(value: object) -> np.ndarray:
    rot = _check_vector(value, (3, 3), "target_rotation")
    if np.abs(rot @ rot.T - np.eye(3)).max() > 1e-6 or np.linalg.det(rot) < 0.0:
        raise ValueError("target_rotation must be a rotation matrix (orthonormal, det +1)")
    return rot


def _positive(value: float, what: str, allow_zero: bool = False) -> float:
    x = float(value)
    if not np.isfinite(x) or x < 0.0 or (x == 0.0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{what} must be a finite number {bound}, got {value!r}")
    return x


@dataclass(frozen=True, eq=False)
class _Problem:
    """One IK problem: the target, the tolerances and the joints that move (see
    :func:`solve_ik`), and the damped least-squares descent towards it."""

    arm: ArmChain
    p_target: np.ndarray
    r_target: np.ndarray | None
    w_rot: float
    tol_p: float
    tol_o: float
    active: np.ndarray
    q_rest: np.ndarray
    gain: float
    step_cap: float

    @property
    def lower(self) -> np.ndarray:
        return self.arm.lower[self.active]

    @property
    def upper(self) -> np.ndarray:
        return self.arm.upper[self.active]

    def evaluate(self, qq: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float, np.ndarray]:
        """The task error, its Jacobian over the active joints, the position and orientation
        errors and the hand's pose at ``qq``."""
        active, p_target, r_target, w_rot = self.active, self.p_target, self.r_target, self.w_rot
        pose, jac = self.arm._fk_jacobian(qq)
        e_pos = p_target - pose[:3, 3]
        if r_target is None:
            return e_pos, jac[:3, active], float(np.linalg.norm(e_pos)), np.nan, pose
        e_rot = rotation_error(r_target, pose[:3, :3])
        e = np.concatenate([e_pos, w_rot * e_rot])
        j = np.vstack([jac[:3, active], w_rot * jac[3:, active]])
        return e, j, float(np.linalg.norm(e_pos)), float(np.linalg.norm(e_rot)), pose

    def done(self, pos_err: float, rot_err: float) -> bool:
        return pos_err <= self.tol_p and (self.r_target is None or rot_err <= self.tol_o)

    def descend(self, q: np.ndarray, budget: int) -> tuple[np.ndarray, tuple, float, int]:
        """Iterate from ``q``; return the final configuration, its evaluation, cost, iterations."""
        active, lower, upper, gain = self.active, self.lower, self.upper, self.gain
        evaluate, done, step_cap = self.evaluate, self.done, self.step_cap
        eye_task = np.eye(3 if self.r_target is None else 6)
        state = evaluate(q)
        e, jac, pos_err, rot_err, _ = state
        cost = float(e @ e)
        damping_scale = 1.0
        iterations = 0
        history = [np.sqrt(cost)]
        while not done(pos_err, rot_err) and iterations < budget:
            iterations += 1
            qa = q[active]
            pull = gain * (self.q_rest[active] - qa)
            accepted = False
            for _ in range(8):
                mu = damping_scale * (1e-6 + _DAMPING * cost)
                weight = np.ones(active.shape[0])
                for _ in range(3):
                    jw = jac * weight
                    gain_matrix = jw.T @ np.linalg.solve(jw @ jac.T + mu * eye_task, eye_task)
                    pull_w = pull * weight
                    dq = gain_matrix @ e + pull_w - gain_matrix @ (jac @ pull_w)
                    pushing_out = ((qa <= lower + 1e-12) & (dq < 0.0)) | (
                        (qa >= upper - 1e-12) & (dq > 0.0)
                    )
                    if not np.any(pushing_out & (weight > 0.0)):
                        break
                    weight[pushing_out] = 0.0  # this joint is on a limit: the others take over
                largest = float(np.abs(dq).max())
                if largest > step_cap:
                    dq *= step_cap / largest
                candidate = q.copy()
                candidate[active] = np.clip(qa + dq, lower, upper)
                new = evaluate(candidate)
                new_cost = float(new[0] @ new[0])
                if new_cost <= cost * (1.0 + 1e-9) or new_cost < 1e-14:
                    accepted = True
                    break
                if pull.any():
                    pull = np.zeros_like(pull)  # the posture pull is a bonus: drop it first
                else:
                    damping_scale *= 10.0
            if not accepted:
                break  # no step reduces the error: a local minimum of the distance
            damping_scale = max(damping_scale * 0.3, 1.0)
            q, state, cost = candidate, new, new_cost
            e, jac, pos_err, rot_err, _ = state
            history.append(np.sqrt(cost))
            if (
                len(history) > _STALL_WINDOW
                and history[-1 - _STALL_WINDOW] - history[-1] < _STALL_M
            ):
                break
        return q, state, cost, iterations


def solve_ik(
    arm: ArmChain,
    target_position: np.ndarray,
    q0: np.ndarray | None = None,
    target_rotation: np.ndarray | None = None,
    *,
    orientation_weight: float = 0.1,
    lock_torso: bool = False,
    position_tolerance: float = POSITION_TOLERANCE_M,
    orientation_tolerance: float = 1e-2,
    max_iterations: int = 200,
    rest: np.ndarray | None = None,
    rest_gain: float = 0.05,
    max_step: float = 0.2,
    restarts: int = 0,
) -> IKResult:
    """Joint angles that bring the hand to ``target_position`` (and ``target_rotation``).

    Parameters
    ----------
    arm : ArmChain
        The chain (``robots.icub.kinematics.load_arm()``).
    target_position : array, shape (3,)
        Target hand position in the root frame, metres.
    q0 : array, shape (n_joints,), optional
        Start (warm start) configuration; default ``arm.rest``. Clipped into the limits first.
    target_rotation : array, shape (3, 3), optional
        Target hand orientation (rotation matrix in the root frame). Position only when None.
    orientation_weight : float
        Metres of position error one radian of orientation error is worth.
    lock_torso : bool
        Keep the three torso joints at their ``q0`` values and move only the 7 arm joints.
    position_tolerance : float
        Converged (``reached``) when the hand is this close to the target, metres.
    orientation_tolerance : float
        Orientation part of the convergence test, radians.
    max_iterations : int
        Iteration budget.
    rest : array, shape (n_joints,), optional
        Posture the null-space term pulls towards; default ``arm.rest``.
    rest_gain : float
        Gain of that pull per iteration (0 disables it).
    max_step : float
        Largest joint change per iteration, radians.
    restarts : int
        When the solve from ``q0`` does not reach the target, try again from this many random
        configurations (a fixed sequence: deterministic) and keep the best. Leave at 0 while
        dragging: a restart may jump to a distant posture.

    Returns
    -------
    IKResult
        The best configuration found and how close it got.

    Raises
    ------
    ValueError
        If a target or configuration has the wrong shape or contains NaN/inf, the rotation is
        not a rotation matrix, or a numeric option is out of range.
    """
    p_target = _check_vector(target_position, (3,), "target_position")
    r_target = None if target_rotation is None else _check_rotation(target_rotation)
    q = arm.clip(arm.rest if q0 is None else arm.check_q(q0, "q0"))
    q_rest = arm.clip(arm.rest if rest is None else arm.check_q(rest, "rest"))
    w_rot = _positive(orientation_weight, "orientation_weight", allow_zero=True)
    tol_p = _positive(position_tolerance, "position_tolerance")
    tol_o = _positive(orientation_tolerance, "orientation_tolerance")
    gain = _positive(rest_gain, "rest_gain", allow_zero=True)
    step_cap = _positive(max_step, "max_step")
    for name, value, low in (("max_iterations", max_iterations, 1), ("restarts", restarts, 0)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    if r_target is not None and w_rot == 0.0:
        raise ValueError("orientation_weight must be > 0 when a target_rotation is given")

    active = np.arange(N_TORSO if lock_torso else 0, arm.n_joints)
    problem = _Problem(arm, p_target, r_target, w_rot, tol_p, tol_o, active, q_rest, gain,
                       step_cap)  # fmt: skip
    lower, upper = problem.lower, problem.upper
    done, descend = problem.done, problem.descend
    best_q, best_state, best_cost, iterations = descend(q, int(max_iterations))
    if restarts and not done(best_state[2], best_state[3]):
        rng = np.random.default_rng(0)  # deterministic restarts
        for _ in range(int(restarts)):
            start = q.copy()
            start[active] = rng.uniform(
                np.where(np.isfinite(lower), lower, -np.pi),
                np.where(np.isfinite(upper), upper, np.pi),
            )
            q_try, state, cost, its = descend(start, int(max_iterations))
            iterations += its
            if done(state[2], state[3]):
                best_q, best_state = q_try, state
                break
            if cost < best_cost:
                best_q, best_state, best_cost = q_try, state, cost

    _, _, pos_err, rot_err, pose = best_state
    return IKResult(
        q=best_q,
        reached=done(pos_err, rot_err),
        position_error_m=pos_err,
        orientation_error_rad=rot_err,
        iterations=iterations,
        position=pose[:3, 3].copy(),
    )
