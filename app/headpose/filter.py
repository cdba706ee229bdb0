"""The One-Euro filter: adaptive low-pass smoothing that does not lag fast movements.

Casiez, Roussel and Vogel, "1 Euro Filter: A Simple Speed-based Low-pass Filter for Noisy Input
in Interactive Systems", CHI 2012. Each sample is low-passed with an exponential smoother whose
cut-off frequency rises with the (itself low-passed) speed of the signal:
``cutoff = min_cutoff + beta * |dx/dt|``. Still heads get strong smoothing (jitter removed);
fast turns get a high cut-off and are followed with little lag.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class OneEuroConfig:
    """Settings of the One-Euro filter.

    Parameters
    ----------
    min_cutoff : float
        Cut-off frequency at rest, Hz. Lower = smoother when the head is still.
    beta : float
        Speed coefficient, s/rad for angles: how fast the cut-off rises with speed. Higher = less
        lag on fast turns. 0 gives a plain first-order low-pass at ``min_cutoff``.
    d_cutoff : float
        Cut-off frequency of the speed estimate, Hz.
    """

    min_cutoff: float = 1.0
    beta: float = 0.3
    d_cutoff: float = 1.0

    def __post_init__(self) -> None:
        for name in ("min_cutoff", "d_cutoff"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive frequency in Hz, got {value}")
        if not (math.isfinite(self.beta) and self.beta >= 0):
            raise ValueError(f"beta must be >= 0, got {self.beta}")


def _alpha(cutoff: np.ndarray | float, dt: float) -> np.ndarray | float:
    tau = 1.0 / (2.0 * math.pi * cutoff)
    return 1.0 / (1.0 + tau / dt)


class OneEuroFilter:
    """One-Euro filter over a vector of channels sharing the same timestamps.

    Parameters
    ----------
    config : OneEuroConfig
        Filter settings.
    """

    def __init__(self, config: OneEuroConfig | None = None) -> None:
        self.config = OneEuroConfig() if config is None else config
        self._t: float | None = None
        self._x: np.ndarray | None = None
        self._dx: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the history: the next sample passes through unchanged."""
        self._t = None
        self._x = None
        self._dx = None

    def __call__(self, x: np.ndarray, t: float) -> np.ndarray:
        """Filter one sample.

        Parameters
        ----------
        x : array, shape (n_channels,)
            The raw sample.
        t : float
            Its time in seconds; strictly greater than the previous sample's.

        Returns
        -------
        array, shape (n_channels,)
            The filtered sample (a new array).
        """
        value = np.array(x, dtype=np.float64, ndmin=1)
        if not np.all(np.isfinite(value)) or not math.isfinite(t):
            raise ValueError("One-Euro filter input and time must be finite")
        if self._x is None or self._t is None:
            self._t, self._x, self._dx = float(t), value, np.zeros_like(value)
            return value.copy()
        if value.shape != self._x.shape:
            raise ValueError(f"expected a sample of shape {self._x.shape}, got {value.shape}")
        dt = float(t) - self._t
        if dt <= 0:
            raise ValueError(f"timestamps must increase: got t={t} after t={self._t}")
        cfg = self.config
        speed = (value - self._x) / dt
        dx = self._dx + _alpha(cfg.d_cutoff, dt) * (speed - self._dx)
        cutoff = cfg.min_cutoff + cfg.beta * np.abs(dx)
        filtered = self._x + _alpha(cutoff, dt) * (value - self._x)
        self._t, self._x, self._dx = float(t), filtered, dx
        return filtered.copy()
