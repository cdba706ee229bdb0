"""The iCub: URDF from the ``icub-models`` package, its left arm, and the simulated scene."""

from robots.icub.model import DEFAULT_ROBOT, available_robots, load_urdf, natural_pose

__all__ = ["DEFAULT_ROBOT", "available_robots", "load_urdf", "natural_pose"]
