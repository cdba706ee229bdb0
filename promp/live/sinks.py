"""The sinks: where a live session's outputs go, each on a thread of its own.

After each step the runner offers the step's :class:`Output` to every sink (the prediction
outlets, the events outlet, the recorder and its journal, a callback of the studio or a
bench): :meth:`SinkWorker.offer` takes the part the sink reads (:meth:`Sink.view`) into the
sink's bounded queue and returns at once; the sink's thread delivers it. So a sink that
raises, blocks or finds the disk full never stalls the prediction:

* **raises**: the output is lost to that sink; the failure is counted, and said once when the
  sink starts failing (``sink 'events outlet' failed: OSError: ...``) and once when it works
  again, never once per output (an events outlet that fails on the event saying it failed
  says nothing new);
* **blocks**: its queue fills (:data:`QUEUE_OUTPUTS` outputs); after that, a lossy sink's
  oldest queued outputs are dropped for the new ones (it delivers the latest when it can) and
  counted, said once when it falls behind and once when it has caught up. A lossless sink
  (the recorder: its appends carry every row of the movement so far) folds each new output
  into the last one queued (:meth:`Output.then`): nothing is lost but
  the ended movements beyond :data:`QUEUE_OUTPUTS` in one fold, counted as dropped (their
  journals keep what was acknowledged, recovered as after a kill).

:class:`Sinks` holds the workers: :meth:`Sinks.news` gives the events of the sinks' changes
since the last call (the runner says them after the step), :meth:`Sinks.flush` waits until
every queue is empty, :meth:`Sinks.close` drains the queues and closes each sink.

**Prompt sinks.** A sink whose ``prompt`` is True (the prediction outlets) is waited for after
a step that offered it something, for at most :data:`PROMPT_S` (:meth:`Sinks.settle`), before
the next step begins: its thread then delivers while the session's thread waits, instead of
waiting for Python's interpreter lock behind the next inference (each call into liblsl gives
the lock up, and getting it back from a thread that is inferring waits up to the switch
interval: a prediction reached its readers up to 6 ms after it was made, ``bench/live.py``).
The wait is bounded, and a sink that did not deliver within it is not waited for again until
its queue is found empty: a sink that blocks delays the prediction by :data:`PROMPT_S` once.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

from promp.live.pipeline import Arrivals
from promp.live.predictor import LivePrediction
from promp.live.segmenter import Boundary, Movement
from promp.live.status import LiveEvent

__all__ = ["CallbackSink", "CLOSE_S", "Output", "PROMPT_S", "QUEUE_OUTPUTS", "Sink",
           "SinkState", "Sinks", "SinkWorker"]  # fmt: skip

QUEUE_OUTPUTS = 256  # a sink may fall this many outputs behind (a second at 250 steps/s)
CLOSE_S = 5.0  # how long closing waits for a sink to deliver what it has queued
PROMPT_S = 0.002  # how long a step waits at most for its prompt sinks to deliver


@dataclass(frozen=True, eq=False)
class Output:
    """What one step gives the sinks.

    Attributes
    ----------
    time : float
        The session's clock at the step.
    events : tuple of LiveEvent
    boundaries : tuple of Boundary
    predictions : tuple of LivePrediction
    movement : Movement or None
        The movement going on after the step (all its rows so far).
    arrivals : tuple of Arrivals
        What the step (or the steps folded into this output) ran on: a session file's record
        (:mod:`promp.live.session_file`).
    """

    time: float
    events: tuple[LiveEvent, ...] = ()
    boundaries: tuple[Boundary, ...] = ()
    predictions: tuple[LivePrediction, ...] = ()
    movement: Movement | None = None
    arrivals: tuple[Arrivals, ...] = ()

    def then(self, later: Output) -> Output:
        """This output and ``later`` as one (the later movement going on)."""
        return Output(later.time, self.events + later.events,
                      self.boundaries + later.boundaries, self.predictions + later.predictions,
                      later.movement, self.arrivals + later.arrivals)  # fmt: skip


class Sink(Protocol):
    """A sink of the session's outputs (see the module docstring)."""

    name: str  # how the events name it
    lossless: bool  # a full queue folds outputs (True) or drops the oldest (False)
    # (optional) prompt: bool, waited for after each step that offers it something (True)

    def view(self, output: Output) -> Output | None:
        """The part of ``output`` this sink reads (None: nothing; not queued)."""

    def take(self, output: Output) -> Sequence[object]:
        """Deliver ``output`` (on the sink's thread); what it returns, the session keeps
        (the recorder's :class:`promp.live.recorder.Recorded`)."""

    def close(self) -> None: ...


