"""When a recording moves: speeds, the idle thresholds, the moving spans of a long take, the
pauses inside a demonstration, and the same spans found as the samples come.

One rule for every place that needs it: the studio trims the still ends of a take
(``app.live.takes.active_span``), a session recorded without markers is cut into
demonstrations at its still periods (:mod:`promp.rigs`), a model learns how its
demonstrations are still (:func:`still_parts`: before, inside and after the motion;
:func:`pause_bound`) and a live session finds its movements (:class:`MovingSpans`, the
streaming form of :func:`moving_spans`: the same spans, whatever the chunks the samples come
in).

A signal moves while its speed exceeds its idle threshold: :data:`HAND_IDLE_M_S` for positions
in metres, :data:`HEAD_IDLE_RAD_S` for angles in radians, and for a signal of another unit
:data:`IDLE_SHARE` of its own high speed (the speed that :data:`IDLE_QUANTILE` of its samples
stay under: EMG in volts has no natural threshold). The speed at a sample is the distance
covered over the :data:`SMOOTH_S` around it (the signal interpolated linearly between its
samples, the window cut at the recording's ends) divided by the window: a tremor or a tracking
jitter faster than the window cancels out, and a late sender's samples, stamped when they were
pushed (a pause, then a burst of samples a few microseconds apart), move the signal by what it
really moved over the window rather than by a step divided by microseconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "FENCE_IQR", "HAND_IDLE_M_S", "HEAD_IDLE_RAD_S", "IDLE_QUANTILE", "IDLE_SHARE", "MARGIN_S",
    "MIN_MOVE_S", "MIN_STILL_S", "MovingSpans", "SMOOTH_S", "SpanEvent", "idle_threshold",
    "inner_pause", "moving", "moving_spans", "pause_bound", "speed", "still_parts"
]  # fmt: skip

HAND_IDLE_M_S = 0.02  # below 2 cm/s the hand is still
HEAD_IDLE_RAD_S = math.radians(10.0)  # below 10 deg/s the head is still
IDLE_SHARE = 0.1  # other units: still below 10 % of the signal's high speed
IDLE_QUANTILE = 0.95
SMOOTH_S = 0.2
MARGIN_S = 0.1
MIN_STILL_S = 0.5  # a pause this long separates two movements of a session
MIN_MOVE_S = 0.2  # a shorter burst of motion is a twitch, not a demonstration (see _runs)
FENCE_IQR = 3.0  # a pause beyond Q3 + 3 IQR of its primitive's is a hesitation (Tukey's far fence)


def _at(times: np.ndarray, values: np.ndarray, centre: np.ndarray, query: np.ndarray,
        angular: bool) -> np.ndarray:  # fmt: skip
    """The signal at ``query`` (k,) relative to its value at the samples ``centre`` (k,):
    linear between the two samples around each query, held beyond the first and last;
    angles as the shortest turn from the centre's. Shape (k, d)."""
    n = times.shape[0]
    a = np.clip(np.searchsorted(times, query, side="right") - 1, 0, n - 2)
    w = np.clip((query - times[a]) / (times[a + 1] - times[a]), 0.0, 1.0)[:, None]
    lo, hi = values[a] - values[centre], values[a + 1] - values[centre]
    if angular:
        lo = np.mod(lo + np.pi, 2 * np.pi) - np.pi
        hi = np.mod(hi + np.pi, 2 * np.pi) - np.pi
    return lo + w * (hi - lo)


def _speed_at(times: np.ndarray, values: np.ndarray, index: np.ndarray, smooth_s: float,
              angular: bool) -> np.ndarray:  # fmt: skip
    """The speed (module docstring) at the samples ``index`` (k,) of ``times`` (n,), ``values``
    (n, d); every sample of the window around each must be in the arrays."""
    half = 0.5 * smooth_s
    t = times[index]
    lo = np.maximum(t - half, times[0])
    hi = np.minimum(t + half, times[-1])
    moved = _at(times, values, index, hi, angular) - _at(times, values, index, lo, angular)
    span = hi - lo
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.linalg.norm(moved, axis=1) / span
    return np.where(span > 0, out, 0.0)


