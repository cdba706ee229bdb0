"""The iCub: URDF from the ``icub-models`` package, its left arm, and the simulated scene.

Modules: ``model`` (URDF loading, natural pose), ``kinematics`` (left-arm chain: FK, Jacobian),
``ik`` (inverse kinematics), ``scene`` (table, object, bins, partner's head and its angle
convention), ``layout`` (the studio's modalities: hand and head), ``scenario`` (simulated
demonstrations; ``python -m robots.icub.scenario``) over ``motion`` (the hand's path and
timing) and ``gaze`` (where the partner looks, how the head follows).
"""

from robots.icub.ik import IKResult, solve_ik
from robots.icub.kinematics import ARM_JOINTS, ArmChain, load_arm
from robots.icub.model import DEFAULT_ROBOT, available_robots, load_urdf, natural_pose
from robots.icub.scene import DEFAULT_SCENE, Scene

__all__ = [
    "ARM_JOINTS",
    "DEFAULT_ROBOT",
    "DEFAULT_SCENE",
    "ArmChain",
    "IKResult",
    "Scene",
    "available_robots",
    "load_arm",
    "load_urdf",
    "natural_pose",
    "solve_ik",
]
