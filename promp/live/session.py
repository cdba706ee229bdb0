"""A live session: the pure pipeline in a thin runner, its sinks given at construction.

``source -> time base -> segmenter -> online predictor -> sinks`` (:mod:`promp.live`). Each
:meth:`LiveSession.step` gathers what arrived (:class:`promp.live.intake.Intake`: the streams
a look opened, every inlet's samples, the calls of a Record button), runs the pipeline's pure
step on it (:func:`promp.live.pipeline.step`), offers the outputs to the sinks
(:mod:`promp.live.sinks`: each on its own thread behind a bounded queue, so none can stall the
prediction), says what changed of the sinks, and publishes a :class:`LiveSnapshot`. Tests call
:meth:`LiveSession.step` directly, with a fake transport and a manual clock, and
:meth:`LiveSession.flush` to wait for the sinks. :meth:`LiveSession.start` runs it on a
thread of its own, with a second thread that looks for the streams that are missing; the
studio's loop reads :meth:`LiveSession.snapshot` every frame without a lock and calls
:meth:`LiveSession.begin` / :meth:`LiveSession.end` from any thread. No fault of a stream, of
the method or of a sink stops the session: it becomes an event and a status.

The sinks are given when the session is made, never set afterwards: the prediction outlets
and the events outlet (:class:`promp.live.outlets.PredictionOutlets`), a recorder
(:class:`promp.live.recorder.Recorder`, or the studio's take recorder: its journal), a
callback for each prediction (a bench's probe), and any other :class:`promp.live.sinks.Sink`.
"""

from __future__ import annotations

import threading
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path

from promp.live.intake import Intake
from promp.live.options import LiveOptions, check_inputs, live_columns, live_inputs
from promp.live.outlets import EventSink, PredictionOutlets, PredictionSink
from promp.live.pipeline import PipelineState, build, step
from promp.live.predictor import LivePrediction
from promp.live.recorder import RecorderSink
from promp.live.sinks import CallbackSink, Output, Sink, Sinks
from promp.live.snapshot import EVENTS_KEPT, LiveSnapshot, SessionRecord
from promp.live.source import LiveInput
from promp.live.status import LiveEvent
from promp.live.transport import Transport
from promp.model import ProMPModel

__all__ = [
    "check_inputs",
    "ERROR_PAUSE_S",
    "EVENTS_KEPT",
    "FIND_EVERY_S",
    "FIND_WAIT_S",
    "IDLE_S",
    "live_columns",
    "LiveOptions",
    "LiveSession",
    "LiveSnapshot",
    "SessionThreads",
]

IDLE_S = 0.002  # the loop's pause when nothing arrived
ERROR_PAUSE_S = 0.5
FIND_EVERY_S = 0.5  # how often the resolver looks (for the missing streams, and the list)
FIND_WAIT_S = 0.5


