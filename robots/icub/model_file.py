"""The iCub as one 3-D model file: its visual meshes (the URDF's, from ``icub-models``) placed
at given joint angles, as glTF binary (``.glb``) in the root frame, metres.

Viewers draw it as it is (Rerun's ``Asset3D``, Foxglove's ``ModelPrimitive``). Rerun's own URDF
importer cannot read ``icub-models``' URDF as shipped (empty ``<texture/>`` elements, which it
refuses: "missing field `filename`"; ``package://`` mesh paths; Collada meshes), so the meshes
and the joints' transforms are ours: yourdfpy's, as the studio draws them.

The URDF is loaded once, for the files alone (not the studio's own instance, which its loop
moves): :func:`robot_glb` holds a lock while it poses it.
"""

from __future__ import annotations

import functools
import threading

import numpy as np
import trimesh.transformations as tra
import yourdfpy

from robots.icub.model import DEFAULT_ROBOT, load_urdf, natural_pose

__all__ = ["joint_matrix", "robot_glb"]

_LOCK = threading.Lock()


@functools.lru_cache(maxsize=2)
def _urdf(robot: str) -> yourdfpy.URDF:
    return load_urdf(robot)


def joint_matrix(joint: yourdfpy.Joint, value: float) -> np.ndarray:
    """The transform (4, 4) from ``joint``'s parent link to its child at ``value`` (rad, or m
    for a prismatic joint); the origin alone for a fixed joint."""
    origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
    if joint.type == "prismatic":
        return origin @ tra.translation_matrix(value * np.asarray(joint.axis, dtype=float))
    if joint.type in ("revolute", "continuous"):
        return origin @ tra.rotation_matrix(value, joint.axis)
    return origin


def robot_glb(q: np.ndarray | None = None, robot: str = DEFAULT_ROBOT) -> bytes:
    """The robot's visual meshes at the actuated joint angles ``q`` (shape (n_actuated,),
    radians, ``urdf.actuated_joint_names``' order; default its natural pose), as ``.glb``.

    Raises
    ------
    ValueError
        An unknown robot, or ``q`` of another length than the robot's actuated joints.
    """
    with _LOCK:
        urdf = _urdf(robot)
        q = natural_pose(urdf) if q is None else np.asarray(q, dtype=float)
        if q.shape != (len(urdf.actuated_joint_names),) or not np.all(np.isfinite(q)):
            n = len(urdf.actuated_joint_names)
            raise ValueError(f"{robot} has {n} actuated joints; finite angles of that many "
                             f"expected, got shape {q.shape}")  # fmt: skip
        scene = urdf.scene
        for joint, value in zip(urdf.actuated_joints, q, strict=True):
            scene.graph.update(frame_from=joint.parent, frame_to=joint.child,
                               matrix=joint_matrix(joint, float(value)))  # fmt: skip
        return scene.export(file_type="glb")
