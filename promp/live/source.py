"""The source stage: live streams in, as timed samples of modalities, with the faults seen.

Each input is a :class:`promp.live.inputs.LiveInput`: one modality in the rig formats'
mapping syntax (``hand=MocapHand:0,1,2@mm``), its channels found in its stream's samples and
converted to SI units (:func:`promp.live.inputs.channels_of`).

:class:`Source` is the stage's pure half: it opens and pulls nothing (the session's intake,
:mod:`promp.live.intake`, holds the inlets and hands it what a look found, :class:`Opened`,
and what each inlet gave, :class:`Pulled`). :meth:`Source.poll` returns what arrived since the
last poll, on the session's clock (the transport's time correction applied), strictly
increasing per stream, and updates each input's :class:`StreamStatus`. What it does with
faults, never raising:

* **NaN or infinite values** (or beyond :data:`promp.data.MAX_MAGNITUDE`): the sample is left
  out (``bad values``), its stamp still the stream's clock (a jump after bad values is found
  by them); samples not of the stream's channel count too (``wrong channels``);
* **a stamp that goes back** a little (under :data:`JUMP_S`): left out;
* **a clock jump**: stamps that go back by :data:`JUMP_S` or more, or that leap ahead by
  :data:`JUMP_S` more than the time that passed here and the lateness of the last delivery
  (how far its newest stamp lay behind this machine's clock: a sender catching up its
  backlog is no jump; so a stream whose stamps always lag by L seconds is not said to jump
  forward by less than L, the time base then seeing a gap) together, are re-anchored: the
  stream's later stamps are shifted so that the first sample after the jump follows the last
  one by the stream's step (``clock jumped``); the movement under way is ended
  (:class:`SourceBatch` ``broken``);
* **a stall**: no sample for :data:`STALL_STEPS` steps (at least :data:`STALL_MIN_S`):
  ``stalled`` until samples come again;
* **a rate change** of over :data:`RATE_TOLERANCE` over the last :data:`RATE_WINDOW_S`
  (its median step): ``rate changed``, said once per change (the time base works from the
  stamps, whatever the rate);
* **a late sender** (a stream with a declared rate whose stamps pause, then come in a burst
  microseconds apart: the backlog of a sender that pushed late on a busy machine): the burst
  is re-spread at the stream's rate (:mod:`promp.live.restamp`), and how late it was is the
  stream's recent lateness (:meth:`Source.lateness`), against which the time base judges a
  pause in its stamps;
* **vanished**: the outlet is gone; the stream is looked for again (:meth:`Source.wanted`,
  by the session's resolver thread) and, found, is ``back`` (the same outlet) or
  ``restarted`` (a new one), or ``wrong channels`` when it no longer has the mapping's channels
  (it is then not used: the mapping would read the wrong values, and that stream is not
  opened again).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from promp.data import MAX_MAGNITUDE
from promp.live.inputs import Channels, LiveInput, channels_of
from promp.live.restamp import Respread
from promp.live.status import Condition, LiveEvent, StreamStatus
from promp.live.transport import Selector, StreamDescription

__all__ = [
    "BAD_DETAIL",
    "Channels",
    "channels_of",
    "CLEAN_S",
    "JUMP_S",
    "LiveInput",
    "Opened",
    "Pulled",
    "RATE_TOLERANCE",
    "RATE_WINDOW_S",
    "Source",
    "SourceBatch",
    "STALL_MIN_S",
    "STALL_STEPS",
    "Wanted",
]

JUMP_S = 0.25
STALL_STEPS = 10.0
STALL_MIN_S = 0.5
RATE_TOLERANCE = 0.25
RATE_WINDOW_S = 2.0
CLEAN_S = 1.0  # NaNs are said until the samples have been clean this long
BAD_DETAIL = f"sample(s) with NaN, infinite or beyond {MAX_MAGNITUDE:.0e} values left out"


@dataclass(eq=False)
class SourceBatch:
    """What one poll brought.

    Attributes
    ----------
    samples : dict of str to (times (n,), values (n, k), units)
        Per input (by modality name), the new samples in SI units.
    markers : list of (time, label)
    events : list of LiveEvent
        Conditions that changed.
    broken : set of str
        Inputs whose samples do not continue the earlier ones (vanished, restarted, a
        clock jump): the movement under way cannot be observed across them.
    """

    samples: dict[str, tuple[np.ndarray, np.ndarray, tuple[str, ...]]]
    markers: list[tuple[float, str]]
    events: list[LiveEvent]
    broken: set[str]


@dataclass(frozen=True)
class Wanted:
    """A stream to look for: feed ``feed``'s (its ``selector``; a marker stream or not), but
    not the stream of uid ``refused`` (it lacked the mapping's channels)."""

    feed: int
    selector: Selector
    markers: bool
    refused: str = ""


@dataclass(frozen=True)
class Opened:
    """What a look found for feed ``feed``: its ``stream`` opened (``problem`` empty), or
    why not (``stream`` None, or a stream that could not be opened)."""

    feed: int
    stream: StreamDescription | None
    problem: str = ""


@dataclass(frozen=True, eq=False)
class Pulled:
    """What an inlet gave: ``times`` (n,) on the session's clock and ``values`` (n,
    n_channels) (a marker stream's: n labels), or ``lost`` (its outlet is gone); ``offset``
    the clock correction added to the sender's stamps (seconds; a session file keeps it)."""

    times: np.ndarray
    values: np.ndarray | list[str]
    lost: bool = False
    offset: float = 0.0
    LOST: ClassVar[Pulled]
    NOTHING: ClassVar[Pulled]


Pulled.LOST = Pulled(np.zeros(0), [], lost=True)
Pulled.NOTHING = Pulled(np.zeros(0), [])


@dataclass(eq=False)
class _Feed:
    """One input's (or the marker stream's) connection and what is known of its samples."""

    selector: Selector
    inputs: tuple[LiveInput, ...]  # none: the marker stream
    connected: bool = False  # its stream's samples are read
    width: int = 0  # its stream's channels
    channels: tuple[Channels, ...] = ()
    uid: str = ""
    rejected: str = ""  # the uid of a stream without the mapping's channels
    status: StreamStatus | None = None
    last: float = -math.inf  # the last time given
    stamp: float = -math.inf  # the last accepted stamp (a burst held may follow the last given)
    shift: float = 0.0  # re-anchoring after clock jumps
    arrival: float = -math.inf  # when the last sample arrived here
    heard: float = -math.inf  # when the last sample, usable or not, arrived (stalls)
    rate: float = 0.0  # the rate the stream is believed to run at (Hz; 0 unknown)
    recent: deque = field(default_factory=deque)  # recent times, for the rate
    spread: Respread = field(default_factory=lambda: Respread(0.0))  # a late sender's bursts
    received: int = 0
    left_out: int = 0
    clean_since: float = math.inf

    @property
    def label(self) -> str:
        return str(self.selector)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(i.name for i in self.inputs)

    @property
    def step(self) -> float:
        return 1.0 / self.rate if self.rate > 0 else 0.0


class Source:
    """The inputs' streams, opened and polled (see the module docstring).

    Parameters
    ----------
    inputs : sequence of LiveInput
    markers : Selector, optional
        The marker stream (``start CLASS`` / ``end CLASS``).
    now : float
        The session's clock at the start (seconds).
    """

    def __init__(self, inputs: Sequence[LiveInput], markers: Selector | None = None,
                 now: float = 0.0):  # fmt: skip
        names = [i.name for i in inputs]
        if not inputs:
            raise ValueError("a live session needs at least one input (--in NAME=STREAM:...)")
        if len(set(names)) != len(names):
            raise ValueError(f"a modality is given twice among the inputs {names}")
        self.inputs = tuple(inputs)
        # inputs of one stream share its inlet
        selectors = list(dict.fromkeys(i.selector for i in inputs))
        self._feeds = [_Feed(sel, tuple(i for i in inputs if i.selector == sel))
                       for sel in selectors]  # fmt: skip
        if markers is not None:
            if markers in selectors:
                raise ValueError(f"the marker stream {str(markers)!r} is also an input's")
            self._feeds.append(_Feed(markers, ()))
        for feed in self._feeds:
            feed.status = StreamStatus(str(feed.selector), Condition.WAITING, now, "not found yet")

    # ------------------------------------------------------------------ connecting

    def wanted(self) -> tuple[Wanted, ...]:
        """The feeds whose stream is not read (what the resolver looks for)."""
        return tuple(Wanted(k, f.selector, not f.inputs, f.rejected)
                     for k, f in enumerate(self._feeds) if not f.connected)  # fmt: skip

    def connected(self) -> frozenset[int]:
        """The feeds whose stream is read (the intake keeps their inlets open)."""
        return frozenset(k for k, f in enumerate(self._feeds) if f.connected)

    def adopt(self, opened: Sequence[Opened], now: float) -> list[LiveEvent]:
        """Take the streams a look opened (:class:`Opened`): a feed reads one unless it lacks
        the mapping's channels (refused: the intake closes it)."""
        events = []
        for k, stream, problem in ((o.feed, o.stream, o.problem) for o in opened):
            feed = self._feeds[k]
            if feed.connected:  # found twice: keep the first
                continue
            if stream is None or problem:  # a vanished stream still listed stays vanished
                if feed.status is None or feed.status.condition is not Condition.VANISHED:
                    events += self._set(feed, Condition.WAITING, now, problem)
                continue
            if feed.inputs:
                try:
                    feed.channels = tuple(channels_of(i, stream) for i in feed.inputs)
                except ValueError as exc:
                    feed.rejected = stream.uid
                    events += self._set(feed, Condition.WRONG_CHANNELS, now, str(exc))
                    continue
            was = feed.status.condition if feed.status else Condition.WAITING
            condition = Condition.OK
            if was is Condition.VANISHED or feed.uid:
                condition = Condition.BACK if stream.uid == feed.uid else Condition.RESTARTED
            feed.connected, feed.width = True, stream.n_channels
            feed.uid, feed.arrival = stream.uid, now
            feed.rate, feed.recent = max(stream.rate, 0.0), deque()
            feed.spread = Respread(feed.rate)  # a declared rate only: an irregular one is not
            feed.last, feed.stamp = -math.inf, -math.inf
            if condition is not Condition.BACK:  # the same outlet back: the same clock,
                feed.shift = 0.0  # re-anchored as it was (a new outlet: its own clock)
            events += self._set(feed, condition, now, stream.summary())
        return events

    # ------------------------------------------------------------------ polling

    def poll(self, pulled: Mapping[int, Pulled], now: float) -> SourceBatch:
        """What arrived since the last poll: ``pulled``, each connected feed's samples (by
        its index; a feed absent gave none), at ``now`` (see the module docstring)."""
        batch = SourceBatch({}, [], [], set())
        for k, feed in enumerate(self._feeds):
            if not feed.connected:
                continue
            got = pulled.get(k, Pulled.NOTHING)
            if got.lost:
                feed.connected = False
                batch.events += self._set(feed, Condition.VANISHED, now, "its outlet is gone; "
                                          "looking for it again")  # fmt: skip
                batch.broken.update(feed.names)
                continue
            times, values = got.times, got.values
            if len(times) == 0:
                batch.events += self._check_stall(feed, now)
                if feed.inputs:
                    self._given(feed, *feed.spread.release(now), now, batch)
                continue
            if not feed.inputs:
                feed.received += len(times)
                if len(values) != len(times):  # no transport gives it; never raised out of here
                    feed.left_out += len(times)
                    batch.events += self._set(feed, Condition.WRONG_CHANNELS, now,
                                              f"{len(times)} marker stamps with {len(values)} "
                                              "labels: left out")  # fmt: skip
                    continue
                times = np.asarray(times, dtype=float) + feed.shift
                batch.markers += [(float(t), str(v)) for t, v in zip(times, values, strict=True)]
                feed.arrival = now
                continue
            self._samples(feed, np.asarray(times, dtype=float), np.asarray(values), now, batch)
        return batch

    def _samples(self, feed: _Feed, times: np.ndarray, values: np.ndarray, now: float,
                 batch: SourceBatch) -> None:  # fmt: skip
        feed.received += times.shape[0]
        feed.heard = now  # a stream that sends bad values is not stalled
        width = feed.width
        if values.ndim != 2 or values.shape[1] != width or times.ndim != 1 \
                or values.shape[0] != times.shape[0]:  # fmt: skip
            feed.left_out += times.shape[0]
            batch.events += self._set(feed, Condition.WRONG_CHANNELS, now,
                                      f"samples of shape {values.shape}, not (n, {width}): "
                                      "left out")  # fmt: skip
            return
        index = np.concatenate([c.index for c in feed.channels])
        scale = np.concatenate([c.scale for c in feed.channels])
        values = values[:, index] * scale
        stamped = np.isfinite(times)
        with np.errstate(invalid="ignore"):
            finite = np.all(np.abs(values) <= MAX_MAGNITUDE, axis=1) & stamped
        condition = feed.status.condition
        if not finite.all():
            bad = int((~finite).sum())
            feed.left_out += bad
            if condition is Condition.BAD_VALUES:  # the same episode: counted, said once
                bad += int(feed.status.detail.split(" ")[0])
                feed.status = StreamStatus(feed.status.stream, condition, feed.status.since,
                                           f"{bad} {BAD_DETAIL}")  # fmt: skip
            else:
                batch.events += self._set(feed, Condition.BAD_VALUES, now, f"{bad} {BAD_DETAIL}")
            feed.clean_since = math.inf
        elif condition is Condition.BAD_VALUES:
            feed.clean_since = min(feed.clean_since, now)
            if now - feed.clean_since >= CLEAN_S:
                batch.events += self._set(feed, Condition.OK, now, "samples usable again")
        elif condition in (Condition.STALLED, Condition.WAITING, Condition.WRONG_CHANNELS):
            batch.events += self._set(feed, Condition.OK, now, "samples usable again")
        # a bad sample's stamp is the stream's clock all the same: a jump after bad values
        # (a marker occluded from the start) is found by it, and it is never given
        if not stamped.all():
            times, values, finite = times[stamped], values[stamped], finite[stamped]
        if times.shape[0] == 0:
            return
        times = times + feed.shift
        kept = self._clock(feed, times, now, batch)
        feed.left_out += int((~kept & finite).sum())  # (bad values: counted above)
        if not kept.any():
            return
        feed.arrival = now
        usable = kept & finite
        times, values = times[usable], values[usable]
        self._given(feed, *feed.spread.add(times, values, now), now, batch)

    def _given(self, feed: _Feed, times: np.ndarray, values: np.ndarray, now: float,
               batch: SourceBatch) -> None:  # fmt: skip
        """Samples given to the inputs (their late bursts re-spread: :mod:`promp.live.restamp`)."""
        if times.shape[0] == 0:
            return
        feed.last = float(times[-1])
        batch.events += self._check_rate(feed, times, now)
        start = 0
        for live_input, channels in zip(feed.inputs, feed.channels, strict=True):
            width = channels.index.shape[0]
            batch.samples[live_input.name] = (times, values[:, start:start + width],
                                              channels.units)  # fmt: skip
            start += width

    def _clock(self, feed: _Feed, times: np.ndarray, now: float,
               batch: SourceBatch) -> np.ndarray:  # fmt: skip
        """Jumps re-anchored in ``times`` (in place), the stamps kept (a mask: those that go
        back a little are left out; module docstring)."""
        if math.isfinite(feed.stamp):
            diffs = np.diff(np.concatenate([[feed.stamp], times]))
            back = np.flatnonzero(diffs <= -JUMP_S)
            # ahead of the time that passed here, beyond catching up how late the last
            # delivery was (a sender pushing its backlog on a busy machine is no jump)
            late = max(feed.arrival - feed.stamp, 0.0)
            leap = (times[-1] - feed.stamp) - (now - feed.arrival) - late > JUMP_S
            if back.size or leap:
                i = int(back[0]) if back.size else int(np.argmax(diffs))
                previous = feed.stamp if i == 0 else float(times[i - 1])
                delta = previous + (feed.step or float(np.median(np.abs(diffs)))) - times[i]
                feed.shift += delta
                times[i:] += delta
                batch.broken.update(feed.names)
                batch.events += self._set(
                    feed, Condition.CLOCK_JUMP, now,
                    f"its time stamps jumped by {-delta:+.3f} s; re-anchored",
                )  # fmt: skip
        keep = times > np.maximum.accumulate(np.concatenate([[feed.stamp], times]))[:-1]
        if keep.any():
            feed.stamp = float(times[keep][-1])
        return keep

    def _check_rate(self, feed: _Feed, times: np.ndarray, now: float) -> list[LiveEvent]:
        """The rate from the median step of the last :data:`RATE_WINDOW_S` (a pause is not
        a rate: the window starts again after one; the median follows a new rate once it
        holds half the window). After a change is said the window starts again: one change,
        one event (a restarted outlet's backlog, a late sender's bursts re-spread)."""
        recent = feed.recent
        if recent and times[0] - recent[-1] > max(STALL_MIN_S, STALL_STEPS * feed.step):
            recent.clear()
        recent.extend(times.tolist())
        while recent and recent[-1] - recent[0] > RATE_WINDOW_S:
            recent.popleft()
        span = recent[-1] - recent[0] if recent else 0.0
        if len(recent) < 5 or span < 0.5 * RATE_WINDOW_S:
            return []
        measured = 1.0 / float(np.median(np.diff(np.asarray(recent))))
        if feed.rate <= 0:
            feed.rate = measured
            return []
        if abs(measured / feed.rate - 1.0) <= RATE_TOLERANCE:
            return []
        before, feed.rate = feed.rate, measured
        if feed.spread.rate > 0:
            feed.spread.rate = measured  # the declared rate was wrong: spread at the real one
        recent.clear()
        return self._set(feed, Condition.RATE_CHANGED, now,
                         f"from {before:.4g} Hz to {measured:.4g} Hz")  # fmt: skip

    def _check_stall(self, feed: _Feed, now: float) -> list[LiveEvent]:
        if not feed.inputs or not math.isfinite(feed.last):
            return []
        limit = max(STALL_MIN_S, STALL_STEPS * feed.step)
        heard = max(feed.arrival, feed.heard)
        if now - heard < limit or feed.status.condition is Condition.STALLED:
            return []
        return self._set(feed, Condition.STALLED, heard,
                         f"no sample for over {limit:.2g} s")  # fmt: skip

    @staticmethod
    def _set(feed: _Feed, condition: Condition, since: float, detail: str) -> list[LiveEvent]:
        old = feed.status
        if old is not None and old.condition is condition and old.detail == detail:
            return []
        feed.status = StreamStatus(str(feed.selector), condition, since, detail)
        return [LiveEvent(since, f"stream {str(feed.selector)!r}: {condition.value} ({detail})")]

    # ------------------------------------------------------------------ reading

    def statuses(self) -> tuple[StreamStatus, ...]:
        """Each input stream's status (and the marker stream's, last)."""
        return tuple(f.status for f in self._feeds if f.status is not None)

    def counts(self) -> dict[str, tuple[int, int]]:
        """Per stream (as selected): samples received, and left out (bad values, stamps
        going back)."""
        return {f.label: (f.received, f.left_out) for f in self._feeds}

    def lateness(self, name: str, now: float) -> float:
        """How far input ``name``'s late samples were moved back in the
        :data:`promp.live.restamp.LATE_WINDOW_S` before ``now`` (s; 0: on time)."""
        feed = next(f for f in self._feeds if name in f.names)
        return feed.spread.lateness(now)

    def nominal_rate(self, name: str) -> float:
        """The rate input ``name``'s stream is believed to run at (Hz; 0 while unknown)."""
        return next(f.rate for f in self._feeds if name in f.names)
