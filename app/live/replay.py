"""The robot finishes the movement: its hand follows the predicted path in real time.

After an inference, the path is the posterior mean hand position from the observation point to
the predicted end, timed by the predicted speed (it lasts the predicted remaining duration).
:class:`Replay` is advanced by the studio's loop (:meth:`Replay.step`, by the time elapsed since
the previous step), never blocking it; each step moves the hand through the IK
(``move_hand``, e.g. :meth:`app.scene.arm.ArmController.move_hand_to`, which also brings the gizmo
along).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np


class Replay:
    """Play, pause and reset a timed hand path (see the module docstring).

    Parameters
    ----------
    move_hand : callable
        ``move_hand(position (3,))`` puts the hand there (IK).
    clock : callable
        Monotonic seconds (injectable for tests).
    """

    def __init__(
        self,
        move_hand: Callable[[np.ndarray], object],
        clock: Callable[[], float] = time.monotonic,
    ):
        self.move_hand = move_hand
        self.clock = clock
        self.times = np.zeros(0)
        self.positions = np.zeros((0, 3))
        self.elapsed = 0.0
        self.playing = False
        self._last: float | None = None

    # ------------------------------------------------------------------ state

    @property
    def has_path(self) -> bool:
        return self.times.shape[0] >= 2

    @property
    def duration(self) -> float:
        """Seconds the whole path takes."""
        return float(self.times[-1] - self.times[0]) if self.has_path else 0.0

    @property
    def progress(self) -> float:
        """Fraction of the path played, in [0, 1]."""
        return min(1.0, self.elapsed / self.duration) if self.duration > 0 else 0.0

    @property
    def finished(self) -> bool:
        return self.has_path and self.elapsed >= self.duration

    def position_at(self, elapsed: float) -> np.ndarray:
        """Hand position ``elapsed`` seconds into the path, shape (3,)."""
        if not self.has_path:
            raise ValueError("no path to replay: run an inference first")
        t = self.times[0] + float(np.clip(elapsed, 0.0, self.duration))
        return np.array([np.interp(t, self.times, self.positions[:, j]) for j in range(3)])

    # ------------------------------------------------------------------ commands

    def load(self, times: np.ndarray, positions: np.ndarray, resume: bool = False) -> None:
        """A new path (times (m,) strictly increasing, seconds; positions (m, 3)); stops and
        rewinds, or with ``resume`` goes on playing it from the same fraction of the path (a
        prediction updated during a replay). An empty ``times`` clears the path.

        Raises
        ------
        ValueError
            Mismatched shapes, non-finite values or times not increasing.
        """
        times = np.asarray(times, dtype=float)
        positions = np.asarray(positions, dtype=float)
        if times.ndim != 1 or positions.shape != (times.shape[0], 3):
            raise ValueError(
                f"a path is times (m,) and positions (m, 3); got {times.shape} and "
                f"{positions.shape}"
            )
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(positions))):
            raise ValueError("a path must be finite (no NaN or inf)")
        if times.shape[0] > 1 and not np.all(np.diff(times) > 0):
            raise ValueError("path times must be strictly increasing")
        fraction = self.progress
        self.times, self.positions = times, positions
        if resume and self.playing and self.has_path:
            self.elapsed = fraction * self.duration
            return
        self.elapsed = 0.0
        self.playing = False
        self._last = None

    def clear(self) -> None:
        self.load(np.zeros(0), np.zeros((0, 3)))

    def play(self) -> None:
        """Start (or resume); from the start again once finished."""
        if not self.has_path:
            raise ValueError("no path to replay: run an inference first")
        if self.finished:
            self.elapsed = 0.0
        if self.elapsed == 0.0:
            self.move_hand(self.position_at(0.0))
        self.playing = True
        self._last = self.clock()

    def pause(self) -> None:
        self.playing = False
        self._last = None

    def reset(self) -> None:
        """Stop and put the hand back at the start of the path (the observation point)."""
        if not self.has_path:
            raise ValueError("no path to replay: run an inference first")
        self.pause()
        self.elapsed = 0.0
        self.move_hand(self.position_at(0.0))

    def step(self) -> bool:
        """Advance by the time elapsed since the previous step; True when the hand moved.

        The hand is moved first and the state (``elapsed``, ``playing``) updated after, so
        anyone who sees the replay finished (another thread, a test) also sees the hand at
        its end.
        """
        if not self.playing or not self.has_path:
            return False
        now = self.clock()
        last = self._last if self._last is not None else now
        elapsed = min(self.duration, self.elapsed + max(0.0, now - last))
        self.move_hand(self.position_at(elapsed))
        self._last = now
        self.elapsed = elapsed
        if elapsed >= self.duration:
            self.playing = False
            self._last = None
        return True
