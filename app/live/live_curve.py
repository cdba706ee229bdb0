"""The live movement's recognition so far: each primitive's probability at every prediction
published in the movement going on (or the last one), against the time since the movement
started, and the moment the commit rule committed. Pure, no viser.

A live session publishes 30 to 100 predictions a second and the studio's loop runs at 60
frames a second: the loop would miss some, so the session (or a replay) hands every prediction
to :meth:`LiveCurves.add` from its own thread (:class:`CurveSink`), and the loop reads an
immutable :class:`LiveCurve` (:meth:`LiveCurves.curve`, made when asked for, at most once
a frame), whose ``version`` says whether anything changed since it last drew.

**Bounded.** A movement keeps at most :data:`MAX_POINTS` points: once full, every other point
is dropped and from then on only every ``stride``-th prediction is kept (the stride doubles at
each halving), so a long movement keeps its whole shape at an even density in fixed memory.
The latest prediction is always the curve's last point, kept or not, and the prediction that
committed is always kept (the commitment's mark stands at its time).
"""

from __future__ import annotations

import threading
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from promp.live.commitment import Commitment
from promp.live.predictor import LivePrediction
from promp.live.sinks import Output

__all__ = ["CurveSink", "LiveCurve", "LiveCurves", "MAX_POINTS"]

MAX_POINTS = 512


@dataclass(frozen=True, eq=False)
class LiveCurve:
    """One movement's recognition so far.

    Attributes
    ----------
    version : int
        Counts the changes (a new prediction or movement).
    movement : int
        The movement's number (0: none yet).
    names : tuple of str
        The model's primitives, the columns of ``probabilities``.
    times : array, shape (n,)
        Each kept prediction's time since the movement started (s): its latest observed
        sample, increasing.
    phases : array, shape (n,)
        The share of the movement each estimated it had observed, in [0, 1].
    probabilities : array, shape (n, K)
    committed : Commitment or None
        The movement's commitment, once made.
    predictions : int
        Predictions of the movement so far (kept or not).
    """

    version: int
    movement: int
    names: tuple[str, ...]
    times: np.ndarray
    phases: np.ndarray
    probabilities: np.ndarray
    committed: Commitment | None
    predictions: int


class LiveCurves:
    """The movement going on's :class:`LiveCurve`, built from predictions added from any
    thread (see the module docstring).

    Parameters
    ----------
    names : sequence of str
        The model's primitives.
    max_points : int
        The most points a movement keeps (even, at least 4).
    """

    def __init__(self, names: Iterable[str], max_points: int = MAX_POINTS):
        if max_points < 4 or max_points % 2:
            raise ValueError(f"max_points is an even count of at least 4, got {max_points}")
        self.names = tuple(names)
        self.max_points = int(max_points)
        self._lock = threading.Lock()
        self._version = 0
        self._movement = 0
        self._rows: list[tuple[float, float, np.ndarray]] = []  # kept (time, phase, p)
        self._latest: tuple[float, float, np.ndarray] | None = None
        self._count = 0  # predictions of the movement
        self._stride = 1
        self._committed: Commitment | None = None
        self._pinned: tuple | None = None  # the committing prediction's row
        self._numbers: list[int] = []  # each kept row's prediction number in the movement
        self._pinned_n = -1
        self._curve = self._make()

    def add(self, predictions: Iterable[LivePrediction]) -> None:
        """Predictions as published, in order."""
        with self._lock:
            for p in predictions:
                self._add(p)

    def _add(self, p: LivePrediction) -> None:
        if p.movement != self._movement:
            self._movement, self._rows, self._count, self._stride = p.movement, [], 0, 1
            self._committed, self._latest, self._pinned = None, None, None
            self._numbers, self._pinned_n = [], -1
        row = (float(p.elapsed), float(p.phase.value), np.array(p.probabilities, dtype=float))
        if self._latest is not None and row[0] <= self._latest[0]:
            # a movement's last prediction on rows cut back by its still end is earlier on
            # its clock: the curve goes forward in time, as the commit rule does
            row = None
        elif self._count % self._stride == 0 or _commits(p):
            self._rows.append(row)
            self._numbers.append(self._count)
            if _commits(p):  # the committing prediction stays: the mark stands there
                self._pinned, self._pinned_n = row, self._count
            if len(self._rows) >= self.max_points:
                self._stride *= 2  # by the predictions' numbers: even, the pinned one aside
                self._rows = [r for r, n in zip(self._rows, self._numbers, strict=True)
                              if n % self._stride == 0 or r is self._pinned]  # fmt: skip
                self._numbers = [n for n in self._numbers if n % self._stride == 0 or
                                 n == self._pinned_n]  # fmt: skip
        self._count += 1
        if row is not None:
            self._latest = row
        if p.committed is not None:
            self._committed = p.committed
        self._version += 1

    def _make(self) -> LiveCurve:
        rows = list(self._rows)
        if self._latest is not None and rows and rows[-1] is not self._latest:
            rows.append(self._latest)
        k = len(self.names)
        times = np.array([r[0] for r in rows], dtype=float)
        phases = np.array([r[1] for r in rows], dtype=float)
        probabilities = (np.vstack([r[2] for r in rows]) if rows
                         else np.zeros((0, k), dtype=float))  # fmt: skip
        return LiveCurve(self._version, self._movement, self.names, times, phases,
                         probabilities, self._committed, self._count)  # fmt: skip

    def curve(self) -> LiveCurve:
        """The latest (immutable; the same object until a prediction is added). Made when
        asked for (the loop asks once a frame; predictions may come faster)."""
        with self._lock:
            if self._curve.version != self._version:
                self._curve = self._make()
            return self._curve


def _commits(p: LivePrediction) -> bool:
    """Whether ``p`` is the prediction that committed (its latest sample the commitment's)."""
    return p.committed is not None and p.committed.at == p.last


class CurveSink:
    """A session's sink feeding a :class:`LiveCurves` with every prediction
    (:mod:`promp.live.sinks`: on its own thread; a full queue folds outputs, losing none)."""

    name = "recognition chart"
    lossless = True

    def __init__(self, curves: LiveCurves):
        self.curves = curves

    def view(self, output: Output) -> Output | None:
        return output if output.predictions else None

    def take(self, output: Output) -> tuple:
        self.curves.add(output.predictions)
        return ()

    def close(self) -> None:
        """Nothing to close."""
