"""The time base stage: the inputs' samples, at their own rates, put on one clock as rows.

The XDF reader's rule, applied as samples arrive (:func:`promp.rigs.streams.on_one_clock` does
the work, on each stream's samples around the new rows): the rows are at the times of the
slowest input (the lowest nominal rate, or the longest median step when a rate is not
declared; chosen once, when every input has samples), the others interpolated linearly at
them (angles through their unwrapped path), or on a regular grid at ``rate`` Hz. A row is
given once every input has a sample at or after its time, so an input that lags holds the
rows back rather than being extrapolated.

A gap in an input cannot be interpolated across: the rows inside it are never given, and
:meth:`TimeBase.push` says so (the session ends the movement under way). A gap is a step
longer than :data:`promp.gaps.GAP_FACTOR` of the input's steps (at its rate, or its median
step when it declares none) beyond its recent lateness (how far a late sender's samples were
moved back lately, :mod:`promp.live.restamp`): a sender that was late and caught up lost
nothing, and a pause it may still be catching up is not a gap.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from promp.gaps import GAP_FACTOR
from promp.rigs.streams import Stream, on_one_clock

__all__ = ["KEEP_S", "Rows", "TimeBase"]

KEEP_S = 1.0  # samples kept before the last row given (interpolation needs one)


@dataclass(frozen=True, eq=False)
class Rows:
    """Samples of every input at common times.

    ``times`` (n,) seconds on the session's clock; ``values`` (n, n_channels), the inputs'
    channels side by side in the inputs' order."""

    times: np.ndarray
    values: np.ndarray

    def __len__(self) -> int:
        return int(self.times.shape[0])


@dataclass(eq=False)
class _Buffer:
    times: np.ndarray
    values: np.ndarray
    units: tuple[str, ...] = ()

    @property
    def step(self) -> float:
        return float(np.median(np.diff(self.times[-50:]))) if self.times.size > 1 else math.nan


