"""The smoothing of the head angles over a sequence of frames: a One-Euro filter
(:mod:`app.headpose.filter`), or none, and the time order it needs."""

from __future__ import annotations

import numpy as np

from app.headpose.filter import OneEuroConfig, OneEuroFilter

#: Smoothing used when the caller does not choose: tuned for 30-60 fps, angles in radians.
DEFAULT_SMOOTHING = OneEuroConfig(min_cutoff=1.0, beta=4.0, d_cutoff=1.0)


class AngleSmoothing:
    """The angles' One-Euro filter over frames in time order, or no smoothing at all.

    Parameters
    ----------
    config : OneEuroConfig or None
        The filter's settings; None: the angles pass unchanged and frames may come in any order.
    """

    def __init__(self, config: OneEuroConfig | None = DEFAULT_SMOOTHING) -> None:
        if config is not None and not isinstance(config, OneEuroConfig):
            raise ValueError(f"smoothing must be a OneEuroConfig or None, got {config!r}")
        self._filter = None if config is None else OneEuroFilter(config)
        self._last_t: float | None = None  # the last frame's time, face or not

    def admit(self, t: float) -> None:
        """Take the next frame's time (seconds, finite).

        Raises
        ------
        ValueError
            With smoothing on, when ``t`` is not after the previous frame's (nothing changes).
        """
        if self._filter is not None and self._last_t is not None and t <= self._last_t:
            raise ValueError(
                f"timestamps must increase when smoothing is on: got t={t} after "
                f"t={self._last_t} (call reset() to start a new sequence)"
            )
        self._last_t = t

    def __call__(self, angles: np.ndarray, t: float) -> np.ndarray:
        """The smoothed ``(roll, pitch, yaw)`` at ``t``, radians, shape (3,)."""
        return angles if self._filter is None else self._filter(angles, t)

    def forget(self) -> None:
        """Forget the angles' history (the face was lost, or zero moved): the next angles pass
        unchanged. The frames' time order is kept."""
        if self._filter is not None:
            self._filter.reset()

    def restart(self) -> None:
        """A new sequence: forget the history and the last frame's time."""
        self.forget()
        self._last_t = None
