"""A recorded take before it becomes a demonstration: the idle time at both ends trimmed
(:func:`save_take`), and where the primitive's demonstrations start. Pure computation, no viser.

A take runs from the end of the 3-2-1 countdown to Stop, so it holds the wait before the user
moves and the time it takes to reach the Stop button: a 3 s movement recorded as a 60 s take is
an outlier to the engine. :func:`active_span` finds the samples where the hand or the head
moves faster than a threshold (:mod:`promp.stillness`: speeds smoothed over :data:`SMOOTH_S`,
so that a tremor or a tracking jitter is not motion) and keeps them, with :data:`MARGIN_S` of
stillness on each side (the movement's onset and settling). The head's speed is that of its
angles (roll, pitch, yaw), the hand's that of its position.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from app.live.recorder import Recording
from promp.data import Demonstration, Layout
from promp.gaps import duration_text
from promp.stillness import HAND_IDLE_M_S, HEAD_IDLE_RAD_S, MARGIN_S, SMOOTH_S, speed
from robots.icub.layout import HAND, HEAD, hand_dims

__all__ = [
    "HAND_IDLE_M_S", "HEAD_IDLE_RAD_S", "MARGIN_S", "SMOOTH_S", "NewDemo", "TakeOptions", "Trim",
    "active_span", "mean_start", "save_take", "speed",
]  # fmt: skip


@dataclass(frozen=True)
class TakeOptions:
    """How a take becomes a demonstration: the workspace's ``layout`` (its columns), and
    whether the still ends are trimmed, below which hand speed (m/s) and head speed (rad/s)."""

    layout: Layout
    trim: bool = True
    hand_idle_m_s: float = HAND_IDLE_M_S
    head_idle_rad_s: float = HEAD_IDLE_RAD_S


@dataclass(frozen=True, eq=False)
class NewDemo:
    """The demonstration a take becomes: ``times`` (n,) and ``values`` (n, D) in the layout's
    column order; ``raw``, the (times, values) of the whole take when its ends were cut."""

    times: np.ndarray
    values: np.ndarray
    raw: tuple[np.ndarray, np.ndarray] | None


@dataclass(frozen=True)
class Trim:
    """What trimming keeps of a take of ``n`` samples: samples ``start`` to ``stop - 1``."""

    start: int
    stop: int
    n: int

    @property
    def trimmed(self) -> bool:
        return self.start > 0 or self.stop < self.n

    def seconds(self, times: np.ndarray) -> tuple[float, float]:
        """The idle time cut at the start and at the end, seconds."""
        return float(times[self.start] - times[0]), float(times[-1] - times[self.stop - 1])


def active_span(
    times: np.ndarray,
    hand: np.ndarray,
    head: np.ndarray | None = None,
    hand_threshold: float = HAND_IDLE_M_S,
    head_threshold: float = HEAD_IDLE_RAD_S,
    margin_s: float = MARGIN_S,
    smooth_s: float = SMOOTH_S,
) -> Trim | None:
    """The samples of a take from the first to the last moment the hand (n, 3; m/s) or the
    head (n, 3 angles; rad/s) moves faster than its threshold, ``margin_s`` added on each side;
    None when nothing moves.

    Raises
    ------
    ValueError
        Fewer than two samples, arrays of different lengths, or a threshold that is not
        positive.
    """
    times = np.asarray(times, dtype=float)
    n = times.shape[0]
    if n < 2:
        raise ValueError(f"a take of {n} sample(s) has no speed to measure")
    for name, threshold in (("hand", hand_threshold), ("head", head_threshold)):
        if not math.isfinite(threshold) or threshold <= 0:
            raise ValueError(f"the {name}'s idle threshold must be positive, got {threshold}")
    blocks = [(np.asarray(hand, dtype=float), hand_threshold)]
    if head is not None:
        blocks.append((np.unwrap(np.asarray(head, dtype=float), axis=0), head_threshold))
    moving = np.zeros(n, dtype=bool)
    for values, threshold in blocks:
        if values.shape[0] != n:
            raise ValueError(f"{values.shape[0]} samples for {n} times")
        moving |= speed(times, values, smooth_s) > threshold
    if not moving.any():
        return None
    first, last = np.flatnonzero(moving)[[0, -1]]
    start = int(np.searchsorted(times, times[first] - margin_s, side="left"))
    stop = int(np.searchsorted(times, times[last] + margin_s, side="right"))
    if stop - start < 2:  # a demonstration has at least two samples
        stop = min(n, start + 2)
        start = stop - 2
    return Trim(start, stop, n)


def mean_start(demos: Sequence[Demonstration], layout: Layout) -> np.ndarray | None:
    """Where the demonstrations' hand starts, on average, shape (3,); None without a hand or
    a demonstration."""
    dims = hand_dims(layout)
    if dims is None or not demos:
        return None
    return np.mean([layout.extract(d)[0, dims] for d in demos], axis=0)


def save_take(recording: Recording, options: TakeOptions) -> tuple[NewDemo | None, str]:
    """The demonstration ``recording`` becomes and what to say of it (its duration, samples,
    the still ends cut, the head angles filled in), or None and why it is refused (fewer than
    two samples, the face lost too long, nothing moving faster than the idle thresholds, a
    threshold that is not positive)."""
    try:
        values, fill = recording.values(options.layout)
        trim = _trim(recording, values, options)
    except ValueError as exc:
        return None, str(exc)
    if trim is None:
        return None, (
            "neither the hand nor the head moved faster than the idle thresholds "
            f"({100 * options.hand_idle_m_s:g} cm/s, {math.degrees(options.head_idle_rad_s):g}°/s)"
            ": untick Trim idle ends (Take options) to keep a still take"
        )
    kept = slice(trim.start, trim.stop)
    times = recording.times[kept]
    text = f"{duration_text(times)}, {trim.stop - trim.start} samples"
    if trim.trimmed:
        before, after = trim.seconds(recording.times)
        text += f" (still ends cut: {before:.1f} s before, {after:.1f} s after)"
    if fill.n_filled:
        text += f" ({fill.message})"
    raw = (recording.times, values) if trim.trimmed else None
    return NewDemo(times, values[kept], raw), text


def _trim(recording: Recording, values: np.ndarray, options: TakeOptions) -> Trim | None:
    """What trimming keeps of ``values`` (the take in the layout's columns): all of it when
    trimming is off; None when nothing moves."""
    n = recording.n_samples
    if not options.trim:
        return Trim(0, n, n)
    layout = options.layout
    head = values[:, layout.dims([HEAD.name])] if HEAD.name in layout.names else None
    return active_span(
        recording.times, values[:, layout.dims([HAND.name])], head,
        hand_threshold=options.hand_idle_m_s, head_threshold=options.head_idle_rad_s,
    )  # fmt: skip
