"""The robot finishes the movement: its hand follows the predicted path in real time.

After an inference, the path is the posterior mean hand position from the observation point to
the predicted end, timed by the predicted speed (it lasts the predicted remaining duration).
:class:`Replay` is advanced by the studio's loop (:meth:`Replay.step`, by the time elapsed since
the previous step), never blocking it; each step moves the hand through the IK (``move_hand``,
e.g. :meth:`app.scene.arm.ArmController.move_hand_to`, which also brings the gizmo along).

Who holds the arm is explicit (:class:`Phase`): the user (``IDLE``: the replay moves nothing),
or the replay, playing, paused or finished. A new prediction (the slider moved, a refit
landed) is followed while the replay holds the arm: played on from the same fraction while
playing, otherwise the hand goes to the new path's start (the observation point), so the arm
never stays at a pose of a prediction no longer shown. The user takes the arm back by dragging
the hand (:meth:`Replay.release`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from enum import Enum

import numpy as np


class Phase(Enum):
    IDLE = "idle"  # the arm is the user's
    PLAYING = "playing"
    PAUSED = "paused"
    FINISHED = "finished"


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
        self.phase = Phase.IDLE
        self._last: float | None = None

    # ------------------------------------------------------------------ state

    @property
    def playing(self) -> bool:
        return self.phase is Phase.PLAYING

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

    def load(self, times: np.ndarray, positions: np.ndarray) -> None:
        """A new path (times (m,) strictly increasing, seconds; positions (m, 3)); an empty
        ``times`` clears it. While playing, the replay goes on along it from the same
        fraction; paused or finished, the hand goes to its start; idle, nothing moves.

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
        if not self.has_path:
            self.release()
            self.elapsed = 0.0
        elif self.phase is Phase.PLAYING:
            self.elapsed = fraction * self.duration
        else:
            self.elapsed = 0.0
            if self.phase is not Phase.IDLE:  # the replay holds the arm: to the new start
                self.phase = Phase.PAUSED
                self.move_hand(self.position_at(0.0))

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
        self.phase = Phase.PLAYING
        self._last = self.clock()

    def pause(self) -> None:
        if self.phase is Phase.PLAYING:
            self.phase = Phase.PAUSED
        self._last = None

    def release(self) -> None:
        """The user takes the arm (a drag): the replay stops and moves nothing until played."""
        self.phase = Phase.IDLE
        self._last = None

    def reset(self) -> None:
        """Stop and put the hand back at the start of the path (the observation point)."""
        if not self.has_path:
            raise ValueError("no path to replay: run an inference first")
        self.phase = Phase.PAUSED
        self._last = None
        self.elapsed = 0.0
        self.move_hand(self.position_at(0.0))

    def step(self) -> bool:
        """Advance by the time elapsed since the previous step; True when the hand moved.

        The hand is moved first and the state (``elapsed``, ``phase``) updated after, so
        anyone who sees the replay finished (another thread, a test) also sees the hand at
        its end.
        """
        if self.phase is not Phase.PLAYING or not self.has_path:
            return False
        now = self.clock()
        last = self._last if self._last is not None else now
        elapsed = min(self.duration, self.elapsed + max(0.0, now - last))
        self.move_hand(self.position_at(elapsed))
        self._last = now
        self.elapsed = elapsed
        if elapsed >= self.duration:
            self.phase = Phase.FINISHED
            self._last = None
        return True
