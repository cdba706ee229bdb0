"""The segmenter stage: where a movement starts and ends in the rows of the time base.

Three ways, one at a time (``start``):

* ``"still"``: the stillness rule of :mod:`promp.stillness`, as the rows come
  (:class:`promp.stillness.MovingSpans`): the same movements as
  :func:`promp.stillness.moving_spans` finds in the whole recording, whatever the chunks the
  rows come in. A movement starts before the first sample of a run of motion that has lasted
  :data:`promp.stillness.MIN_MOVE_S` (a shorter burst is a twitch) and ends after its last
  moving sample, by the stillness the model's demonstrations had before and after their
  motion (:class:`StillRule`: their median; :data:`promp.stillness.MARGIN_S` for a model
  that learned none), once the inputs have been still for the pause allowed
  (:meth:`Segmenter.allowed_pause`): never less
  than :data:`promp.stillness.MIN_STILL_S`, and never less than the pauses the model learned
  inside its demonstrations (:meth:`promp.model.Primitive.pause`): the recognised
  primitive's while the latest prediction's phase may have reached its end, every
  primitive's longest while the phase is surely short of it or before a prediction. A pause
  longer than every learned one always ends the movement. Only inputs in metres or radians
  are watched (they have a fixed idle speed; a force or an EMG in its own unit has none while
  nothing moves): a session with none of them cannot use it.
* ``"marker"``: a marker stream's ``start [CLASS]`` and ``end [CLASS]``
  (:func:`promp.rigs.cutting.parse_marker`): the movement holds the rows from the start
  marker's time to the end marker's, and is labelled with the class.
* ``"call"``: :meth:`Segmenter.begin` and :meth:`Segmenter.end` (the studio's buttons), at
  the times given.

Calls work in every mode (a button overrides the automatic start). A movement also ends
when an input breaks (:meth:`Segmenter.abort`: the stillness rule starts again after the
break, as on a new recording) and after :data:`MAX_MOVEMENT_S`. A new movement starts a new
observation: its rows are its own, from its start.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from promp.live.timebase import Rows
from promp.model import ProMPModel
from promp.rigs.cutting import parse_marker
from promp.stillness import MARGIN_S, MIN_MOVE_S, MIN_STILL_S, SMOOTH_S, MovingSpans, SpanEvent

__all__ = [
    "Belief",
    "Boundary",
    "HISTORY_S",
    "MAX_MOVEMENT_S",
    "Movement",
    "Segmenter",
    "SLACK_S",
    "STARTS",
    "StillRule",
]

STARTS = ("still", "marker", "call")
MAX_MOVEMENT_S = 30.0
HISTORY_S = 3.0  # rows kept while nothing moves (a late marker), beyond a start's reach
# A marker and a sample stamped at one instant may differ by the streams' clock corrections
# (microseconds on one machine): a row this close to a start or end marker belongs inside.
SLACK_S = 0.002


@dataclass(frozen=True, eq=False)
class Movement:
    """The rows of one movement so far.

    Attributes
    ----------
    number : int
        Counts the session's movements from 1.
    label : str
        The class its start marker named ('' otherwise).
    times : array, shape (n,)
        Seconds on the session's clock; ``times[0]`` is the movement's start.
    values : array, shape (n, n_channels)
    ended : str
        Why it ended ('' while it goes on).
    """

    number: int
    label: str
    times: np.ndarray
    values: np.ndarray
    ended: str = ""

    def __len__(self) -> int:
        return int(self.times.shape[0])

    @property
    def start(self) -> float:
        return float(self.times[0]) if len(self) else math.nan


@dataclass(frozen=True, eq=False)
class Boundary:
    """A movement started or ended (``kind``), at ``time``; for an end, ``reason`` and the
    ended ``movement`` (all its rows)."""

    kind: str  # "start" or "end"
    number: int
    time: float
    reason: str = ""
    movement: Movement | None = None


@dataclass(frozen=True)
class StillRule:
    """What the stillness rule takes from the model: per primitive the longest pause it is
    taken to make (s, :meth:`promp.model.Primitive.pause`), and the stillness kept
    ``before`` a movement's first moving sample and ``after`` its last (s: the median of the
    training demonstrations', so that a live movement starts and ends as they did)."""

    pauses: Mapping[str, float] = field(default_factory=dict)
    before: float = MARGIN_S
    after: float = MARGIN_S

    def __post_init__(self) -> None:
        for name, value in [*self.pauses.items(), ("before", self.before),
                            ("after", self.after)]:  # fmt: skip
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name!r}: a stillness must be a finite number of seconds "
                                 f">= 0, got {value}")  # fmt: skip

    @classmethod
    def of(cls, model: ProMPModel, modalities: Sequence[str]) -> StillRule:
        """The rule ``model`` learned, with ``modalities`` watched (a model that learned none:
        no pause, :data:`promp.stillness.MARGIN_S` on each side)."""
        pauses = {p.name: p.pause(modalities) for p in model.primitives}
        ends = []
        for part in ("lead", "trail"):
            learned = [p.still(part, modalities) for p in model.primitives]
            learned = [x for x in learned if x is not None]
            ends.append(float(np.median(np.concatenate(learned))) if learned else MARGIN_S)
        return cls(pauses, *ends)