class LiveSession:
    """The live pipeline's runner (see the module docstring).

    Parameters
    ----------
    model : ProMPModel
    inputs : sequence of LiveInput or str
        The modalities observed (``hand=MocapHand:0,1,2@mm``); each must be a modality of the
        model with as many channels as it has columns.
    transport : Transport
    options : LiveOptions
    outlets : PredictionOutlets, optional
        Each prediction and each event published (two sinks: the prediction outlets and the
        events outlet).
    recorder : Recorder, optional
        Records every movement (:class:`promp.live.recorder.Recorder` or one with its
        ``append``, ``finish`` and ``close``); what it returns is in the snapshot's
        ``recorded``.
    on_prediction : callable, optional
        Called with each prediction, on its sink's thread (the studio's, a bench's probe).
    sinks : sequence of Sink
        Any other sinks.
    now : float, optional
        The session's start on the transport's clock (default: the clock, now); a session
        file records it (:mod:`promp.live.session_file`).
    """

    def __init__(
        self,
        model: ProMPModel,
        inputs: Sequence[LiveInput | str],
        transport: Transport,
        options: LiveOptions | None = None,
        outlets: PredictionOutlets | None = None,
        recorder=None,
        on_prediction: Callable[[LivePrediction], object] | None = None,
        sinks: Sequence[Sink] = (),
        now: float | None = None,
    ):
        inputs = live_inputs(model, inputs)
        self.transport = transport
        self.state: PipelineState = build(model, inputs, options or LiveOptions(),
                                          transport.clock() if now is None else now)
        own = (lambda: outlets.source_ids) if outlets is not None else tuple
        self._intake = Intake(transport, self.state.source.wanted(), own)
        chosen: list[Sink] = []
        if outlets is not None:
            chosen += [PredictionSink(outlets), EventSink(outlets)]
        if recorder is not None:
            chosen.append(RecorderSink(recorder))
        if on_prediction is not None:
            chosen.append(CallbackSink(on_prediction))
        self._sinks = Sinks([*chosen, *sinks])
        self._record = SessionRecord()
        self._lock = threading.Lock()  # the record and the snapshot: the step and flush
        self._threads = SessionThreads(self.step, self._intake)
        self._snapshot: LiveSnapshot | None = None
        self._publish(transport.clock())

    # ------------------------------------------------------------------ from any thread

    def snapshot(self) -> LiveSnapshot:
        """The latest snapshot (immutable; read it from any thread, without a lock)."""
        return self._snapshot

    def begin(self, label: str = "", time: float | None = None) -> None:
        """A movement starts now (or at ``time`` on the session's clock)."""
        self._intake.call("start", self.transport.clock() if time is None else time, label)

    def end(self, time: float | None = None) -> None:
        """The movement going on ends now (or at ``time``)."""
        self._intake.call("end", self.transport.clock() if time is None else time)

    @property
    def compute_s(self) -> tuple[float, ...]:
        """Each inference's time, seconds (the latest :data:`promp.live.snapshot.TIMES_KEPT`)."""
        return tuple(self._record.compute_s)

    def start(self) -> None:
        """Run the session on its own threads until :meth:`close`."""
        self._threads.start()

    def close(self) -> None:
        """Stop the threads, deliver what the sinks have queued and close them (the outlets,
        the recorder's journal: a recording under way stays in its journal), close the
        inlets."""
        self._threads.stop()
        self.state.predictor.close()
        problems = self._sinks.close()
        self._intake.close()
        now = self.transport.clock()
        self._publish(now, [LiveEvent(now, p) for p in problems])

    def flush(self, timeout: float = 10.0) -> bool:
        """Wait until every sink delivered what it was offered (False after ``timeout``
        seconds), then publish what they returned and what changed of them (a stepped
        session's tests)."""
        done = self._sinks.flush(timeout)
        news = self._publish(self.transport.clock())
        return self._sinks.flush(timeout) if news else done

    def connect(self, wait: float = FIND_WAIT_S) -> None:
        """Look for the missing streams once, here (a session stepped by hand)."""
        self._intake.look(wait)

    # ------------------------------------------------------------------ one step

    def step(self) -> bool:
        """The pipeline once on what arrived, its outputs to the sinks; True when anything
        arrived or happened."""
        now = self.transport.clock()
        arrivals = self._intake.arrivals(now)
        self.state, events, boundaries, predictions = step(self.state, arrivals)
        if arrivals.opened or any(p.lost for p in arrivals.pulled.values()):
            source = self.state.source  # what the source reads changed: the inlets follow
            self._intake.settle(source.connected(), source.wanted())
        worked = bool(arrivals.opened or arrivals.calls or events or predictions
                      or any(len(p.times) for p in arrivals.pulled.values()))  # fmt: skip
        if worked or boundaries:  # (a step that did neither changed nothing but the clock)
            self._sinks.offer(Output(now, events, boundaries, predictions,
                                     self.state.segmenter.movement, (arrivals,)))  # fmt: skip
            if predictions:  # out before the next inference (promp.live.sinks: prompt sinks)
                self._sinks.settle()
        return bool(self._publish(now, events, boundaries, predictions, worked)) or worked

    def _publish(self, now: float, events=(), boundaries=(), predictions=(),
                 changed: bool = True) -> list[LiveEvent]:  # fmt: skip
        """Record a step's outputs with what changed of the sinks since (collected after the
        step, said once: in the events, and to the sinks) and what they returned, and publish
        a snapshot if anything changed; the sinks' news."""
        with self._lock:
            sinks = self._sinks.states()
            news = self._sinks.news(now, sinks)
            if news:
                self._sinks.offer(Output(now, tuple(news)))
            kept = self._sinks.kept()
            if events or boundaries or predictions or news or kept:
                self._record.add([*events, *news], boundaries, predictions, kept)
            snap = self._snapshot
            # a stream's condition changes with an event, or with samples (a count): changed;
            # the streams found by their content (one gone and another come in one look keep
            # the count)
            if snap is None or changed or news or kept or sinks != snap.sinks \
                    or self._intake.found != snap.found:  # fmt: skip
                source = self.state.source
                self._snapshot = self._record.snapshot(
                    self.transport.clock(), self._intake.found, source.statuses(),
                    self.state.segmenter.movement, source.counts(), sinks,
                )  # fmt: skip
        return news


class SessionThreads:
    """A session's two threads: the loop, stepping, and the resolver, looking for the streams
    that are missing (a find blocks for a moment). A failing step is said and the loop goes
    on after :data:`ERROR_PAUSE_S`; a failing look is said and looked again."""

    def __init__(self, step: Callable[[], bool], intake: Intake):
        self._step, self._intake = step, intake
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    def start(self) -> None:
        if self._threads:
            return
        self._stop.clear()
        self._threads = [threading.Thread(target=self._loop, name="live-session", daemon=True),
                         threading.Thread(target=self._resolve, name="live-resolver",
                                          daemon=True)]  # fmt: skip
        for thread in self._threads:
            thread.start()

    def stop(self) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=10.0)
        self._threads = []

    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                worked = self._step()
            except Exception as exc:  # a defect here must show, not end the session silently
                where = traceback.extract_tb(exc.__traceback__)[-1]
                self._intake.note(f"the session's step failed: {type(exc).__name__}: {exc} "
                                  f"({Path(where.filename).name}:{where.lineno})")  # fmt: skip
                self._stop.wait(ERROR_PAUSE_S)
                continue
            if not worked:
                self._stop.wait(IDLE_S)

    def _resolve(self) -> None:
        while not self._stop.is_set():
            try:
                self._intake.look(FIND_WAIT_S)
            except Exception as exc:  # a transport error must not end the search
                self._intake.note(f"looking for streams failed: {type(exc).__name__}: {exc}")
            self._stop.wait(FIND_EVERY_S)