class TimeBase:
    """Rows of several inputs on one clock (see the module docstring).

    Parameters
    ----------
    names : sequence of str
        The inputs, in the order of the rows' columns.
    widths : sequence of int
        Each input's number of channels.
    rate : float, optional
        A regular grid at this rate (Hz) instead of the slowest input's times.
    """

    def __init__(self, names: Sequence[str], widths: Sequence[int], rate: float | None = None):
        if rate is not None and not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"the time base's rate must be a positive number of Hz, got {rate}")
        self.names = tuple(names)
        self.widths = tuple(int(w) for w in widths)
        self.rate = rate
        self.base: int | None = None
        self._buffers = {n: _Buffer(np.zeros(0), np.zeros((0, w)))
                         for n, w in zip(self.names, self.widths, strict=True)}  # fmt: skip
        self._given = -math.inf  # the time of the last row given
        # each input's next samples come after this (its latest; -inf once its clock may
        # have changed: a restart)
        self._after = dict.fromkeys(self.names, -math.inf)

    def choose_base(self, rates: Mapping[str, float]) -> None:
        """Fix the input whose times are the rows' (``rates``: the nominal rates, 0 unknown;
        otherwise the longest median step). Called once every input has samples."""
        if all(rates.get(n, 0.0) > 0 for n in self.names):
            self.base = int(np.argmin([rates[n] for n in self.names]))
        else:
            self.base = int(np.argmax([self._buffers[n].step for n in self.names]))

    def push(self, name: str, times: np.ndarray, values: np.ndarray, units: tuple[str, ...],
             rate: float = 0.0, late: float = 0.0) -> str:  # fmt: skip
        """Add input ``name``'s new samples (strictly after its earlier ones); returns a
        message when they leave a gap after the earlier ones ('' otherwise). ``rate``: the
        input's (Hz; 0: irregular), ``late``: its recent lateness (s)."""
        buf = self._buffers[name]
        times = np.asarray(times, dtype=float)
        values = np.asarray(values, dtype=float).reshape(times.shape[0], -1)
        buf.units = tuple(units)
        gap = ""
        old = buf.times[-50:]
        joined = np.concatenate([old, times])
        if joined.size >= 2:
            spans = np.diff(joined)
            step = 1.0 / rate if rate > 0 else float(np.median(spans))
            limit = GAP_FACTOR * step + max(late, 0.0)
            over = np.flatnonzero(spans[max(old.size - 1, 0):] > limit)
            if over.size:
                i = int(over[-1]) + max(old.size - 1, 0)  # spans[i]: joined[i] -> joined[i + 1]
                gap = (f"input {name!r} paused {spans[i]:.3f} s (from {joined[i]:.3f} to "
                       f"{joined[i + 1]:.3f} s on the session's clock)")  # fmt: skip
                buf.times, buf.values = np.zeros(0), np.zeros((0, values.shape[1]))
                times, values = times[i + 1 - old.size:], values[i + 1 - old.size:]
        buf.times = np.concatenate([buf.times, times])
        buf.values = np.concatenate([buf.values, values])
        if times.size:
            self._after[name] = float(times[-1])
        return gap

    def restart(self, name: str) -> None:
        """Forget input ``name``'s samples (it vanished, or its clock jumped): rows start
        again after its next samples, wherever its clock now is."""
        self.drop(name)
        self._after[name] = -math.inf

    def drop(self, name: str) -> None:
        """Forget input ``name``'s samples, its clock unchanged (they waited too long for
        another input): its next samples come after them."""
        buf = self._buffers[name]
        buf.times, buf.values = np.zeros(0), np.zeros((0, buf.values.shape[1]))

    def advance(self, rates: Mapping[str, float] | None = None) -> Rows | None:
        """The rows that every input now covers and that were not given yet (None if none).

        ``rates``: the inputs' nominal rates, to choose the base the first time."""
        buffers = [self._buffers[n] for n in self.names]
        firsts = [b.times[0] if b.times.size else self._after[n]
                  for n, b in zip(self.names, buffers, strict=True)]  # fmt: skip
        self._forget_before(max(max(firsts), self._given))  # no row before, rows or not
        if any(b.times.size == 0 for b in buffers):
            return None
        if self.base is None and self.rate is None:
            if len(buffers) > 1 and any(b.times.size < 2 for b in buffers):
                return None
            self.choose_base(rates or {})
        lo = max(max(b.times[0] for b in buffers), self._given)
        hi = min(b.times[-1] for b in buffers)
        if self.rate is None:
            base = buffers[self.base].times
            new = base[(base > self._given) & (base >= lo) & (base <= hi)]
        else:
            # grid times k / rate; the next k after the last row given (rounded: a grid time
            # is computed as lo + j / rate, which may sit an ulp off k / rate)
            first = math.ceil(lo * self.rate - 1e-6)
            if math.isfinite(self._given):
                first = max(first, round(self._given * self.rate) + 1)
            last = math.floor(hi * self.rate + 1e-6)
            new = np.arange(first, last + 1) / self.rate
        if new.size == 0:
            return None
        # on_one_clock needs two rows: the span starts at the last row given (dropped after)
        start = self._given if math.isfinite(self._given) and self._given >= lo - 1e-9 \
            else float(new[0])  # fmt: skip
        if start == float(new[-1]) or (start < lo and new.size < 2):
            # one first row, or one row after an input that starts again within 1e-9 after
            # the last row given (the span then starts at it): wait for the next
            return None
        if self.rate is None and np.count_nonzero((base >= start) & (base <= new[-1])) < 2:
            # the rows' input started again (a clock jump, a restart) on another phase: the
            # last row given is none of its times, and one row after it is one sample on the
            # time base (on_one_clock refuses it: found by the live session machine)
            return None
        streams = []  # (each holds a sample at or before start and one at or after the end)
        for name, b in zip(self.names, buffers, strict=True):
            a = max(int(np.searchsorted(b.times, start, side="right")) - 1, 0)
            z = int(np.searchsorted(b.times, new[-1], side="left")) + 1
            times, values = b.times[a:z], b.values[a:z]
            streams.append(Stream(name, times, values, b.units or ("",) * values.shape[1]))
        # the pauses were judged by push, with the senders' lateness: a pause it let through
        # (a late sender catching up) is interpolated across, never refused here
        times, values = on_one_clock(streams, start, float(new[-1]), self.rate,
                                     "the live time base", base=self.base, gaps=False)
        fresh = times > self._given
        times, values = times[fresh], [v[fresh] for v in values]
        self._given = float(times[-1])
        self._forget_before(self._given)
        return Rows(np.asarray(times, dtype=float), np.hstack(values))

    def _forget_before(self, t: float) -> None:
        """Keep each input's samples from :data:`KEEP_S` before ``t`` (s) on, at least its
        last two: no row before ``t`` can be given. A row needs every input from its first
        sample on (or, for an input whose samples were dropped, from after its latest), so
        while one starts later than the others their earlier samples can never be in a row;
        they were kept for as long as no row came (found by the live session machine's test:
        the hand's clock back by 28 s, then the head silent for 31 s, its samples dropped:
        the hand's 31 s held, 248 kB)."""
        for b in self._buffers.values():
            keep = int(np.searchsorted(b.times, t - KEEP_S, side="left"))
            keep = min(keep, max(b.times.size - 2, 0))
            if keep:
                b.times, b.values = b.times[keep:], b.values[keep:]