@dataclass(frozen=True)
class Belief:
    """What the latest prediction says of a movement: its ``movement`` number, the
    ``primitive`` recognised and ``phase_high``, the upper end of the interval of the share of
    it observed (below 1: the predictor is sure, at its interval's level, that the movement
    has more to come)."""

    movement: int
    primitive: str
    phase_high: float


class Segmenter:
    """Rows in, movements out (see the module docstring).

    Parameters
    ----------
    start : {"still", "marker", "call"}
    width : int
        The rows' number of columns.
    still_blocks : sequence of (slice, unit)
        The columns of each input the stillness detection watches, and its unit.
    max_movement_s : float
    rule : StillRule, optional
        What the model learned (:meth:`StillRule.of`); default: no pause learned (a pause of
        :data:`promp.stillness.MIN_STILL_S` ends a movement), :data:`MARGIN_S` each side.
    """

    def __init__(
        self,
        start: str,
        width: int,
        still_blocks: Sequence[tuple[slice, str]] = (),
        max_movement_s: float = MAX_MOVEMENT_S,
        rule: StillRule | None = None,
    ):
        if start not in STARTS:
            raise ValueError(f"unknown movement start {start!r}; expected one of {STARTS}")
        blocks = [(cols, unit) for cols, unit in still_blocks if unit in ("m", "rad")]
        if start == "still" and not blocks:
            raise ValueError(
                "the stillness detection watches inputs in metres or radians (a position, "
                "angles), and none is given: use --start marker (a marker stream) instead"
            )
        rule = rule or StillRule()
        pauses = dict(rule.pauses)
        self.rule = rule
        self.start = start
        self.blocks = blocks
        self.max_movement_s = float(max_movement_s)
        self.pauses = pauses
        self.longest_pause = self._allowed(max(pauses.values(), default=0.0))
        reach = self.longest_pause + MIN_MOVE_S + SMOOTH_S + rule.before  # a start's
        self.history_s = max(HISTORY_S, reach)
        self._columns = np.concatenate(
            [np.arange(width)[cols] for cols, _ in blocks]).astype(int) if blocks \
            else np.zeros(0, dtype=int)  # fmt: skip
        self._spans = MovingSpans([u for _, u in blocks],
                                  [np.arange(width)[c].size for c, _ in blocks])  # fmt: skip
        self._times = np.zeros(0)
        self._values = np.zeros((0, int(width)))
        self._first = 0  # the movement's first row in the buffer, when one goes on
        self._from = -math.inf  # no row before this time belongs to it (a start ahead of them)
        self._open: tuple[int, str] | None = None  # (number, label) of the movement going on
        self._count = 0
        self._pending: list[tuple[float, str, str]] = []  # (time, "start"/"end", label)
        self._belief: Belief | None = None
        self.unknown: list[tuple[float, str]] = []  # markers that were neither

    # ------------------------------------------------------------------ what says when

    def begin(self, time: float, label: str = "") -> None:
        """A movement starts at ``time`` (session clock): rows from then on belong to it."""
        self._pending.append((float(time), "start", label))

    def end(self, time: float) -> None:
        """The movement going on ends at ``time``: rows after it do not belong to it."""
        self._pending.append((float(time), "end", ""))

    def markers(self, markers: Sequence[tuple[float, str]]) -> None:
        """Marker events ``(time, label)``; used in ``"marker"`` mode, others set aside in
        :attr:`unknown`."""
        for time, label in markers:
            parsed = parse_marker(label)
            if parsed is None or self.start != "marker":
                self.unknown.append((float(time), str(label)))
                continue
            self._pending.append((float(time), parsed[0], parsed[1]))

    @staticmethod
    def _allowed(pause: float) -> float:
        """The still time that ends a movement when pauses up to ``pause`` are known: at least
        :data:`MIN_STILL_S`, and longer than ``pause``."""
        return max(MIN_STILL_S, float(np.nextafter(pause, math.inf))) if pause > 0 \
            else MIN_STILL_S  # fmt: skip

    def allowed_pause(self) -> float:
        """The still time that ends the movement going on now (see the module docstring)."""
        belief, number = self._belief, self._open[0] if self._open is not None else 0
        if belief is None or belief.movement != number or belief.phase_high < 1.0 \
                or belief.primitive not in self.pauses:  # fmt: skip
            return self.longest_pause
        return self._allowed(self.pauses[belief.primitive])

    # ------------------------------------------------------------------ rows

    def feed(self, rows: Rows | None, belief: Belief | None = None) -> list[Boundary]:
        """Add the time base's new rows; the boundaries they (and the calls and markers so
        far) make, in order. ``belief``: the latest prediction's (the pause allowed depends on
        it)."""
        if belief is not None:
            self._belief = belief
        out: list[Boundary] = []
        if rows is not None and len(rows):
            values = np.asarray(rows.values, dtype=float)
            self._times = np.concatenate([self._times, rows.times])
            self._values = np.concatenate([self._values, values])
            if self._open is not None:  # a start the rows had not reached yet: from it on
                self._first = max(self._first, int(np.searchsorted(self._times, self._from)))
            if self.start == "still":
                events = self._spans.push(rows.times, values[:, self._columns],
                                          self.allowed_pause())  # fmt: skip
                for event in events:
                    out += self._still(event)
        out += self._calls()
        if self._open is not None and self._first < self._times.size:
            if self._times[-1] - self._times[self._first] > self.max_movement_s:
                out += self._close(float(self._times[-1]),
                                   f"longer than {self.max_movement_s:g} s")  # fmt: skip
        self._trim()
        return out

    def _calls(self) -> list[Boundary]:
        """The calls' and markers' boundaries that the rows so far reach."""
        out: list[Boundary] = []
        self._pending.sort(key=lambda p: p[0])
        while self._pending:
            time, kind, label = self._pending[0]
            if kind == "end" and (not self._times.size or self._times[-1] < time + SLACK_S):
                break  # wait for the rows up to the end
            self._pending.pop(0)
            if kind == "start":
                if self._open is not None:
                    out += self._close(time, "a new movement started")
                first = int(np.searchsorted(self._times, time - SLACK_S, side="left"))
                out += self._open_at(first, label, time, time - SLACK_S)
            elif self._open is not None:
                out += self._close(time, "end marker" if self.start == "marker" else "ended")
        return out

    def abort(self, reason: str) -> list[Boundary]:
        """End the movement going on now (an input broke): with the rows it has. The
        stillness rule starts again with the next rows."""
        if self.start == "still":
            self._spans.reset()
            if self._open is None:
                self._times, self._values = self._times[:0], self._values[:0]
        if self._open is None:
            return []
        end = float(self._times[-1]) if self._times.size else math.inf
        out = self._close(end, reason)
        if self.start == "still":
            self._times, self._values = self._times[:0], self._values[:0]
        return out

    @property
    def movement(self) -> Movement | None:
        """The movement going on (None between movements)."""
        if self._open is None:
            return None
        return Movement(self._open[0], self._open[1], self._times[self._first:],
                        self._values[self._first:])  # fmt: skip

    # ------------------------------------------------------------------ inside

    def _still(self, event: SpanEvent) -> list[Boundary]:
        """A start or end of the stillness rule (rows as :func:`promp.stillness.moving_spans`
        cuts them)."""
        if event.kind == "start":
            if self._open is not None:  # a call's movement goes on: the call overrides
                return []
            first = int(np.searchsorted(self._times, event.first - self.rule.before,
                                        side="left"))  # fmt: skip
            return self._open_at(first, "", float(self._times[first]))
        if self._open is None:
            return []  # ended by a call or a break already
        stop = int(np.searchsorted(self._times, event.last + self.rule.after, side="right"))
        return self._close(event.last + self.rule.after, "still", stop)

    def _open_at(self, first: int, label: str, time: float,
                 since: float = -math.inf) -> list[Boundary]:  # fmt: skip
        """Movement ``self._count + 1`` starts at ``time``, at row ``first`` (rows not come yet:
        the first at or after ``since``)."""
        self._count += 1
        self._open, self._first, self._from = (self._count, label), first, since
        return [Boundary("start", self._count, float(time))]

    def _close(self, time: float, reason: str, stop: int | None = None) -> list[Boundary]:
        number, label = self._open
        if stop is None:
            stop = int(np.searchsorted(self._times, time + SLACK_S, side="right"))
        times, values = self._times[self._first:stop], self._values[self._first:stop]
        ended = Movement(number, label, times, values, reason)
        self._open = None
        self._times, self._values = self._times[stop:], self._values[stop:]
        self._first = 0
        return [Boundary("end", number, float(time), reason, ended)]

    def _trim(self) -> None:
        """Rows before the movement going on (or older than :attr:`history_s`) go."""
        if not self._times.size:
            return
        keep = int(np.searchsorted(self._times, self._times[-1] - self.history_s))
        if self._open is not None:
            keep = min(keep, self._first)
        if keep:
            self._times, self._values = self._times[keep:], self._values[keep:]
            self._first -= keep if self._open is not None else 0
