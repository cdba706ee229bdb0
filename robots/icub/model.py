"""Load the iCub URDF shipped by the ``icub-models`` package.

Nothing is vendored: the URDF and its meshes are resolved inside the installed package
(``<prefix>/share/iCub``). Mesh references in the URDF look like ``package://iCub/meshes/...``.

Frames: the URDF root (``root_link``, the waist) is the world frame of the whole studio. In it z is
up, the robot faces -x and its left is -y.
"""

from __future__ import annotations

from pathlib import Path

import icub_models
import numpy as np
import yourdfpy

DEFAULT_ROBOT = "iCubNancy01"
SOLE_FRAME = "l_sole"

# A relaxed standing pose, well inside every joint limit: arms hanging forward with the elbows
# bent, the left hand above the table. Unlisted joints stay at 0 (inside their limits).
_NATURAL_POSE = {
    "l_shoulder_pitch": -0.3,
    "l_shoulder_roll": 0.4,
    "l_shoulder_yaw": 0.1,
    "l_elbow": 1.2,
    "l_wrist_prosup": 0.0,
    "l_wrist_pitch": -0.1,
    "r_shoulder_pitch": -0.3,
    "r_shoulder_roll": 0.4,
    "r_shoulder_yaw": 0.1,
    "r_elbow": 1.2,
    "r_wrist_pitch": -0.1,
}


def share_dir() -> Path:
    """The ``share/iCub`` folder of the installed ``icub-models`` package."""
    return icub_models.get_models_path().parent


def available_robots() -> list[str]:
    """Names of the robots shipped by ``icub-models`` that have a URDF, sorted."""
    root = icub_models.get_models_path()
    return sorted(d.name for d in root.iterdir() if (d / "model.urdf").is_file())


def urdf_path(robot: str = DEFAULT_ROBOT) -> Path:
    """Path of the URDF of ``robot``.

    Raises
    ------
    ValueError
        If ``icub-models`` has no robot of that name; the message lists the valid names.
    """
    names = available_robots()
    if robot not in names:
        raise ValueError(f"unknown robot {robot!r}: icub-models ships {', '.join(names)}")
    return icub_models.get_model_file(robot)


def _resolve_mesh(fname: str) -> str:
    """Map ``package://iCub/...`` mesh references to files inside the installed package."""
    prefix = "package://iCub/"
    if fname.startswith(prefix):
        return str(share_dir() / fname[len(prefix) :])
    return fname


def load_urdf(robot: str = DEFAULT_ROBOT, load_meshes: bool = True) -> yourdfpy.URDF:
    """Load the URDF of ``robot``, with its visual meshes unless ``load_meshes`` is False.

    Raises
    ------
    ValueError
        If the robot name is unknown.
    """
    return yourdfpy.URDF.load(
        str(urdf_path(robot)),
        filename_handler=_resolve_mesh,
        load_meshes=load_meshes,
        build_scene_graph=True,
        load_collision_meshes=False,
        build_collision_scene_graph=False,
    )


def natural_pose(urdf: yourdfpy.URDF) -> np.ndarray:
    """A natural standing pose, shape (n_actuated,), ordered like ``urdf.actuated_joint_names``.

    Every value is clipped into its joint's limits (the all-zero pose violates the elbow limit).
    """
    q = np.zeros(len(urdf.actuated_joint_names))
    for i, name in enumerate(urdf.actuated_joint_names):
        q[i] = _NATURAL_POSE.get(name, 0.0)
        limit = urdf.joint_map[name].limit
        if limit is not None and limit.lower is not None and limit.upper is not None:
            q[i] = float(np.clip(q[i], limit.lower, limit.upper))
    return q


def ground_height(urdf: yourdfpy.URDF) -> float:
    """Height of the ground (the soles) in the root frame, in metres (negative: below the waist)."""
    return float(urdf.get_transform(SOLE_FRAME, urdf.base_link)[2, 3])
