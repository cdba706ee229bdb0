"""What a value of the studio was at any recent moment.

The hand and the head reading change only at discrete moments: the loop sets the arm after an
IK step, and reads the head once a frame. :class:`StateHistory` keeps each value with the time
it became current, so a reader asking for a moment gets exactly what a reader at that moment
would have got, even when it asks late. The recorder relies on it: on a busy machine its thread
may wake long after a tick was due, and it samples every missed tick from the history instead
of leaving a gap in the take (a gap the studio's own checks would flag, leaving the take out of
learning: a stall of the machine is not a fault of the demonstration).
"""

from __future__ import annotations

import bisect
import threading
import time
from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")
KEPT_S = 30.0  # how far back a value can be asked for


class StateHistory(Generic[T]):
    """Values with the times they became current (monotonic seconds), kept for ``kept_s``.

    Thread-safe: one writer (the loop) and any readers.
    """

    def __init__(self, kept_s: float = KEPT_S, clock: Callable[[], float] = time.monotonic):
        if not kept_s > 0:
            raise ValueError(f"kept_s must be positive, got {kept_s}")
        self.kept_s = float(kept_s)
        self.clock = clock
        self._times: list[float] = []
        self._values: list[T] = []
        self._lock = threading.Lock()

    def record(self, value: T) -> None:
        """``value`` is current from now on (timed inside the lock, so that the history is
        in time order and a reader never misses a value older than its question)."""
        with self._lock:
            now = self.clock()
            self._times.append(now)
            self._values.append(value)
            if self._times[0] < now - 2 * self.kept_s:  # trimmed now and then, not every time
                cut = bisect.bisect_left(self._times, now - self.kept_s) - 1
                if cut > 0:
                    del self._times[:cut], self._values[:cut]

    def at(self, t: float) -> T:
        """The value current at time ``t``: the last one recorded at or before ``t``.

        Raises
        ------
        LookupError
            Nothing was recorded at or before ``t`` (before the first value, or older than
            what is kept).
        """
        with self._lock:
            i = bisect.bisect_right(self._times, t) - 1
            if i < 0:
                oldest = f"{self._times[0]:.3f} s" if self._times else "nothing recorded"
                raise LookupError(f"no value at {t:.3f} s (oldest: {oldest})")
            return self._values[i]

    def latest(self) -> T:
        """The current value.

        Raises
        ------
        LookupError
            Nothing was recorded yet.
        """
        with self._lock:
            if not self._values:
                raise LookupError("nothing recorded yet")
            return self._values[-1]
