"""A late sender's samples put back at their rate: the stamps of a regular stream, re-spread.

An outlet that stamps its samples when it pushes them (``pylsl``'s default, which
``docs/live.md`` advises) stamps them late when its machine is busy: the sender sleeps past its
time, then pushes its backlog at once, and the stamps show a pause (0.1-0.35 s on a loaded
machine) followed by a burst of samples microseconds apart. The samples were taken at the
stream's rate all along. For a stream that declares a rate, :class:`Respread` puts such a burst
back: a stamp is when the sample was pushed, never before it was taken, and samples are one
step apart, so each sample of a burst is placed one step before the next one (the burst's last
keeps its stamp), and never at or before the stream's previous sample (a burst longer than its
pause explains is spread evenly after it). A burst follows a pause of more than
:data:`PAUSE_STEPS` steps: it is the most samples after it that came, on average, closer than
:data:`BURST_SHARE` of a step. On average, because a busy machine also preempts the sender
while it pushes its backlog: a burst with a hole of a few milliseconds (under a quarter of a
step per sample so far) is still one. A stream that runs faster than it declares is judged at
the rate it runs (the median step of its last :data:`RUN_GAPS` samples given, once it gave that
many and when it is under :data:`RUN_SHARE` of the declared step): its samples after a pause
are not a burst, and it is left as it is.

A burst is held until it is whole (as many samples as were due during its pause), so that it
is re-spread whole whatever the chunks it arrives in; one that stays short of that is given
once nothing came for :data:`QUIET_S` (or two steps), or after as long as its pause, and the
samples after a pause are given at once when three or more came at the rate (a sender that
paused and resumed on time; their steps over :data:`RUN_SHARE` of a step on average). How far
samples were moved back in the last :data:`LATE_WINDOW_S` is the stream's recent lateness
(:meth:`Respread.lateness`): the time base judges a pause in the stamps against the stream's
rate and this lateness (:mod:`promp.live.timebase`).

On-time samples (a step apart or more) are given as they come, unchanged.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

__all__ = ["BURST_SHARE", "QUIET_S", "LATE_WINDOW_S", "PAUSE_STEPS", "RUN_GAPS", "RUN_SHARE",
           "Respread"]

BURST_SHARE = 0.25  # samples closer than a quarter of a step on average are a burst (a backlog
# pushed at once is microseconds apart; a stream replayed up to 4x faster than it declares is not)
QUIET_S = 0.05  # a burst short of its backlog is given once nothing came for this long
PAUSE_STEPS = 2.0  # a burst follows a pause longer than this many steps
LATE_WINDOW_S = 10.0
RUN_GAPS = 32  # the steps a stream is seen running at: the median of its last 32
RUN_SHARE = 0.75  # ... when under 3/4 of the declared step


class Respread:
    """One regular stream's samples, its late bursts re-spread (see the module docstring).

    Parameters
    ----------
    rate : float
        The stream's rate (Hz); 0 or less: irregular, nothing is re-spread.
    """

    def __init__(self, rate: float):
        self.rate = float(rate)
        self.reset()

    def reset(self) -> None:
        """A new stream (or the same one after a break): nothing held, no lateness."""
        self._times = np.zeros(0)
        self._values: np.ndarray | None = None
        self._since = math.inf  # when the samples held began to be held
        self._heard = -math.inf  # when the latest samples arrived
        self._last = -math.inf  # the latest time given
        self._late: deque[tuple[float, float]] = deque()  # (when, seconds moved back)
        self._gaps: deque[float] = deque(maxlen=RUN_GAPS)  # between the latest samples given
        self._running = math.nan  # their median once there are RUN_GAPS (read at every step)

    @property
    def step(self) -> float:
        """The stream's step (s): the declared one, or the one it runs at when shorter
        (0: irregular)."""
        declared = 1.0 / self.rate if self.rate > 0 else 0.0
        # clearly faster (not an on-time stream's jitter); nan: too few steps yet
        if declared > 0 and self._running < RUN_SHARE * declared:
            return self._running
        return declared

    def add(self, times: np.ndarray, values: np.ndarray, now: float
            ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """Samples (times (k,) strictly increasing after the earlier ones, values (k, d))
        arrived at ``now``; the samples given now (a burst under way is held)."""
        times = np.asarray(times, dtype=float)
        values = np.asarray(values, dtype=float)
        if self.step <= 0:
            if times.size:
                self._last = float(times[-1])
            return times, values
        if times.size:
            self._heard = now
            if self._values is None or not self._times.size:
                self._values = values[:0]
                self._since = now
            self._times = np.concatenate([self._times, times])
            self._values = np.concatenate([self._values, values])
        return self._given(now)

    def release(self, now: float) -> tuple[np.ndarray, np.ndarray]:
        """The samples held whose burst is over by ``now`` (nothing new arrived)."""
        if self._values is None or not self._times.size:
            return np.zeros(0), np.zeros((0, self._width()))
        return self._given(now)

    def lateness(self, now: float) -> float:
        """The most samples were moved back in the last :data:`LATE_WINDOW_S`, seconds."""
        while self._late and self._late[0][0] < now - LATE_WINDOW_S:
            self._late.popleft()
        return max((s for _, s in self._late), default=0.0)

    def _width(self) -> int:
        return self._values.shape[1] if self._values is not None else 0

    def _given(self, now: float) -> tuple[np.ndarray, np.ndarray]:
        times, values = self._times, self._values
        if values is None or not times.size:
            return np.zeros(0), np.zeros((0, self._width()))
        step = self.step
        gaps = np.diff(np.concatenate([[self._last], times]))
        pauses = self._pauses(times, gaps, step)
        held = times.size
        if pauses and self._may_go_on(times[pauses[-1][0]:], gaps[pauses[-1][0]], step, now):
            held = pauses[-1][0]  # it waits, to be re-spread whole
        out = times[:held].copy()
        for j, k in pauses:
            if k > held:
                break
            if k - j > 1:  # a burst
                out[j:k] = self._spread(times[j:k], out[j - 1] if j else self._last)
        if held:
            given = out[:held] if not math.isfinite(self._last) else \
                np.concatenate([[self._last], out[:held]])  # fmt: skip
            self._gaps.extend(np.diff(given).tolist())
            if len(self._gaps) == RUN_GAPS:
                self._running = float(np.median(self._gaps))
            self._last = float(out[held - 1])
        given = (out, values[:held])
        self._times, self._values = times[held:], values[held:]
        if held == times.size:
            self._since = math.inf  # nothing held
        elif held:
            self._since = now  # a new burst held (one held already stays from its start)
        return given

    @staticmethod
    def _pauses(times: np.ndarray, gaps: np.ndarray, step: float) -> list[tuple[int, int]]:
        """The pauses among ``times`` (``gaps``: from the sample before each), as [j, k): a
        pause of more than :data:`PAUSE_STEPS` steps before ``times[j]``, and the burst after
        it, ``times[j:k]``: the most samples that came, on average, closer than
        :data:`BURST_SHARE` of a step (a backlog whose push was interrupted is still one);
        none (``k == j + 1``) when the samples after the pause came at the rate."""
        paused = np.flatnonzero(np.isfinite(gaps) & (gaps > PAUSE_STEPS * step))  # not the first
        pauses: list[tuple[int, int]] = []
        for j in paused.tolist():
            if pauses and j < pauses[-1][1]:
                continue  # a pause within a burst (the sender interrupted again)
            span = times[j + 1:] - times[j]
            fast = np.flatnonzero(BURST_SHARE * step * np.arange(1, span.size + 1) >= span)
            pauses.append((j, j + 1 + (int(fast[-1]) + 1 if fast.size else 0)))
        return pauses

    def _may_go_on(self, after: np.ndarray, gap: float, step: float, now: float) -> bool:
        """Whether the samples ``after`` a pause of ``gap`` seconds may be the start of a
        backlog still coming: fewer than were due during the pause, the latest heard less
        than a quiet time ago, held for less than the pause, and not coming at the rate (three
        or more, their steps over :data:`RUN_SHARE` of a step on average)."""
        count = after.size
        quiet = max(2.0 * step, QUIET_S)
        return (
            count < gap / step - 0.5
            and now - self._heard < quiet
            and now - self._since < gap + quiet
            and not (count >= 3 and after[-1] - after[0] >= RUN_SHARE * (count - 1) * step)
        )

    def _spread(self, stamps: np.ndarray, previous: float) -> np.ndarray:
        """A burst's ``stamps`` (push times) as sample times: one step before the next at
        most, after ``previous`` (spread evenly after it when they cannot be a step apart)."""
        step = self.step
        times = stamps.copy()
        for k in range(times.size - 2, -1, -1):
            times[k] = min(times[k], times[k + 1] - step)
        if math.isfinite(previous) and times[0] <= previous:
            even = previous + (stamps[-1] - previous) * np.arange(1, times.size + 1) \
                / times.size  # fmt: skip
            times = np.maximum(times, even)
        moved = float(np.max(stamps - times))
        if moved > 0:
            self._late.append((float(stamps[-1]), moved))
        return times