@dataclass(frozen=True)
class SinkState:
    """A sink at one moment: outputs delivered, failures (the last one's error, and whether
    the latest delivery failed), outputs dropped, queued, and whether its queue is full."""

    name: str
    delivered: int = 0
    failures: int = 0
    failing: bool = False
    error: str = ""
    dropped: int = 0
    queued: int = 0
    full: bool = False

    @property
    def healthy(self) -> bool:
        return not self.failing and not self.full


class SinkWorker:
    """One sink on its own thread, behind a bounded queue (see the module docstring)."""

    def __init__(self, sink: Sink, capacity: int | None = None):
        self.sink = sink
        self.capacity = int(QUEUE_OUTPUTS if capacity is None else capacity)
        self._queue: deque[Output] = deque()
        self._cond = threading.Condition()
        self._busy = False
        self._closing = False
        self._state = SinkState(sink.name)
        self._kept: list[object] = []
        self.prompt = bool(getattr(sink, "prompt", False))
        self._late = False  # a settle timed out: not waited for until its queue empties
        self._thread = threading.Thread(target=self._run, name=f"live-sink-{sink.name}",
                                        daemon=True)  # fmt: skip
        self._thread.start()

    def offer(self, output: Output) -> None:
        """Queue the part of ``output`` the sink reads; never blocks."""
        part = self.sink.view(output)
        if part is None:
            return
        with self._cond:
            dropped = 0
            if len(self._queue) < self.capacity:
                self._queue.append(part)
            elif self.sink.lossless:
                folded = self._queue[-1].then(part)
                ends = folded.boundaries
                dropped = max(len(ends) - self.capacity, 0)
                self._queue[-1] = replace(folded, boundaries=ends[dropped:])
            else:  # the oldest goes: a live sink wants the latest
                self._queue.popleft()
                self._queue.append(part)
                dropped = 1
            queued = len(self._queue)
            self._state = replace(self._state, dropped=self._state.dropped + dropped,
                                  queued=queued, full=queued >= self.capacity)  # fmt: skip
            self._cond.notify_all()

    def _run(self) -> None:
        while True:
            with self._cond:
                self._cond.wait_for(lambda: self._queue or self._closing)
                if not self._queue:
                    return
                output = self._queue.popleft()
                self._busy = True
            failed, kept = "", ()
            try:
                kept = self.sink.take(output) or ()
            except Exception as exc:  # a sink failing must not end its thread
                failed = f"{type(exc).__name__}: {exc}"
            with self._cond:
                self._busy = False
                self._kept.extend(kept)
                s = self._state
                self._state = replace(
                    s, delivered=s.delivered + (not failed), failures=s.failures + bool(failed),
                    failing=bool(failed), error=failed or s.error, queued=len(self._queue),
                    full=len(self._queue) >= self.capacity,
                )  # fmt: skip
                self._cond.notify_all()

    def state(self) -> SinkState:
        return self._state

    def kept(self) -> list[object]:
        """What the sink returned since the last call."""
        if not self._kept:  # most calls: nothing (read without the lock: a list's length)
            return []
        with self._cond:
            kept, self._kept = self._kept, []
        return kept

    def flush(self, timeout: float) -> bool:
        """Wait until everything queued was delivered; False after ``timeout`` seconds."""
        with self._cond:
            return self._cond.wait_for(lambda: not self._queue and not self._busy, timeout)

    def settle(self, deadline: float) -> bool:
        """Wait until everything queued was delivered, at most until ``deadline``
        (:func:`time.monotonic`), unless the sink was late at the last settle and still has
        something queued (module docstring: prompt sinks); whether it was delivered."""
        with self._cond:
            idle = not self._queue and not self._busy
            if idle or (self._late and self._queue):
                self._late = self._late and not idle
                return idle
            done = self._cond.wait_for(lambda: not self._queue and not self._busy,
                                       max(deadline - time.monotonic(), 0.0))  # fmt: skip
            self._late = not done
            return done

    def stop(self, timeout: float) -> bool:
        """Deliver what is queued and end the thread; False if it is still busy after
        ``timeout`` seconds (a sink that blocks: its thread is left behind)."""
        with self._cond:
            self._closing = True
            self._cond.notify_all()
        self._thread.join(timeout)
        return not self._thread.is_alive()


