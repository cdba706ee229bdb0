"""Time modulation: the phase, alpha, and durations (one convention, used everywhere).

A primitive lives on the phase z in [0, 1]. A movement recorded at sample period ``dt`` that
lasts ``T`` seconds spans ``n = T / dt + 1`` samples and has the time modulation

    alpha = s_bar / n,            so   n = s_bar / alpha   and   T = (s_bar / alpha - 1) * dt.

A sample taken ``t`` seconds after the movement started has phase ``z = t / T``. With uniform
sampling ``n`` is just the number of samples, as in the paper (``alpha = s_bar / n``); writing it
through the duration keeps phases right when a few samples are missing. ``s_bar`` (default 100)
is only a reference length: alpha = 1 means a movement of ``s_bar`` samples.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "alpha_from_duration", "check_alpha", "demo_phases", "duration_from_alpha", "n_observed_for",
    "n_samples_from_alpha", "phases"
]  # fmt: skip


def check_alpha(alpha: float | np.ndarray) -> None:
    if not np.all(np.isfinite(alpha)) or np.any(np.asarray(alpha) <= 0):
        raise ValueError(f"alpha must be a positive finite number, got {alpha}")


def alpha_from_duration(duration: float, dt: float, s_bar: float) -> float:
    """Alpha of a movement lasting ``duration`` seconds sampled every ``dt`` seconds."""
    return float(s_bar / (duration / dt + 1.0))


def n_samples_from_alpha(alpha: float | np.ndarray, s_bar: float) -> float | np.ndarray:
    """Predicted length in samples, ``s_bar / alpha`` (not rounded)."""
    check_alpha(alpha)
    return s_bar / np.asarray(alpha, dtype=float)


def duration_from_alpha(alpha: float | np.ndarray, dt: float, s_bar: float) -> float | np.ndarray:
    """Predicted duration in seconds, ``(s_bar / alpha - 1) * dt``."""
    return (n_samples_from_alpha(alpha, s_bar) - 1.0) * dt


def phases(elapsed: np.ndarray, duration: float) -> np.ndarray:
    """Phases of samples taken ``elapsed`` seconds after the start of a movement of ``duration``."""
    if not np.isfinite(duration) or duration <= 0:
        raise ValueError(f"duration must be positive, got {duration}")
    return np.asarray(elapsed, dtype=float) / duration


def demo_phases(times: np.ndarray) -> np.ndarray:
    """Phases of a whole demonstration's samples: 0 at the first, 1 at the last."""
    times = np.asarray(times, dtype=float)
    return (times - times[0]) / (times[-1] - times[0])


def n_observed_for(percent: float, n_samples: int) -> int:
    """The samples seen when ``percent`` % of an ``n_samples`` movement is observed:
    ``ceil(p / 100 * n)``, at least 1 (the evaluation's rule, and the studio's).

    Raises
    ------
    ValueError
        If ``percent`` is not in (0, 100] or ``n_samples`` < 1.
    """
    if not math.isfinite(percent) or not 0.0 < percent <= 100.0:
        raise ValueError(f"the observed percentage must be in (0, 100], got {percent}")
    if n_samples < 1:
        raise ValueError(f"a movement has at least one sample, got {n_samples}")
    return max(1, math.ceil(percent / 100.0 * n_samples - 1e-9))