def speed(times: np.ndarray, values: np.ndarray, smooth_s: float = SMOOTH_S,
          angular: bool = False) -> np.ndarray:  # fmt: skip
    """The speed of ``values`` (n, d) at ``times`` (n,): the distance covered over the
    ``smooth_s`` seconds around each sample, divided by that time (cut at the recording's
    ends); shape (n,), in the values' unit per second. ``angular``: the values are angles in
    radians, each step taken as the shortest turn."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float).reshape(times.shape[0], -1)
    if times.shape[0] < 2:
        return np.zeros(times.shape[0])
    return _speed_at(times, values, np.arange(times.shape[0]), smooth_s, angular)


def idle_threshold(unit: str, speeds: np.ndarray) -> float:
    """The speed below which a signal of ``unit`` is still (see the module docstring)."""
    if unit == "m":
        return HAND_IDLE_M_S
    if unit == "rad":
        return HEAD_IDLE_RAD_S
    high = float(np.quantile(speeds, IDLE_QUANTILE)) if speeds.size else 0.0
    return IDLE_SHARE * high if high > 0 else math.inf


def moving(times: np.ndarray, blocks: Sequence[tuple[np.ndarray, str]]) -> np.ndarray:
    """Whether any of ``blocks`` (values (n, d) and their unit) moves at each of ``times``
    (n,), shape (n,) of bool."""
    times = np.asarray(times, dtype=float)
    n = times.shape[0]
    out = np.zeros(n, dtype=bool)
    for values, unit in blocks:
        speeds = speed(times, np.asarray(values, dtype=float).reshape(n, -1),
                       angular=unit == "rad")  # fmt: skip
        out |= speeds > idle_threshold(unit, speeds)
    return out


def moving_spans(
    times: np.ndarray,
    blocks: Sequence[tuple[np.ndarray, str]],
    min_still_s: float = MIN_STILL_S,
    min_move_s: float = MIN_MOVE_S,
    margin_s: float = MARGIN_S,
    margin_after_s: float | None = None,
) -> list[tuple[int, int]]:
    """The movements of a long recording: sample ranges ``[start, stop)`` where any of
    ``blocks`` (values (n, d) and their unit) moves, pauses shorter than ``min_still_s``
    (from a moving sample to the next) bridged, bursts of motion shorter than ``min_move_s``
    dropped (moving for less than ``min_move_s + SMOOTH_S / 2``: :func:`_runs`),
    ``margin_s`` of stillness kept before (and ``margin_after_s``, default the same, after).
    Empty when nothing moves."""
    times = np.asarray(times, dtype=float)
    after = margin_s if margin_after_s is None else margin_after_s
    spans = []
    for first, last in _runs(times, moving(times, blocks), min_still_s, min_move_s):
        start = int(np.searchsorted(times, times[first] - margin_s, side="left"))
        end = int(np.searchsorted(times, times[last] + after, side="right"))
        spans.append((start, end))
    return spans


def _runs(times: np.ndarray, flags: np.ndarray, min_still_s: float,
          min_move_s: float) -> list[tuple[int, int]]:  # fmt: skip
    """The first and last moving sample of each movement (:func:`moving_spans`). The window
    of the speed widens a burst of motion (an instant jump of a tracker is moving for a whole
    window, :data:`SMOOTH_S`): a burst is a twitch unless moving for ``min_move_s`` and half a
    window more (a jump never counts; the start is decided 0.1 s later than it would without
    the half window)."""
    index = np.flatnonzero(flags)
    if not index.size:
        return []
    breaks = np.flatnonzero(np.diff(times[index]) >= min_still_s)
    firsts = index[np.concatenate([[0], breaks + 1])]
    lasts = index[np.concatenate([breaks, [index.size - 1]])]
    return [(int(a), int(b)) for a, b in zip(firsts, lasts, strict=True)
            if times[b] - times[a] >= min_move_s + 0.5 * SMOOTH_S]  # fmt: skip


def still_parts(times: np.ndarray, blocks: Sequence[tuple[np.ndarray, str]]
                ) -> tuple[float, float, float]:  # fmt: skip
    """How a demonstration is still, seconds: the ``lead`` from its first sample to its first
    moving one, the longest ``pause`` inside it (from a moving sample to the next across still
    samples; 0 when it never stops) and the ``trail`` from its last moving sample to its last.
    All 0 when nothing moves.

    A demonstration is a piece of a longer recording, held still around it (a take trimmed
    of its still ends, a session cut at its pauses): its speeds are measured with its first
    and last sample held for half a window before and after it, as they are in a live stream,
    and not over a window cut at its ends (which, with nothing before a movement's first
    sample, finds motion sooner). A lead or trail inside the hold counts as 0."""
    times = np.asarray(times, dtype=float)
    n = times.shape[0]
    if n < 2:
        return 0.0, 0.0, 0.0
    step = float(np.median(np.diff(times)))
    k = int(math.ceil(0.5 * SMOOTH_S / step)) if step > 0 else 0
    padded = np.concatenate([times[0] - step * np.arange(k, 0, -1), times,
                             times[-1] + step * np.arange(1, k + 1)])  # fmt: skip
    held = []
    for values, unit in blocks:
        values = np.asarray(values, dtype=float).reshape(n, -1)
        held.append((np.vstack([np.repeat(values[:1], k, axis=0), values,
                                np.repeat(values[-1:], k, axis=0)]), unit))  # fmt: skip
    index = np.flatnonzero(moving(padded, held)[k:k + n])
    if not index.size:
        return 0.0, 0.0, 0.0
    across = np.flatnonzero(np.diff(index) > 1)  # still samples in between
    pause = float(np.max(times[index[across + 1]] - times[index[across]])) if across.size else 0.0
    return float(times[index[0]] - times[0]), pause, float(times[-1] - times[index[-1]])


def inner_pause(times: np.ndarray, blocks: Sequence[tuple[np.ndarray, str]]) -> float:
    """The longest pause inside a demonstration (:func:`still_parts`), seconds."""
    return still_parts(times, blocks)[1]


def pause_bound(pauses: Sequence[float]) -> float:
    """The longest pause a primitive is taken to make, from the longest pause inside each of
    its demonstrations (:func:`inner_pause`; 0 for one that never stops), seconds.

    A robust upper bound of the pauses seen: the demonstrations that paused are kept but for
    a hesitation (a pause beyond Tukey's far fence, Q3 + 3 IQR of those pauses, when there are
    four or more to tell), and the longest kept is extended by the mean spacing of the kept
    ones (the distance that, on average, separates consecutive pauses seen: how far the next
    demonstration's may lie beyond the longest). 0 when no demonstration paused."""
    seen = np.sort(np.asarray([p for p in pauses if p > 0], dtype=float))
    if not seen.size:
        return 0.0
    if seen.size >= 4:
        q1, q3 = np.quantile(seen, [0.25, 0.75])
        seen = seen[seen <= q3 + FENCE_IQR * (q3 - q1)]
    spacing = (seen[-1] - seen[0]) / (seen.size - 1) if seen.size > 1 else 0.0
    return float(seen[-1] + spacing)


# ---------------------------------------------------------------------------- as samples come


@dataclass(frozen=True)
class SpanEvent:
    """A movement of :class:`MovingSpans` started (``kind`` "start") or ended ("end").

    ``first`` and ``last`` are the times of its first and last moving sample (``last`` the
    latest so far for a start); the movement holds the samples from ``first - margin_s`` to
    ``last + margin_s`` (:func:`moving_spans`). ``decided`` is the time of the newest sample
    when it was decided."""

    kind: str
    first: float
    last: float
    decided: float


class MovingSpans:
    """:func:`moving_spans` as the samples come: fed a recording in any chunks, it finds the
    same movements, each start decided once the run of motion has lasted ``min_move_s`` (and
    half the window: :func:`_runs`) and
    each end once the inputs have been still for the pause allowed, both when the samples
    of the window after the deciding one (``SMOOTH_S / 2``) have come.

    Parameters
    ----------
    units : sequence of str
        The unit of each block ("m" or "rad": a fixed idle speed).
    widths : sequence of int
        Each block's number of columns.
    min_move_s : float
    """

    def __init__(self, units: Sequence[str], widths: Sequence[int],
                 min_move_s: float = MIN_MOVE_S):  # fmt: skip
        if any(u not in ("m", "rad") for u in units):
            raise ValueError(f"the stillness seen as samples come has a fixed idle speed only "
                             f"in m or rad, got units {list(units)}")  # fmt: skip
        self.units = tuple(units)
        self.widths = tuple(int(w) for w in widths)
        self.min_move_s = float(min_move_s)
        self.reset()

    def reset(self) -> None:
        """Forget every sample: the next is a recording's first (after a break)."""
        self._times = np.zeros(0)
        self._values = np.zeros((0, sum(self.widths)))
        self._next = 0  # the first sample of the buffer not decided yet
        self._first: float | None = None  # the run of motion going on (first, last moving)
        self._last = -math.inf
        self._started = False

    @property
    def started(self) -> bool:
        """Whether a movement goes on (its start was said, its end not yet)."""
        return self._started

    @property
    def last_moving(self) -> float:
        """The time of the latest moving sample (-inf before any)."""
        return self._last

    def push(self, times: np.ndarray, values: np.ndarray,
             min_still_s: float = MIN_STILL_S) -> list[SpanEvent]:  # fmt: skip
        """Add samples ``times`` (k,), strictly after the earlier ones, ``values`` (k, the
        blocks' columns side by side); the starts and ends they decide, a pause from a moving
        sample to the next of ``min_still_s`` or more ending a movement."""
        times = np.asarray(times, dtype=float)
        if times.size:
            self._times = np.concatenate([self._times, times])
            self._values = np.concatenate([self._values,
                                           np.asarray(values, dtype=float).reshape(times.size, -1)])
        half = 0.5 * SMOOTH_S
        decidable = int(np.searchsorted(self._times, self._times[-1] - half, side="left")) \
            if self._times.size else 0  # fmt: skip
        return self._decide(decidable, min_still_s)

    def finish(self, min_still_s: float = MIN_STILL_S) -> list[SpanEvent]:
        """The recording ended: its last samples decided (their window cut at its end), and
        the movement going on ended at its last moving sample."""
        out = self._decide(self._times.size, min_still_s)
        if self._first is not None and self._started:
            out.append(SpanEvent("end", self._first, self._last, self._newest()))
        self._first, self._started = None, False
        return out

    def _newest(self) -> float:
        return float(self._times[-1]) if self._times.size else math.nan

    def _decide(self, stop: int, min_still_s: float) -> list[SpanEvent]:
        """Samples ``self._next`` to ``stop - 1`` decided moving or still, in order."""
        if stop <= self._next or self._times.size < 2:
            return []
        index = np.arange(self._next, stop)
        flags = np.zeros(index.size, dtype=bool)
        column = 0
        for unit, width in zip(self.units, self.widths, strict=True):
            block = self._values[:, column:column + width]
            column += width
            flags |= _speed_at(self._times, block, index, SMOOTH_S, unit == "rad") \
                > idle_threshold(unit, np.zeros(0))  # fmt: skip
        out: list[SpanEvent] = []
        decided = self._newest()
        for t, move in zip(self._times[index].tolist(), flags.tolist(), strict=True):
            if self._first is not None and t - self._last >= min_still_s:
                if self._started:
                    out.append(SpanEvent("end", self._first, self._last, decided))
                self._first, self._started = None, False
            if not move:
                continue
            if self._first is None:
                self._first = t
            self._last = t
            if not self._started and \
                    self._last - self._first >= self.min_move_s + 0.5 * SMOOTH_S:  # fmt: skip
                self._started = True
                out.append(SpanEvent("start", self._first, self._last, decided))
        self._next = stop
        self._trim()
        return out

    def _trim(self) -> None:
        """Samples no window still needs go (one before the earliest still needed stays, for
        the interpolation; the recording's first stays while a window reaches it)."""
        if self._next >= self._times.size:
            keep_from = self._times[-1] - SMOOTH_S if self._times.size else 0.0
        else:
            keep_from = self._times[self._next] - 0.5 * SMOOTH_S
        drop = int(np.searchsorted(self._times, keep_from, side="right")) - 1
        drop = min(drop, self._next, self._times.size - 2)
        if drop > 0:
            self._times, self._values = self._times[drop:], self._values[drop:]
            self._next -= drop
