"""The neutral pose: what zero roll, pitch and yaw mean.

Geometrically, zero is facing the camera (``line_of_sight=True``: looking along the line from the
head to the camera) or facing along the camera's optical axis
(:func:`app.headpose.pose.neutral_frame`). A calibration turns that zero to the partner's own
resting pose: ``R = R_calibration.T @ R_cam_neutral.T @ R_cam_head`` (the package docstring).
"""

from __future__ import annotations

import numpy as np

from app.headpose.pose import euler_zyx, neutral_frame, rotation_zyx


class NeutralPose:
    """The zero of the head angles: the geometric neutral frame and the calibration on top.

    Parameters
    ----------
    line_of_sight : bool
        True: zero means facing the camera wherever the face is in the image. False: zero
        means facing along the camera's optical axis.

    Attributes
    ----------
    calibration : array, shape (3, 3)
        The calibrated neutral, relative to the geometric neutral frame (the identity until
        :meth:`calibrate`).
    """

    def __init__(self, line_of_sight: bool = True) -> None:
        self.line_of_sight = bool(line_of_sight)
        self.calibration = np.eye(3)

    def angles(self, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
        """The head's ``(roll, pitch, yaw)`` relative to the neutral pose, radians, shape (3,).

        Parameters
        ----------
        rotation : array, shape (3, 3)
            The head frame in the camera frame (``R_cam_head``, from the PnP fit).
        translation : array, shape (3,)
            The head's position in the camera frame (where the line of sight starts).
        """
        neutral = neutral_frame(translation if self.line_of_sight else None)
        return np.array(euler_zyx(self.calibration.T @ neutral.T @ rotation))

    def calibrate(self, angles: np.ndarray) -> None:
        """Make the pose at ``angles`` (radians, as :meth:`angles` gave them) the new zero."""
        self.calibration = self.calibration @ rotation_zyx(*angles)

    def clear(self) -> None:
        """Drop the calibration: zero is the geometric neutral frame again."""
        self.calibration = np.eye(3)
