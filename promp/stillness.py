"""When a recording moves: speeds, the idle thresholds, and the moving spans of a long take.

One rule for both places that need it: the studio trims the still ends of a take
(``app.live.takes.active_span``), and a session recorded without markers is cut into demonstrations
at its still periods (:mod:`promp.rigs`). A signal moves while its speed (the norm of its time
derivative, smoothed over :data:`SMOOTH_S` so that a tremor or a tracking jitter is not
motion) exceeds its idle threshold: :data:`HAND_IDLE_M_S` for positions in metres,
:data:`HEAD_IDLE_RAD_S` for angles in radians, and for a signal of another unit
:data:`IDLE_SHARE` of its own high speed (the speed that :data:`IDLE_QUANTILE` of its samples
stay under: EMG in volts has no natural threshold).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = [
    "HAND_IDLE_M_S", "HEAD_IDLE_RAD_S", "IDLE_QUANTILE", "IDLE_SHARE", "MARGIN_S", "MIN_MOVE_S",
    "MIN_STILL_S", "SMOOTH_S", "idle_threshold", "moving_spans", "speed"
]  # fmt: skip

HAND_IDLE_M_S = 0.02  # below 2 cm/s the hand is still
HEAD_IDLE_RAD_S = math.radians(10.0)  # below 10 deg/s the head is still
IDLE_SHARE = 0.1  # other units: still below 10 % of the signal's high speed
IDLE_QUANTILE = 0.95
SMOOTH_S = 0.2
MARGIN_S = 0.1
MIN_STILL_S = 0.5  # a pause this long separates two movements of a session
MIN_MOVE_S = 0.2  # a shorter burst of motion is a twitch, not a demonstration


def speed(times: np.ndarray, values: np.ndarray, smooth_s: float = SMOOTH_S) -> np.ndarray:
    """The norm of the time derivative of ``values`` (n, d) at ``times`` (n,), smoothed by a
    centred moving average over ``smooth_s`` seconds; shape (n,)."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float).reshape(times.shape[0], -1)
    if times.shape[0] < 2:
        return np.zeros(times.shape[0])
    raw = np.linalg.norm(np.gradient(values, times, axis=0), axis=1)
    dt = float(np.median(np.diff(times)))
    width = max(1, int(round(smooth_s / dt)) | 1)  # odd
    if width == 1:
        return raw
    padded = np.pad(raw, width // 2, mode="edge")
    return np.convolve(padded, np.ones(width) / width, mode="valid")


def idle_threshold(unit: str, speeds: np.ndarray) -> float:
    """The speed below which a signal of ``unit`` is still (see the module docstring)."""
    if unit == "m":
        return HAND_IDLE_M_S
    if unit == "rad":
        return HEAD_IDLE_RAD_S
    high = float(np.quantile(speeds, IDLE_QUANTILE)) if speeds.size else 0.0
    return IDLE_SHARE * high if high > 0 else math.inf


def moving_spans(
    times: np.ndarray,
    blocks: Sequence[tuple[np.ndarray, str]],
    min_still_s: float = MIN_STILL_S,
    min_move_s: float = MIN_MOVE_S,
    margin_s: float = MARGIN_S,
) -> list[tuple[int, int]]:
    """The movements of a long recording: sample ranges ``[start, stop)`` where any of
    ``blocks`` (values (n, d) and their unit; angles in radians are unwrapped here) moves,
    pauses shorter than ``min_still_s`` bridged, bursts shorter than ``min_move_s`` dropped,
    ``margin_s`` of stillness kept on each side. Empty when nothing moves."""
    times = np.asarray(times, dtype=float)
    n = times.shape[0]
    moving = np.zeros(n, dtype=bool)
    for values, unit in blocks:
        values = np.asarray(values, dtype=float).reshape(n, -1)
        if unit == "rad":
            values = np.unwrap(values, axis=0)
        speeds = speed(times, values)
        moving |= speeds > idle_threshold(unit, speeds)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(int), [0]])))
    runs = [[int(a), int(b)] for a, b in zip(edges[::2], edges[1::2], strict=True)]
    merged: list[list[int]] = []
    for run in runs:
        if merged and times[run[0]] - times[merged[-1][1] - 1] < min_still_s:
            merged[-1][1] = run[1]
        else:
            merged.append(run)
    spans = []
    for first, stop in merged:
        if times[stop - 1] - times[first] < min_move_s:
            continue
        start = int(np.searchsorted(times, times[first] - margin_s, side="left"))
        end = int(np.searchsorted(times, times[stop - 1] + margin_s, side="right"))
        spans.append((start, end))
    return spans
