"""A live session: the stages wired, on one clock, behind one immutable snapshot.

``source -> time base -> segmenter -> online predictor -> sinks`` (:mod:`promp.live`).
:meth:`LiveSession.step` runs each stage once on what arrived (tests call it directly, with a
fake transport and a manual clock); :meth:`LiveSession.start` runs it on a thread of its own,
with a second thread that looks for the streams that are missing (a find blocks for a moment),
and publishes a :class:`LiveSnapshot` after each step that changed something: the studio's
loop reads :meth:`LiveSession.snapshot` every frame without a lock and calls
:meth:`LiveSession.begin` / :meth:`LiveSession.end` (a Record button) from any thread. No fault
of a stream, of the method or of a sink stops the session: it becomes an event and a status.
"""

from __future__ import annotations

import queue
import threading
import traceback
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from promp.live.outlets import PredictionOutlets
from promp.live.predictor import LivePrediction, OnlinePredictor, observed_columns
from promp.live.recorder import Recorded, Recorder
from promp.live.segmenter import (
    MAX_MOVEMENT_S,
    Belief,
    Boundary,
    Movement,
    Segmenter,
    StillRule,
)
from promp.live.source import LiveInput, Source
from promp.live.status import LiveEvent, StreamStatus
from promp.live.timebase import TimeBase
from promp.live.transport import Selector, StreamDescription, Transport
from promp.model import ProMPModel

__all__ = [
    "check_inputs",
    "ERROR_PAUSE_S",
    "EVENTS_KEPT",
    "FIND_EVERY_S",
    "FIND_WAIT_S",
    "IDLE_S",
    "LiveOptions",
    "LiveSession",
    "LiveSnapshot",
]

IDLE_S = 0.002  # the loop's pause when nothing arrived
ERROR_PAUSE_S = 0.5
FIND_EVERY_S = 0.5  # how often the resolver looks (for the missing streams, and the list)
FIND_WAIT_S = 0.5
EVENTS_KEPT = 50


@dataclass(frozen=True)
class LiveOptions:
    """How a session observes and predicts.

    Attributes
    ----------
    start : {"still", "marker", "call"}
        How movements start and end (:mod:`promp.live.segmenter`).
    markers : str
        The marker stream (NAME, type=TYPE or source_id=ID) for ``start="marker"``.
    alpha_method : {"ml", "model"}
    remainder : str or None
        The modality whose predicted remainder is published.
    remainder_rate : float
        Its rate, Hz.
    rate : float or None
        A regular time base at this rate (Hz); None: the slowest input's samples.
    max_movement_s : float
    n_points : int or None
        The prior and posterior's samples (:func:`promp.evidence.pipeline.infer`).
    min_observed : int
        Rows a movement needs before its first prediction.
    """

    start: str = "still"
    markers: str = ""
    alpha_method: str = "ml"
    remainder: str | None = None
    remainder_rate: float = 50.0
    rate: float | None = None
    max_movement_s: float = MAX_MOVEMENT_S
    n_points: int | None = None
    min_observed: int = 2


@dataclass(frozen=True, eq=False)
class LiveSnapshot:
    """The session at one moment (immutable; a new one after each step that changed it).

    Attributes
    ----------
    version : int
    time : float
        The session's clock when it was taken.
    found : tuple of StreamDescription
        The streams on the network at the last look (names, rates, channel counts).
    statuses : tuple of StreamStatus
        Each input's (and the marker stream's).
    movement : Movement or None
        The movement going on.
    prediction : LivePrediction or None
        The latest (of the movement going on, or of the last one).
    events : tuple of LiveEvent
        The latest :data:`EVENTS_KEPT`.
    n_events : int
        The events so far (the last of them are ``events``).
    ended : tuple of Movement
        The movements that ended, latest last (at most :data:`EVENTS_KEPT`).
    recorded : tuple of Recorded
        With a recorder, the movements it recorded (latest last, at most
        :data:`EVENTS_KEPT`): each one's demonstration, for a take.
    predictions : int
        Published so far.
    counts : dict of str to (int, int)
        Per input: samples received, samples left out.
    """

    version: int
    time: float
    found: tuple[StreamDescription, ...]
    statuses: tuple[StreamStatus, ...]
    movement: Movement | None
    prediction: LivePrediction | None
    events: tuple[LiveEvent, ...]
    n_events: int
    ended: tuple[Movement, ...]
    recorded: tuple[Recorded, ...]
    predictions: int
    counts: dict[str, tuple[int, int]]


