"""Where the partner looks, and how their head follows, in the simulated experiment.

Gaze in object manipulation jumps from landmark to landmark ahead of the hand, and people
watching someone else's manipulation do the same (Johansson et al. 2001, "Eye-hand coordination
in object manipulation": the grasp site, the tip of the obstacle the object has to clear, the
target, each reached by the eyes before the hand; Flanagan and Johansson 2003, "Action plans
used in action observation"). :func:`landmark_gaze` fixates the landmarks of a movement in turn;
:func:`head_angles_following` turns the head towards the gaze with a first-order lag and adds
the noise of a webcam head-pose estimator: white noise plus a slow drift (Ornstein-Uhlenbeck)
on each angle and a per-demonstration roll bias. Angles follow the convention of
:mod:`robots.icub.scene` (radians, zero when looking at the robot's eyes).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from robots.icub.scene import head_orientation_looking_at


class HeadBehaviour(Protocol):
    """How the simulated partner's head moves (:class:`robots.icub.scenario.ScenarioParams`
    is one): time constants in s, angles in degrees."""

    head_lag: tuple[float, float]
    head_noise_deg: float
    head_drift_deg: float
    head_drift_time: float
    roll_bias_deg: float


def landmark_gaze(
    times: np.ndarray, landmarks: np.ndarray, arrivals: np.ndarray, shift: float, lead: float
) -> np.ndarray:
    """Where the partner looks, shape (n, 3): fixations on the landmarks of the movement.

    The gaze is on ``landmarks[0]`` (the object, where the hand starts) until ``shift`` s after
    the start, then on each next landmark in turn; it leaves an intermediate landmark (the
    apex) ``lead`` s before the hand reaches it, and stays on the last one (the drop point).

    Parameters
    ----------
    times : array, shape (n,)
        Seconds from the start of the movement.
    landmarks : array, shape (n_landmarks, 3)
    arrivals : array, shape (n_landmarks,)
        When the hand reaches each landmark.
    shift, lead : float
        Seconds.
    """
    switches = [shift] + [max(shift, float(a) - lead) for a in arrivals[1:-1]]
    index = np.searchsorted(np.maximum.accumulate(switches), times, side="right")
    return np.asarray(landmarks, dtype=float)[index]


def head_angles_following(
    times: np.ndarray,
    looked_at: np.ndarray,
    head_position: np.ndarray,
    rng: np.random.Generator,
    params: HeadBehaviour,
) -> np.ndarray:
    """The partner's head angles while looking at ``looked_at``, shape (n, 3): roll, pitch, yaw.

    The head turns towards where the gaze is with a first-order lag (``head_lag``), and the
    estimator's noise is added (see the module docstring). Radians.

    Parameters
    ----------
    times : array, shape (n,)
    looked_at : array, shape (n, 3)
        Where the gaze is at ``times``.
    head_position : array, shape (3,)
    rng : numpy.random.Generator
    params : HeadBehaviour
    """
    lag = rng.uniform(*params.head_lag)
    _, pitch, yaw = head_orientation_looking_at(looked_at, head_position)
    wanted = np.column_stack([np.zeros_like(pitch), pitch, yaw])
    head = np.empty_like(wanted)
    head[0] = wanted[0]
    for k in range(1, len(times)):
        a = np.exp(-(times[k] - times[k - 1]) / lag)
        head[k] = a * head[k - 1] + (1.0 - a) * wanted[k]

    n = len(times)
    white = rng.normal(scale=np.deg2rad(params.head_noise_deg), size=(n, 3))
    drift = np.empty((n, 3))
    drift_std = np.deg2rad(params.head_drift_deg)
    drift[0] = rng.normal(scale=drift_std, size=3)
    for k in range(1, n):  # Ornstein-Uhlenbeck, exact discretisation
        a = np.exp(-(times[k] - times[k - 1]) / params.head_drift_time)
        drift[k] = a * drift[k - 1] + np.sqrt(1.0 - a * a) * drift_std * rng.normal(size=3)
    roll_bias = np.deg2rad(params.roll_bias_deg) * rng.normal()
    head[:, 0] += roll_bias
    return head + white + drift
