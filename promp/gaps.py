"""Logging gaps: pauses of a recording's clock inside a demonstration, and the two spans a
demonstration with one has.

A step between samples longer than :data:`GAP_FACTOR` times the demonstration's median step is
a gap (the logger paused). A demonstration with gaps has two durations, and both are said
wherever its duration is (:func:`duration_text`: the checks' findings, the studio's list of
demonstrations, the import's preview and the command lines): the movement (the span without
its gaps, :func:`active_duration`, what the checks compare) and the file's span::

    13.7 s of movement, 34.8 s with the 21.1 s gap

A demonstration with a gap may be repaired on request (:func:`repair_gaps`), never by default.
"""

from __future__ import annotations

import numpy as np

from promp.data import Demonstration
from promp.units import seconds

__all__ = [
    "active_duration",
    "duration_text",
    "GAP_FACTOR",
    "gap_lengths",
    "gap_steps",
    "repair_gaps",
    "REPAIRS",
]

# A step over 10x the median step is a pause of the logger (clean sets: at most 1.3x).
GAP_FACTOR = 10.0
REPAIRS = ("cut", "split")


def gap_steps(times: np.ndarray) -> np.ndarray:
    """Indices ``i`` of the steps ``times[i] -> times[i + 1]`` that are gaps, shape (n_gaps,).

    Parameters
    ----------
    times : array, shape (n_samples,)
        Increasing times in seconds.
    """
    steps = np.diff(np.asarray(times, dtype=float))
    if steps.size == 0:
        return np.zeros(0, dtype=int)
    return np.flatnonzero(steps > GAP_FACTOR * float(np.median(steps)))


def gap_lengths(times: np.ndarray) -> np.ndarray:
    """The length in seconds of each gap of ``times`` (shape (n_gaps,))."""
    times = np.asarray(times, dtype=float)
    return np.diff(times)[gap_steps(times)]


def active_duration(demo: Demonstration) -> float:
    """The demonstration's duration without its gaps, in seconds (a gap is reported on its
    own; a movement with a logging pause is not also a slow one)."""
    steps = np.diff(demo.times)
    return float(steps.sum() - gap_lengths(demo.times).sum())


def duration_text(times: np.ndarray) -> str:
    """How long the samples at ``times`` (shape (n_samples,), seconds) last, in words: ``4.2 s``
    without a gap; with gaps, both spans (see the module docstring)."""
    times = np.asarray(times, dtype=float)
    span = float(times[-1] - times[0]) if times.size else 0.0
    lengths = gap_lengths(times)
    if lengths.size == 0:
        return seconds(span)
    pause = float(lengths.sum())
    gaps = f"the {seconds(pause)} gap" if lengths.size == 1 else (
        f"its {lengths.size} gaps ({seconds(pause)})"
    )  # fmt: skip
    return f"{seconds(span - pause)} of movement, {seconds(span)} with {gaps}"


def repair_gaps(demo: Demonstration, mode: str) -> list[Demonstration]:
    """``demo`` repaired at its gaps: ``"cut"`` keeps the part before the first gap, ``"split"``
    makes every part its own demonstration (named ``<name>-part1``, ``-part2``...).
    Parts of a single sample cannot be demonstrations and are dropped; a demonstration without
    a gap comes back as it is.

    Raises
    ------
    ValueError
        Unknown mode, or nothing of two samples or more is left.
    """
    if mode not in REPAIRS:
        raise ValueError(f"repair must be one of {REPAIRS}, got {mode!r}")
    gaps = gap_steps(demo.times)
    if gaps.size == 0:
        return [demo]
    bounds = np.concatenate([[0], gaps + 1, [demo.n_samples]])
    parts = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b - a >= 2]
    if mode == "cut":
        parts = [p for p in parts if p[0] == 0]
    if not parts:
        raise ValueError(
            f"demonstration {demo.name!r}: no part of two samples or more around its gaps"
        )
    out = []
    for k, (a, b) in enumerate(parts, start=1):
        name = demo.name if mode == "cut" else f"{demo.name}-part{k}"
        times = demo.times[a:b] - demo.times[a] + demo.times[0]
        out.append(Demonstration(times, demo.values[a:b], demo.columns, name=name))
    return out