class Sinks:
    """The session's sink workers, and what is said of them (see the module docstring)."""

    def __init__(self, sinks: Sequence[Sink], capacity: int | None = None):
        self.workers = tuple(SinkWorker(s, capacity) for s in sinks)
        self._said = {w.sink.name: _Said() for w in self.workers}

    def offer(self, output: Output) -> None:
        for worker in self.workers:
            worker.offer(output)

    def states(self) -> tuple[SinkState, ...]:
        return tuple(w.state() for w in self.workers)

    def kept(self) -> list[object]:
        return [k for w in self.workers for k in w.kept()]

    def news(self, now: float, states: Sequence[SinkState] | None = None) -> list[LiveEvent]:
        """The events of the sinks' changes since the last call (``states``: theirs now, if
        just read): one per change of a sink (it started or stopped failing, fell behind or
        caught up), never one per output."""
        events = []
        for state in self.states() if states is None else states:
            texts = self._said[state.name].update(state)
            events += [LiveEvent(now, f"sink {state.name!r} {t}") for t in texts]
        return events

    def settle(self, timeout: float = PROMPT_S) -> bool:
        """Wait, at most ``timeout`` seconds in all, until every prompt sink delivered what was
        offered (module docstring: a sink late at its last settle is not waited for)."""
        deadline = time.monotonic() + timeout
        return all([w.settle(deadline) for w in self.workers if w.prompt])

    def flush(self, timeout: float = CLOSE_S) -> bool:
        """Wait until every sink delivered what was offered; False after ``timeout``."""
        return all([w.flush(timeout) for w in self.workers])

    def close(self, timeout: float = CLOSE_S) -> list[str]:
        """Drain and stop every worker, then close every sink; what could not be done."""
        problems = [f"sink {w.sink.name!r} did not finish in {timeout:g} s"
                    for w in self.workers if not w.stop(timeout)]  # fmt: skip
        for worker in self.workers:
            try:
                worker.sink.close()
            except Exception as exc:  # closing must go on to the others
                problems.append(f"sink {worker.sink.name!r} did not close: "
                                f"{type(exc).__name__}: {exc}")  # fmt: skip
        return problems


@dataclass
class _Said:
    """What was last said of one sink."""

    failing: bool = False
    error: str = ""
    failures: int = 0
    behind: bool = False
    dropped: int = 0

    def update(self, state: SinkState) -> list[str]:
        """What changed since (at most one text per kind of change), remembered as said."""
        texts = []
        if state.failures > self.failures and (not self.failing or state.error != self.error):
            texts.append(f"failed: {state.error}")
            self.failing, self.error = True, state.error
        if self.failing and not state.failing:
            texts.append(f"works again (after {state.failures} failure(s))")
            self.failing = False
        behind = state.full or state.dropped > self.dropped
        if behind and not self.behind:
            texts.append(f"fell behind: its queue is full ({state.dropped} output(s) dropped)")
        elif self.behind and not behind:
            texts.append(f"caught up ({state.dropped} output(s) dropped)")
        self.behind, self.failures, self.dropped = behind, state.failures, state.dropped
        return texts


class CallbackSink:
    """Each prediction handed to ``callback`` (the studio's, a bench's probe), on the sink's
    thread; ``name`` says it in the events."""

    lossless = False

    def __init__(self, callback: Callable[[LivePrediction], object],
                 name: str = "prediction callback"):  # fmt: skip
        self.callback = callback
        self.name = name

    def view(self, output: Output) -> Output | None:
        return Output(output.time, predictions=output.predictions) if output.predictions \
            else None  # fmt: skip

    def take(self, output: Output) -> Sequence[object]:
        for prediction in output.predictions:
            self.callback(prediction)
        return ()

    def close(self) -> None:
        pass
