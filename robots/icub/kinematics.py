"""The iCub's left-arm chain in numpy: forward kinematics and the geometric Jacobian.

The chain is read from the URDF by walking its joints from the root link to the hand frame
``l_hand_dh_frame``: every fixed joint in between is folded into a constant transform, so one
forward-kinematics call is a handful of small matrix products (tens of microseconds).

Joint order (the 10 "arm joints" everywhere in ``robots.icub``): the three torso joints in the order
they appear from the root (``torso_pitch``, ``torso_roll``, ``torso_yaw``), then the seven joints of
the left arm from the shoulder to the wrist. Poses and Jacobians are in the root frame of the URDF
(the studio's world frame: z up, the robot faces -x, its left is -y).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import yourdfpy

from robots.icub.model import DEFAULT_ROBOT, load_urdf, natural_pose

TORSO_JOINTS = ("torso_pitch", "torso_roll", "torso_yaw")
LEFT_ARM_JOINTS = (
    "l_shoulder_pitch",
    "l_shoulder_roll",
    "l_shoulder_yaw",
    "l_elbow",
    "l_wrist_prosup",
    "l_wrist_pitch",
    "l_wrist_yaw",
)
ARM_JOINTS = TORSO_JOINTS + LEFT_ARM_JOINTS
N_TORSO = len(TORSO_JOINTS)
HAND_FRAME = "l_hand_dh_frame"

_MOVABLE = ("revolute", "continuous")


def _readonly(array: np.ndarray) -> np.ndarray:
    out = np.array(array, dtype=float, copy=True)
    out.setflags(write=False)
    return out


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@dataclass(frozen=True, eq=False)
class ArmChain:
    """A serial chain of revolute joints with constant transforms in between.

    Build it with :meth:`from_urdf` (or :func:`load_arm` for an ``icub-models`` robot).

    Attributes
    ----------
    joint_names : tuple of str, length n_joints
        The movable joints from the base to the tip.
    lower, upper : array, shape (n_joints,)
        Joint limits in radians (``-inf``/``inf`` for continuous joints).
    rest : array, shape (n_joints,)
        A natural configuration inside the limits (the IK's preferred posture).
    base_frame, tip_frame : str
        The URDF links the chain starts and ends at.
    full_index : array of int, shape (n_joints,)
        Position of each joint in the URDF's ``actuated_joint_names``.
    n_full : int
        Number of actuated joints of the whole URDF.
    """

    joint_names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    rest: np.ndarray
    base_frame: str
    tip_frame: str
    full_index: np.ndarray
    n_full: int
    # Constant transform from the previous joint's frame to joint i's frame, shape (n, 4, 4);
    # the unit axes in the joint frames, shape (n, 3); the joint-to-tip transform, shape (4, 4).
    _pre: np.ndarray = field(repr=False)
    _axes: np.ndarray = field(repr=False)
    _tip: np.ndarray = field(repr=False)
    _skews: np.ndarray = field(init=False, repr=False)
    _skews2: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("lower", "upper", "rest", "_pre", "_axes", "_tip"):
            object.__setattr__(self, name, _readonly(getattr(self, name)))
        full_index = np.array(self.full_index, dtype=int)
        full_index.setflags(write=False)
        object.__setattr__(self, "full_index", full_index)
        skews = np.array([_skew(a) for a in self._axes]).reshape(-1, 3, 3)
        object.__setattr__(self, "_skews", _readonly(skews))
        object.__setattr__(self, "_skews2", _readonly(skews @ skews))

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_urdf(
        cls,
        urdf: yourdfpy.URDF,
        joint_names: tuple[str, ...] = ARM_JOINTS,
        tip_frame: str = HAND_FRAME,
        base_frame: str | None = None,
    ) -> ArmChain:
        """Walk ``urdf`` from ``base_frame`` (default: its root link) to ``tip_frame``.

        Parameters
        ----------
        urdf : yourdfpy.URDF
            The robot description.
        joint_names : tuple of str
            The movable joints the chain must contain, in order from the base.
        tip_frame, base_frame : str
            End and start links of the chain.

        Raises
        ------
        ValueError
            If a link is missing, the tip is not below the base, the movable joints on the path
            are not exactly ``joint_names``, or a joint on the path is neither fixed nor revolute.
        """
        if not joint_names:
            raise ValueError("an arm chain needs at least one movable joint")
        base = urdf.base_link if base_frame is None else base_frame
        path = _joint_path(urdf, base, tip_frame)

        movable = [j.name for j in path if j.type != "fixed"]
        if tuple(movable) != tuple(joint_names):
            missing = [n for n in joint_names if n not in movable]
            raise ValueError(
                f"the URDF's chain {base!r} -> {tip_frame!r} has movable joints {movable}, "
                f"expected {list(joint_names)}" + (f" (missing {missing})" if missing else "")
            )
        pre, axes, lower, upper = [], [], [], []
        acc = np.eye(4)
        for joint in path:
            origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
            acc = acc @ origin
            if joint.type == "fixed":
                continue
            axis, lo, hi = _axis_and_limits(joint)
            pre.append(acc)
            axes.append(axis)
            lower.append(lo)
            upper.append(hi)
            acc = np.eye(4)

        names = list(urdf.actuated_joint_names)
        full_index = [names.index(n) for n in joint_names]
        full_rest = natural_pose(urdf)
        rest = np.clip(full_rest[full_index], lower, upper)
        return cls(
            joint_names=tuple(joint_names),
            lower=np.array(lower),
            upper=np.array(upper),
            rest=rest,
            base_frame=base,
            tip_frame=tip_frame,
            full_index=np.array(full_index),
            n_full=len(names),
            _pre=np.array(pre).reshape(-1, 4, 4),
            _axes=np.array(axes).reshape(-1, 3),
            _tip=acc,
        )

    # ------------------------------------------------------------------ properties

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    # ------------------------------------------------------------------ checks and mapping

    def check_q(self, q: np.ndarray, what: str = "q") -> np.ndarray:
        """``q`` as a float array of shape (n_joints,).

        Raises
        ------
        ValueError
            If ``q`` has another shape or contains NaN/inf.
        """
        arr = np.asarray(q, dtype=float)
        if arr.shape != (self.n_joints,):
            raise ValueError(
                f"{what} must have shape ({self.n_joints},) (joints {', '.join(self.joint_names)})"
                f", got {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{what} contains NaN or infinite values: {arr}")
        return arr

    def within_limits(self, q: np.ndarray, tol: float = 1e-9) -> bool:
        """True if every joint of ``q``, shape (n_joints,), is inside its limits (+- ``tol``)."""
        arr = self.check_q(q)
        return bool(np.all(arr >= self.lower - tol) and np.all(arr <= self.upper + tol))

    def clip(self, q: np.ndarray) -> np.ndarray:
        """``q``, shape (n_joints,), clipped into the joint limits (a new array)."""
        return np.clip(self.check_q(q), self.lower, self.upper)

    def from_full(self, q_full: np.ndarray) -> np.ndarray:
        """The arm joints, shape (n_joints,), of a full URDF configuration, shape (n_full,)."""
        arr = np.asarray(q_full, dtype=float)
        if arr.shape != (self.n_full,):
            raise ValueError(
                f"a full configuration has shape ({self.n_full},) (the URDF's actuated joints), "
                f"got {arr.shape}"
            )
        return arr[self.full_index].copy()

    def into_full(self, q: np.ndarray, q_full: np.ndarray) -> np.ndarray:
        """A copy of ``q_full``, shape (n_full,), with the arm joints set to ``q``.

        ``q`` has shape (n_joints,); ``q_full`` is ordered like the URDF's
        ``actuated_joint_names`` (yourdfpy's configuration vector).
        """
        arm = self.check_q(q)
        out = np.array(q_full, dtype=float, copy=True)
        if out.shape != (self.n_full,):
            raise ValueError(
                f"a full configuration has shape ({self.n_full},) (the URDF's actuated joints), "
                f"got {out.shape}"
            )
        out[self.full_index] = arm
        return out

    # ------------------------------------------------------------------ kinematics

    def _frames(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint frames, shape (n, 4, 4), and the tip pose, shape (4, 4); no input checks."""
        s = np.sin(q)[:, None, None]
        c = np.cos(q)[:, None, None]
        # Rodrigues: R = I + sin K + (1 - cos) K^2, all joints at once.
        local = self._pre.copy()
        local[:, :3, :3] = self._pre[:, :3, :3] @ (
            np.eye(3) + s * self._skews + (1.0 - c) * self._skews2
        )
        frames = np.empty_like(local)
        t = local[0]
        frames[0] = t
        for i in range(1, local.shape[0]):
            t = t @ local[i]
            frames[i] = t
        return frames, t @ self._tip

    def _fk_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        frames, tip = self._frames(q)
        z = np.einsum("nij,nj->ni", frames[:, :3, :3], self._axes)
        d = tip[:3, 3] - frames[:, :3, 3]
        jac = np.empty((6, q.shape[0]))
        jac[0] = z[:, 1] * d[:, 2] - z[:, 2] * d[:, 1]
        jac[1] = z[:, 2] * d[:, 0] - z[:, 0] * d[:, 2]
        jac[2] = z[:, 0] * d[:, 1] - z[:, 1] * d[:, 0]
        jac[3:] = z.T
        return tip, jac

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Pose of the tip frame in the base frame.

        Parameters
        ----------
        q : array, shape (n_joints,)
            Joint angles in radians, in :attr:`joint_names` order.

        Returns
        -------
        array, shape (4, 4)
            Homogeneous transform of the tip in the base frame.
        """
        return self._frames(self.check_q(q))[1]

    def position(self, q: np.ndarray) -> np.ndarray:
        """Tip position in the base frame, shape (3,), for ``q`` of shape (n_joints,)."""
        return self.fk(q)[:3, 3].copy()

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Geometric Jacobian of the tip, shape (6, n_joints), in the base frame.

        Rows 0-2 map joint velocities to the tip's linear velocity, rows 3-5 to its angular
        velocity, both expressed in the base frame.
        """
        return self._fk_jacobian(self.check_q(q))[1]

    def fk_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tip pose, shape (4, 4), and geometric Jacobian, shape (6, n_joints), in one pass."""
        return self._fk_jacobian(self.check_q(q))

    def random_configurations(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` configurations drawn uniformly inside the (finite) limits, shape (n, n_joints)."""
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        return rng.uniform(lo, hi, size=(int(n), self.n_joints))


@lru_cache(maxsize=8)
def load_arm(robot: str = DEFAULT_ROBOT) -> ArmChain:
    """The left-arm chain (torso + arm, see the module docstring) of an ``icub-models`` robot.

    Cached: the chain is immutable, loading the URDF takes about a second.

    Raises
    ------
    ValueError
        If the robot name is unknown or its URDF lacks the chain.
    """
    return ArmChain.from_urdf(load_urdf(robot, load_meshes=False))


def _joint_path(urdf: yourdfpy.URDF, base: str, tip: str) -> list:
    """The joints of ``urdf`` from link ``base`` down to link ``tip``, in order.

    Raises
    ------
    ValueError
        A link the URDF does not have, or ``tip`` not below ``base``.
    """
    links = set(urdf.link_map)
    for role, link in (("tip", tip), ("base", base)):
        if link not in links:
            raise ValueError(
                f"the URDF has no {role} link {link!r}: it cannot hold the iCub's left-arm "
                f"chain ({base!r} -> {tip!r})"
            )
    parent_joint = {j.child: j for j in urdf.robot.joints}
    path = []
    link = tip
    while link != base:
        if link not in parent_joint:
            raise ValueError(f"link {tip!r} is not below {base!r} in the URDF tree")
        joint = parent_joint[link]
        path.append(joint)
        link = joint.parent
    path.reverse()
    return path


def _axis_and_limits(joint) -> tuple[np.ndarray, float, float]:
    """A movable joint's unit axis (3,) and its limits (radians; infinite when continuous).

    Raises
    ------
    ValueError
        A joint neither revolute nor continuous, one that mimics another, without a valid
        axis, or revolute without limits (or with them inverted).
    """
    if joint.type not in _MOVABLE:
        raise ValueError(
            f"joint {joint.name!r} is {joint.type!r}: the arm chain supports only fixed, "
            "revolute and continuous joints"
        )
    if joint.mimic is not None:
        raise ValueError(f"joint {joint.name!r} mimics another joint: not supported")
    axis = np.asarray(joint.axis, dtype=float)
    norm = float(np.linalg.norm(axis))
    if not np.isfinite(norm) or norm < 1e-12:
        raise ValueError(f"joint {joint.name!r} has no valid axis ({joint.axis})")
    limit = joint.limit
    if joint.type == "revolute":
        if limit is None or limit.lower is None or limit.upper is None:
            raise ValueError(f"revolute joint {joint.name!r} has no limits in the URDF")
        lo, hi = float(limit.lower), float(limit.upper)
        if not lo <= hi:
            raise ValueError(f"joint {joint.name!r}: lower limit {lo} > upper {hi}")
    else:
        lo, hi = -np.inf, np.inf
    return axis / norm, lo, hi