class LiveSession:
    """The live pipeline (see the module docstring).

    Parameters
    ----------
    model : ProMPModel
    inputs : sequence of LiveInput or str
        The modalities observed (``hand=MocapHand:0,1,2@mm``); each must be a modality of the
        model with as many channels as it has columns.
    transport : Transport
    options : LiveOptions
    outlets : PredictionOutlets, optional
    recorder : Recorder, optional
        Records every movement (its demonstrations are in the snapshot's ``ended``).
    on_prediction : callable, optional
        Called with each prediction on the session's thread (a bench's probe).
    """

    def __init__(
        self,
        model: ProMPModel,
        inputs: Sequence[LiveInput | str],
        transport: Transport,
        options: LiveOptions | None = None,
        outlets: PredictionOutlets | None = None,
        recorder: Recorder | None = None,
        on_prediction: Callable[[LivePrediction], None] | None = None,
    ):
        options = options or LiveOptions()
        inputs = [i if isinstance(i, LiveInput) else LiveInput.parse(i) for i in inputs]
        check_inputs(model, inputs)
        if options.start == "marker" and not options.markers:
            raise ValueError("--start marker needs the marker stream: --markers STREAM")
        if options.markers and options.start != "marker":
            raise ValueError(f"a marker stream ({options.markers!r}) starts and ends movements "
                             f"only with --start marker, not --start {options.start}")
        self.model, self.options, self.transport = model, options, transport
        names = [i.name for i in inputs]
        widths = [len(i.modality.fields) for i in inputs]
        columns = observed_columns(names, widths)
        units = [model.layout.modality(i.name).unit for i in inputs]
        markers = Selector.parse(options.markers) if options.markers else None
        self.source = Source(inputs, transport, markers, own=self._own_streams)
        self.timebase = TimeBase(names, widths, options.rate)
        watched = [n for n, u in zip(names, units, strict=True) if u in ("m", "rad")]
        self.segmenter = Segmenter(
            options.start, sum(widths), [(columns[n], u) for n, u in zip(names, units,
                                                                      strict=True)],
            options.max_movement_s, StillRule.of(model, watched),
        )  # fmt: skip
        self.predictor = OnlinePredictor(model, columns, options.alpha_method, options.remainder,
                                         options.remainder_rate, options.n_points)  # fmt: skip
        self.columns = tuple(c for n in names for c in model.layout.modality(n).columns)
        self.outlets, self.recorder, self.on_prediction = outlets, recorder, on_prediction
        self._calls: queue.SimpleQueue = queue.SimpleQueue()
        self._opened: queue.SimpleQueue = queue.SimpleQueue()
        self._events: deque[LiveEvent] = deque(maxlen=EVENTS_KEPT)
        self._ended: deque[Movement] = deque(maxlen=EVENTS_KEPT)
        self._recorded: deque[Recorded] = deque(maxlen=EVENTS_KEPT)
        self._found: tuple[StreamDescription, ...] = ()
        self._predicted = (0, 0)  # (movement, rows) of the latest prediction
        self._prediction: LivePrediction | None = None
        self._count = 0
        self.compute_s: deque[float] = deque(maxlen=100_000)  # each inference's time
        self._n_events = 0
        self._version = 0
        self._snapshot = self._take()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    # ------------------------------------------------------------------ from any thread

    def snapshot(self) -> LiveSnapshot:
        return self._snapshot

    def begin(self, label: str = "", time: float | None = None) -> None:
        """A movement starts now (or at ``time`` on the session's clock)."""
        self._calls.put(("start", self.transport.clock() if time is None else time, label))

    def end(self, time: float | None = None) -> None:
        """The movement going on ends now (or at ``time``)."""
        self._calls.put(("end", self.transport.clock() if time is None else time, ""))

    def start(self) -> None:
        """Run the session on its own threads until :meth:`close`."""
        if self._threads:
            return
        self._stop.clear()
        self._threads = [threading.Thread(target=self._loop, name="live-session", daemon=True),
                         threading.Thread(target=self._resolve, name="live-resolver",
                                          daemon=True)]  # fmt: skip
        for thread in self._threads:
            thread.start()

    def close(self) -> None:
        """Stop the threads, close the inlets, the outlets and the recorder's journal (a
        recording under way stays in its journal)."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=10.0)
        self._threads = []
        self.source.close()
        if self.outlets is not None:
            self.outlets.close()
        if self.recorder is not None:
            self.recorder.close()

    # ------------------------------------------------------------------ the threads

    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                worked = self.step()
            except Exception as exc:  # a defect here must show, not end the session silently
                where = traceback.extract_tb(exc.__traceback__)[-1]
                self._calls.put(("event", self.transport.clock(),
                                 f"the session's step failed: {type(exc).__name__}: {exc} "
                                 f"({Path(where.filename).name}:{where.lineno})"))
                self._stop.wait(ERROR_PAUSE_S)
                continue
            if not worked:
                self._stop.wait(IDLE_S)

    def _resolve(self) -> None:
        while not self._stop.is_set():
            try:
                found = self.transport.find(FIND_WAIT_S)
                self._found = tuple(found)
                missing = self.source.missing()
                if missing:
                    self._opened.put(self.source.open_missing(found, missing))
            except Exception as exc:  # a transport error must not end the search
                self._calls.put(("event", self.transport.clock(),
                                 f"looking for streams failed: {type(exc).__name__}: {exc}"))
            self._stop.wait(FIND_EVERY_S)

    def _own_streams(self) -> frozenset[str]:
        """The source ids of the streams this session publishes (never read back as its
        inputs or markers: its events would come back as markers, each saying the last)."""
        return frozenset(self.outlets.source_ids) if self.outlets is not None else frozenset()

    def connect(self, wait: float = FIND_WAIT_S) -> None:
        """Look for the missing streams once, here (a session stepped by hand)."""
        found = self.transport.find(wait)
        self._found = tuple(found)
        self._opened.put(self.source.open_missing(found, self.source.missing()))

    # ------------------------------------------------------------------ one step

    def step(self) -> bool:
        """Each stage once on what arrived; True when anything did."""
        now = self.transport.clock()
        events: list[LiveEvent] = []
        boundaries: list[Boundary] = []
        while not self._opened.empty():
            events += self.source.adopt(self._opened.get())
        while not self._calls.empty():
            kind, time, label = self._calls.get()
            if kind == "start":
                self.segmenter.begin(time, label)
            elif kind == "end":
                self.segmenter.end(time)
            else:
                events.append(LiveEvent(time, label))
        batch = self.source.poll()
        events += batch.events
        for name in sorted(batch.broken):
            self.timebase.restart(name)
            boundaries += self.segmenter.abort(f"input {name!r} broke off")
        for name, (times, values, units) in batch.samples.items():
            gap = self.timebase.push(name, times, values, units, self.source.nominal_rate(name),
                                     self.source.lateness(name))  # fmt: skip
            if gap:
                events.append(LiveEvent(now, gap))
                boundaries += self.segmenter.abort(gap)
        self.segmenter.markers(batch.markers)
        for time, label in self.segmenter.unknown:
            events.append(LiveEvent(time, f"marker {_shown(label)} left out (not start/end "
                                          "CLASS)"))  # fmt: skip
        self.segmenter.unknown.clear()
        rows = self.timebase.advance({n: self.source.nominal_rate(n)
                                      for n in self.timebase.names})  # fmt: skip
        boundaries += self.segmenter.feed(rows, self._belief())
        predicted = False
        for b in boundaries:
            if b.movement is not None:  # its last rows, if they came with its end
                predicted |= self._predict(b.movement, events)
            events += self._boundary(b)
        movement = self.segmenter.movement
        if movement is not None:
            if self.recorder is not None:
                self._sink(lambda: self.recorder.append(movement), events)
            predicted |= self._predict(movement, events)
        for event in events:
            self._events.append(event)
            self._n_events += 1
            self._sink(lambda e=event: self.outlets and self.outlets.event(e), events)
        changed = bool(events or boundaries or rows is not None or predicted
                       or self.source.statuses() != self._snapshot.statuses)  # a count said
        if changed or len(self._found) != len(self._snapshot.found):
            self._snapshot = self._take()
        return bool(batch.samples or batch.markers or events or predicted)

    def _belief(self) -> Belief | None:
        """What the latest prediction says of its movement (the segmenter's pause allowed)."""
        p = self._prediction
        return None if p is None else Belief(p.movement, p.primitive, p.phase.high)

    def _boundary(self, b: Boundary) -> list[LiveEvent]:
        if b.kind == "start":
            return [LiveEvent(b.time, f"movement {b.number} started")]
        events = [LiveEvent(b.time, f"movement {b.number} ended ({b.reason})")]
        if b.movement is not None:
            self._ended.append(b.movement)
            if self.recorder is not None:
                def finish(movement=b.movement) -> None:
                    recorded = self.recorder.finish(movement)
                    if recorded is not None:
                        self._recorded.append(recorded)

                self._sink(finish, events)
        return events

    def _predict(self, movement: Movement, events: list[LiveEvent]) -> bool:
        """A prediction from ``movement``'s rows, unless they were predicted from (or a
        still end cut them back to fewer)."""
        n = len(movement)
        number, done = self._predicted
        if n < self.options.min_observed or (number == movement.number and n <= done):
            return False
        self._predicted = (movement.number, n)
        try:
            prediction = self.predictor.predict(movement.number, movement.times, movement.values)
        except ValueError as exc:
            events.append(LiveEvent(float(movement.times[-1]), f"no prediction: {exc}"))
            return False
        self._prediction = prediction
        self._count += 1
        self.compute_s.append(prediction.compute_s)
        if self.outlets is not None:
            self._sink(lambda: self.outlets.publish(prediction), events)
        if self.on_prediction is not None:
            self.on_prediction(prediction)
        return True

    def _sink(self, action: Callable[[], object], events: list[LiveEvent]) -> None:
        """Run a sink's ``action``; its failure is an event, never the session's end."""
        try:
            action()
        except Exception as exc:  # a sink (an outlet, the disk) failing must not stop it
            events.append(LiveEvent(self.transport.clock(),
                                    f"a sink failed: {type(exc).__name__}: {exc}"))

    def _take(self) -> LiveSnapshot:
        self._version += 1
        return LiveSnapshot(
            self._version, self.transport.clock(), self._found, self.source.statuses(),
            self.segmenter.movement, self._prediction, tuple(self._events), self._n_events,
            tuple(self._ended), tuple(self._recorded),
            self._count, self.source.counts(),
        )  # fmt: skip


def _shown(label: str, limit: int = 60) -> str:
    """A marker's label as an event quotes it (cut to ``limit`` characters)."""
    return repr(label if len(label) <= limit else label[:limit] + "...")


def check_inputs(model: ProMPModel, inputs: Sequence[LiveInput]) -> None:
    """ValueError unless each input is a modality of ``model`` with its number of columns
    and, where the mapping states one, a unit that converts to the modality's."""
    from promp.rigs.mapping import si_unit

    for live_input in inputs:
        modality = model.layout.modality(live_input.name)  # raises on an unknown name
        fields = live_input.modality.fields
        if len(fields) != len(modality.columns):
            raise ValueError(
                f"input {live_input.name!r} maps {len(fields)} channel(s) {list(fields)}, but "
                f"the model's {modality.name!r} has {len(modality.columns)} columns "
                f"{list(modality.columns)}"
            )
        stated = live_input.modality.stated_unit
        if stated and modality.unit and si_unit(stated)[0] != modality.unit:
            raise ValueError(
                f"input {live_input.name!r} is in {stated!r} ({si_unit(stated)[0]!r}), but the "
                f"model's {modality.name!r} is in {modality.unit!r}"
            )

