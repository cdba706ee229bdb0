"""A live session's sinks (promp.live.sinks): the prediction outlets, the events outlet, the
recorder and its journal, a prediction callback. Each one raises, blocks (until the test
releases it), or finds the disk full (OSError ENOSPC, after writing part of its data), and the
session keeps predicting through each fault; the fault is said once when it starts and once
when it ends, never once per output; what a sink was given while it blocked is delivered
(the recorder: nothing lost) or dropped and counted (the outlets, the callback); a journal
that hit a full disk holds whole rows only. A failing events outlet, whose failure was an
event for it to publish, once made a step loop for ever: it is a test of its own."""

from __future__ import annotations

import errno
import os
import threading

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import promp.live.journal
import promp.live.sinks
from promp.live.journal import read_journal
from promp.live.outlets import PredictionOutlets, outlet_specs
from promp.live.recorder import Recorder
from promp.live.session import LiveOptions, LiveSession
from promp.live.sinks import CallbackSink
from tests.live_fakes import FakeStream, FakeTransport, hand_model

RATE = 100.0
SINKS = ("prediction outlets", "events outlet", "recorder", "prediction callback")
FAULTS = ("raises", "blocks", "disk full")
LIMIT_S = 120.0  # a generous bound on work that takes well under a second: past it, a hang


class Fault:
    """A fault switched on and off at a sink's operation (``hit``)."""

    def __init__(self, kind: str):
        self.kind = kind
        self.on = False
        self.release = threading.Event()
        self.blocked = threading.Event()

    def hit(self) -> None:
        if not self.on:
            return
        if self.kind == "raises":
            raise RuntimeError("the sink broke")
        if self.kind == "disk full":
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.blocked.set()
        assert self.release.wait(LIMIT_S), "the test never released the sink"


class FullDisk:
    """The journal's ``os``: a write while the fault is on writes half its data, then fails
    as a full disk does (or raises, or blocks)."""

    def __init__(self, fault: Fault):
        self.fault = fault

    def __getattr__(self, name):
        return getattr(os, name)

    def write(self, fd: int, data: bytes) -> int:
        if self.fault.on and self.fault.kind == "disk full":
            os.write(fd, data[: len(data) // 2])
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.fault.hit()
        return os.write(fd, data)


class LosslessWitness(CallbackSink):
    """A healthy sink that never drops: every prediction the session made reaches it."""

    lossless = True


class Rig:
    """A session in call mode over a 100 Hz hand stream with every sink, ``faulty`` one of
    them, and a lossless witness of the predictions."""

    def __init__(self, tmp_path, monkeypatch, faulty: str, fault: Fault):
        self.transport = FakeTransport()
        self.stream = self.transport.add(FakeStream("Hand", ("x", "y", "z"), rate=RATE))
        model = hand_model()
        outlets = PredictionOutlets(outlet_specs(model, "icub", None), self.transport.outlet)
        kind = {"prediction outlets": "icub-probabilities", "events outlet": "icub-events"}
        if faulty in kind:
            outlet = self.transport.outlets[kind[faulty]]
            push = outlet.push

            def faulty_push(rows, stamp):
                fault.hit()
                push(rows, stamp)

            outlet.push = faulty_push
        if faulty == "recorder":
            monkeypatch.setattr(promp.live.journal, "os", FullDisk(fault))
        self.called: list = []

        def callback(prediction):
            if faulty == "prediction callback":
                fault.hit()
            self.called.append(prediction)

        self.witness: list = []
        self.recorder = Recorder(tmp_path, ("x", "y", "z"))
        self.session = LiveSession(model, ["hand=Hand:0,1,2"], self.transport,
                                   LiveOptions(start="call"), outlets=outlets,
                                   recorder=self.recorder, on_prediction=callback,
                                   sinks=[LosslessWitness(self.witness.append, "witness")])
        self.session.connect()
        self.session.step()
        self.stamp = self.transport.now
        self.wait = False  # whether each step waits for the sinks (while they are healthy)

    def push(self, n: int) -> None:
        """``n`` samples in real time (a slow circle, metres), a step every third."""
        for k in range(n):
            self.transport.now += 1 / RATE
            self.stamp += 1 / RATE
            t = self.stamp
            self.stream.push([t], np.array([[0.1 * np.cos(t), 0.1 * np.sin(t), 0.0]]))
            if k % 3 == 2 or k == n - 1:
                self.session.step()
                if self.wait:
                    self.session.flush()

    def movement(self, n: int) -> None:
        """A movement of ``n`` samples, begun and ended by calls."""
        self.session.begin()
        self.push(n)
        self.session.end(self.stamp)
        self.push(3)

    def texts(self, name: str) -> list[str]:
        return [e.text for e in self.session.snapshot().events if e.text.startswith(
            f"sink {name!r}")]  # fmt: skip


def within(work, what: str) -> None:
    """Run ``work`` on a thread; fail (not hang) when it does not end in :data:`LIMIT_S`."""
    errors: list[BaseException] = []

    def run() -> None:
        try:
            work()
        except BaseException as exc:  # noqa: BLE001 (the test's thread reports it)
            errors.append(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(LIMIT_S)
    assert not thread.is_alive(), f"{what} did not end: the session stalled"
    if errors:
        raise errors[0]


def script(rig: Rig, fault: Fault) -> tuple[int, int]:
    """Movement 1 healthy, then with the fault on: movement 1 goes on and ends, 2 and 3 come
    and go; the fault off (released), movement 4. The predictions before and during the
    fault. While the sinks are healthy, each step waits for them (a queue of 4 then never
    fills on a busy machine); while one is faulty, none does."""
    session = rig.session
    session.begin()
    rig.wait = True
    rig.push(30)
    session.flush()
    before = session.snapshot().predictions
    fault.on, rig.wait = True, False

    def faulty_part() -> None:
        rig.push(30)
        session.end(rig.stamp)
        rig.push(3)
        rig.movement(15)
        rig.movement(15)

    within(faulty_part, f"predicting while the sink is faulty ({fault.kind})")
    during = session.snapshot().predictions - before
    if fault.kind == "blocks":  # it took an output, and holds it
        assert fault.blocked.wait(LIMIT_S) and not session.flush(0.0)
    fault.on = False
    fault.release.set()
    assert session.flush()
    rig.wait = True
    rig.movement(30)
    assert session.flush()
    return before, during


HEALTHY: dict = {}


def healthy_predictions(tmp_path, monkeypatch) -> list[tuple[int, int]]:
    """What the script predicts with every sink healthy: (movement, rows) of each."""
    if not HEALTHY:
        rig = Rig(tmp_path / "healthy", monkeypatch, "none", Fault("raises"))
        HEALTHY["counts"] = script(rig, Fault("raises"))
        HEALTHY["predictions"] = [(p.movement, p.n_observed) for p in rig.witness]
        rig.session.close()
    return HEALTHY["predictions"]


@pytest.mark.parametrize("kind", FAULTS)
@pytest.mark.parametrize("faulty", SINKS)
def test_a_faulty_sink_never_stalls_the_session(tmp_path, monkeypatch, faulty, kind) -> None:
    healthy = healthy_predictions(tmp_path, monkeypatch)
    if kind == "blocks":
        monkeypatch.setattr(promp.live.sinks, "QUEUE_OUTPUTS", 4)  # falls behind sooner
    fault = Fault(kind)
    rig = Rig(tmp_path, monkeypatch, faulty, fault)
    counts = script(rig, fault)
    snap = rig.session.snapshot()
    # the same predictions as with every sink healthy, each handed on
    assert counts == HEALTHY["counts"] and counts[1] >= 15
    assert [(p.movement, p.n_observed) for p in rig.witness] == healthy
    assert [p.seq for p in rig.witness] == list(range(1, snap.predictions + 1))
    said = rig.texts(faulty)
    if kind == "blocks":
        assert [t.split(":")[0].split(" (")[0] for t in said] == [
            f"sink {faulty!r} fell behind", f"sink {faulty!r} caught up"], said
    else:
        assert len(said) == 2 and said[0].endswith(("RuntimeError: the sink broke",
                                                    "No space left on device"))  # fmt: skip
        assert "works again" in said[1], said
    state = next(s for s in snap.sinks if s.name == faulty)
    assert state.healthy and (state.failures > 0) == (kind != "blocks")
    check_the_sink_works_again(rig, faulty, kind, snap)
    rig.session.close()


def check_the_sink_works_again(rig: Rig, faulty: str, kind: str, snap) -> None:
    """Movement 4 (after the fault) reached the faulty sink whole."""
    last = [p for p in rig.witness if p.movement == 4]
    assert last
    if faulty == "prediction outlets":
        rows = rig.transport.outlets["icub-probabilities"].pushed
        assert [int(r[0][0, 0]) for r in rows[-len(last):]] == [p.seq for p in last]
    elif faulty == "events outlet":
        texts = [r[0][0] for r in rig.transport.outlets["icub-events"].pushed]
        assert "movement 4 ended (ended)" in texts
    elif faulty == "prediction callback":
        assert rig.called[-len(last):] == last
    else:
        check_the_journals(rig, kind, snap)


def check_the_journals(rig: Rig, kind: str, snap) -> None:
    """Every movement's journal holds whole rows, the first of the movement's: all of them
    when the recorder only blocked (a lossless sink), and for movement 4."""
    recorded = {r.number: r for r in snap.recorded}
    assert 4 in recorded
    for movement in snap.ended:
        path = rig.recorder.journal_path(movement.number)
        if kind != "blocks" and movement.number in (2, 3) and not path.exists():
            continue  # born and ended while the disk was full: nothing acknowledged
        demo, header = read_journal(path)  # raises on a torn row
        n = demo.n_samples
        assert_allclose(demo.times + header["start"], movement.times[:n], rtol=0, atol=1e-12)
        assert_array_equal(demo.values, movement.values[:n])
        if kind == "blocks" or movement.number == 4:
            assert n == len(movement) and movement.number in recorded


class Runaway(BaseException):
    """Raised by the events outlet past any sane number of calls: ends a runaway loop (it
    escapes ``except Exception``) instead of filling the memory."""


def test_a_failing_events_outlet_does_not_hang_the_session() -> None:
    """The events outlet's failure used to be appended, as an event, to the list of events the
    step was publishing: the step published it, failed again, and never ended (10 000 calls
    here in the first step). Now a step hands its events to the outlet's own thread and says
    the failure once."""
    transport = FakeTransport()
    stream = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=RATE))
    outlets = PredictionOutlets(outlet_specs(hand_model(), "icub", None), transport.outlet)
    calls = []

    def broken(rows, stamp):
        calls.append(rows)
        if len(calls) > 10_000:
            raise Runaway
        raise OSError("the events outlet is down")

    transport.outlets["icub-events"].push = broken
    session = LiveSession(hand_model(), ["hand=Hand:0,1,2"], transport,
                          LiveOptions(start="call"), outlets=outlets)  # fmt: skip
    session.connect()

    def run() -> None:
        session.begin()
        for _ in range(10):
            transport.now += 0.05
            stream.push(transport.now - np.arange(5)[::-1] * 0.01,
                        np.random.default_rng(0).normal(size=(5, 3)) * 0.01)  # fmt: skip
            session.step()
        session.flush()

    within(run, "stepping with a failing events outlet")
    snap = session.snapshot()
    assert snap.predictions >= 5 and len(calls) < 100
    said = [e.text for e in snap.events if "events outlet" in e.text]
    assert said == ["sink 'events outlet' failed: OSError: the events outlet is down"]
    assert len(transport.outlets["icub-probabilities"].pushed) == snap.predictions
    session.close()


def test_two_outputs_folded_keep_everything_in_order_and_the_later_state() -> None:
    from promp.live.segmenter import Movement
    from promp.live.sinks import Output
    from promp.live.status import LiveEvent

    first = Output(1.0, (LiveEvent(1.0, "a"),), ("b1",), ("p1", "p2"),
                   Movement(1, "", np.zeros(2), np.zeros((2, 3))))  # fmt: skip
    later = Output(2.5, (LiveEvent(2.0, "b", "decision"),), ("b2",), ("p3",), None,
                   ("a2", "a3"))  # fmt: skip
    first = Output(first.time, first.events, first.boundaries, first.predictions,
                   first.movement, ("a1",))  # fmt: skip
    both = first.then(later)
    assert both.arrivals == ("a1", "a2", "a3")
    assert both.time == 2.5 and both.movement is None
    assert [e.time for e in both.events] == [1.0, 2.0] and both.events[1].kind == "decision"
    assert both.boundaries == ("b1", "b2") and both.predictions == ("p1", "p2", "p3")
    assert later.then(first).movement is first.movement


# The workers and what is said of them, each alone (no session): a sink the test gates.

class Gated:
    """A sink whose ``take`` waits until the test opens its gate (``taking`` is set while it
    waits), raises ``fail`` when set, and returns ``("kept", time)`` for each output."""

    def __init__(self, name: str = "gated", lossless: bool = False, view=lambda o: o):
        self.name, self.lossless, self._view = name, lossless, view
        self.gate, self.taking = threading.Event(), threading.Event()
        self.gate.set()
        self.fail: Exception | None = None
        self.taken: list = []
        self.closed = 0

    def view(self, output):
        return self._view(output)

    def take(self, output):
        self.taking.set()
        assert self.gate.wait(LIMIT_S), "the test never opened the gate"
        if self.fail is not None:
            raise self.fail
        self.taken.append(output)
        return [("kept", output.time)]

    def close(self) -> None:
        self.closed += 1


def waited(wait, worker) -> bool:
    """``wait(seconds)`` (a worker's ``flush``, a sink's ``taking.wait``) until it is True or
    ``LIMIT_S`` passed, failing as soon as the worker's thread has ended: a worker whose thread
    died (an error in it) fails the test at once instead of holding it ``LIMIT_S``."""
    for _ in range(int(LIMIT_S / 0.05)):
        if wait(0.05):
            return True
        assert worker._thread.is_alive(), f"the thread of sink {worker.sink.name!r} ended"
    return False


def blocked(sink: Gated, worker) -> None:
    """Close ``sink``'s gate and wait until its thread is inside ``take`` on output -1."""
    from promp.live.sinks import Output

    sink.gate.clear()
    sink.taking.clear()
    worker.offer(Output(-1.0))
    assert waited(sink.taking.wait, worker)


def test_a_lossy_worker_drops_its_oldest_outputs_and_counts_them() -> None:
    from promp.live.sinks import Output, SinkState, SinkWorker

    sink = Gated()
    worker = SinkWorker(sink, capacity=2)
    assert worker.capacity == 2 and worker.state() == SinkState("gated")
    assert worker._thread.daemon and worker._thread.name == "live-sink-gated"
    blocked(sink, worker)
    worker.offer(Output(1.0))
    s = worker.state()
    assert (s.queued, s.full, s.dropped) == (1, False, 0) and s.healthy
    worker.offer(Output(2.0))
    s = worker.state()
    assert (s.queued, s.full, s.dropped) == (2, True, 0) and not s.healthy
    worker.offer(Output(3.0))
    worker.offer(Output(4.0))
    s = worker.state()
    assert (s.queued, s.full, s.dropped) == (2, True, 2)
    assert not worker.flush(0.01)  # blocked: not delivered
    sink.gate.set()
    assert waited(worker.flush, worker)
    assert [o.time for o in sink.taken] == [-1.0, 3.0, 4.0]  # the latest two
    s = worker.state()
    assert (s.delivered, s.failures, s.queued, s.full, s.dropped) == (3, 0, 0, False, 2)
    assert worker.kept() == [("kept", -1.0), ("kept", 3.0), ("kept", 4.0)]
    assert worker.kept() == []
    assert worker.stop(LIMIT_S) and not worker._thread.is_alive()


def test_a_lossless_worker_folds_into_its_last_output_and_drops_only_ends_beyond_it() -> None:
    from promp.live.sinks import Output, SinkWorker

    sink = Gated(lossless=True)
    worker = SinkWorker(sink, capacity=2)
    blocked(sink, worker)
    worker.offer(Output(1.0, boundaries=("a",), predictions=("p1",)))
    worker.offer(Output(2.0, boundaries=("b",), predictions=("p2",)))
    worker.offer(Output(3.0, boundaries=("c",), predictions=("p3",)))
    s = worker.state()
    assert (s.queued, s.full, s.dropped) == (2, True, 0)
    worker.offer(Output(4.0, boundaries=("d", "e"), predictions=("p4",)))
    s = worker.state()  # b, c, d, e folded: two ends past a capacity of 2 dropped
    assert (s.queued, s.full, s.dropped) == (2, True, 2)
    sink.gate.set()
    assert waited(worker.flush, worker)
    assert [o.time for o in sink.taken] == [-1.0, 1.0, 4.0]
    assert sink.taken[2].boundaries == ("d", "e")
    assert sink.taken[2].predictions == ("p2", "p3", "p4")
    worker.stop(LIMIT_S)


def test_a_worker_counts_failures_keeps_the_last_error_and_works_again() -> None:
    from promp.live.sinks import Output, SinkWorker

    sink = Gated()
    worker = SinkWorker(sink)
    assert worker.capacity == promp.live.sinks.QUEUE_OUTPUTS
    sink.fail = OSError("down")
    worker.offer(Output(1.0))
    worker.offer(Output(2.0))
    assert waited(worker.flush, worker)
    s = worker.state()
    assert (s.delivered, s.failures, s.failing, s.error) == (0, 2, True, "OSError: down")
    assert not s.healthy and worker.kept() == []
    sink.fail = None
    worker.offer(Output(3.0))
    assert waited(worker.flush, worker)
    s = worker.state()
    assert (s.delivered, s.failures, s.failing, s.error) == (1, 2, False, "OSError: down")
    assert s.healthy and worker.kept() == [("kept", 3.0)]
    worker.stop(LIMIT_S)


def test_a_worker_queues_only_what_its_sink_reads_and_delivers_the_queue_when_stopped() -> None:
    from promp.live.sinks import Output, SinkWorker

    sink = Gated(view=lambda o: o if o.time > 0 else None)
    worker = SinkWorker(sink)
    sink.gate.clear()
    worker.offer(Output(-5.0))  # not read: never queued
    assert worker.state().queued == 0 and worker.flush(0.01)
    worker.offer(Output(1.0))
    assert waited(sink.taking.wait, worker)
    worker.offer(Output(2.0))
    assert not worker.stop(0.01)  # blocked: its thread goes on
    sink.gate.set()
    assert worker.stop(LIMIT_S)
    assert [o.time for o in sink.taken] == [1.0, 2.0]


def test_the_sinks_say_each_change_once_and_close_every_sink() -> None:
    from promp.live.sinks import Output, Sinks

    a, b, broken = Gated("a"), Gated("b"), Gated("c")

    def refuse() -> None:
        raise OSError("no")

    broken.close = refuse
    sinks = Sinks([a, b, broken], capacity=1)
    assert [w.capacity for w in sinks.workers] == [1, 1, 1]
    assert sinks.news(0.0) == []
    a.fail = RuntimeError("x")
    sinks.offer(Output(1.0))
    assert sinks.flush()
    assert [s.name for s in sinks.states()] == ["a", "b", "c"]
    assert sorted(sinks.kept()) == [("kept", 1.0), ("kept", 1.0)]
    news = sinks.news(7.0)
    assert len(news) == 1 and news[0].time == 7.0 and news[0].kind == ""
    assert "'a'" in news[0].text and "RuntimeError: x" in news[0].text
    assert sinks.news(8.0) == []  # said once
    a.fail = None
    blocked(b, sinks.workers[1])
    sinks.offer(Output(2.0))
    assert waited(sinks.workers[0].flush, sinks.workers[0])
    assert waited(sinks.workers[2].flush, sinks.workers[2])
    assert not sinks.flush(0.01)
    news = sinks.news(9.0)  # a works again, b fell behind
    assert [("'a'" in e.text, "'b'" in e.text) for e in news] == [(True, False), (False, True)]
    b.gate.set()
    assert sinks.flush()
    news = sinks.news(10.0, sinks.states())
    assert len(news) == 1 and "'b'" in news[0].text
    problems = sinks.close()
    assert len(problems) == 1 and "'c'" in problems[0] and "OSError: no" in problems[0]
    assert (a.closed, b.closed) == (1, 1)


def test_closing_says_a_sink_that_does_not_finish_and_closes_the_others() -> None:
    from promp.live.sinks import Sinks

    a, stuck = Gated("a"), Gated("stuck")
    sinks = Sinks([stuck, a])
    blocked(stuck, sinks.workers[0])
    problems = sinks.close(0.01)
    assert len(problems) == 1 and "'stuck'" in problems[0]
    assert (a.closed, stuck.closed) == (1, 1)
    stuck.gate.set()
    assert sinks.workers[0].stop(LIMIT_S)


def test_what_is_said_of_a_sink_follows_its_state() -> None:
    from promp.live.sinks import SinkState, _Said

    said = _Said()
    assert said.update(SinkState("s")) == []
    assert len(said.update(SinkState("s", failures=1, failing=True, error="E: 1"))) == 1
    assert said.update(SinkState("s", failures=2, failing=True, error="E: 1")) == []
    changed = said.update(SinkState("s", failures=3, failing=True, error="E: 2"))
    assert len(changed) == 1 and "E: 2" in changed[0]  # another error: said
    again = said.update(SinkState("s", delivered=1, failures=3, error="E: 2"))
    assert len(again) == 1 and "3" in again[0]
    assert said.update(SinkState("s", delivered=2, failures=3, error="E: 2")) == []
    both = said.update(SinkState("s", failures=4, failing=True, error="E: 2"))
    assert len(both) == 1 and said.failing  # the same error, failing again after working
    assert len(said.update(SinkState("s", failures=4, error="E: 2"))) == 1
    behind = said.update(SinkState("s", failures=4, error="E: 2", dropped=5))
    assert len(behind) == 1 and "5" in behind[0] and said.behind
    assert said.update(SinkState("s", failures=4, error="E: 2", dropped=5, full=True)) == []
    assert said.update(SinkState("s", failures=4, error="E: 2", dropped=6)) == []
    up = said.update(SinkState("s", failures=4, error="E: 2", dropped=6))
    assert len(up) == 1 and "6" in up[0] and not said.behind
    assert len(said.update(SinkState("s", failures=4, error="E: 2", dropped=6,
                                     full=True))) == 1  # fmt: skip


def test_a_callback_sink_reads_only_predictions_and_hands_each_on() -> None:
    from promp.live.sinks import Output

    got = []
    sink = CallbackSink(got.append)
    assert sink.name == "prediction callback" and not sink.lossless
    assert sink.view(Output(1.0, boundaries=("b",))) is None
    part = sink.view(Output(2.0, boundaries=("b",), predictions=("p", "q")))
    assert (part.time, part.boundaries, part.predictions) == (2.0, (), ("p", "q"))
    assert sink.take(part) == () and got == ["p", "q"]
    sink.close()


def test_a_worker_whose_queue_stayed_full_while_it_delivered_is_still_full() -> None:
    from promp.live.sinks import Output, SinkWorker

    sink = Gated()
    worker = SinkWorker(sink, capacity=2)
    blocked(sink, worker)
    worker.offer(Output(1.0))
    worker.offer(Output(2.0))  # full while -1 is delivered
    second = threading.Event()
    taken = sink.take

    def take(output):  # -1 delivered: hold on the next output until the test looked
        if output.time == 1.0:
            sink.taking.set()
            assert second.wait(LIMIT_S), "the test never let the second output go"
        return taken(output)

    sink.take = take
    sink.taking.clear()
    sink.gate.set()
    assert waited(sink.taking.wait, worker)  # -1 delivered, 1.0 taken: 2.0 still queued
    s = worker.state()
    assert (s.delivered, s.queued, s.full) == (1, 2, True)
    second.set()
    assert waited(worker.flush, worker)
    s = worker.state()
    assert (s.delivered, s.queued, s.full) == (3, 0, False)
    worker.stop(LIMIT_S)


def test_the_sinks_news_read_the_states_given() -> None:
    from promp.live.sinks import Sinks, SinkState

    sinks = Sinks([Gated("a")])
    failing = SinkState("a", failures=1, failing=True, error="OSError: full")
    news = sinks.news(3.0, [failing])  # the worker itself is healthy
    assert len(news) == 1 and news[0].time == 3.0
    assert sinks.news(4.0, [failing]) == []
    assert sinks.close() == []


class Prompt(Gated):
    """A gated sink that is waited for after each step (``prompt``)."""

    prompt = True


def test_settle_waits_for_a_prompt_sink_and_not_again_for_one_that_was_late() -> None:
    import time

    from promp.live.sinks import Output, Sinks

    prompt, other = Prompt("prompt"), Gated("other")
    sinks = Sinks([prompt, other])
    worker, slow = sinks.workers
    assert worker.prompt and not slow.prompt
    blocked(other, slow)  # a sink that is not prompt is never waited for
    prompt.gate.clear()
    sinks.offer(Output(1.0))
    assert waited(prompt.taking.wait, worker)
    opener = threading.Timer(0.05, prompt.gate.set)  # opened while settle waits
    opener.start()
    assert sinks.settle(LIMIT_S)  # returns once delivered, though the other still holds
    assert [o.time for o in prompt.taken] == [1.0] and worker.state().delivered == 1
    assert not slow.flush(0.0)
    # late: a settle that times out is not waited for again while the sink has a queue
    prompt.gate.clear()
    prompt.taking.clear()
    sinks.offer(Output(2.0))
    assert waited(prompt.taking.wait, worker)
    assert not sinks.settle(0.0)
    sinks.offer(Output(3.0))
    result: list[bool] = []
    waiter = threading.Thread(target=lambda: result.append(worker.settle(time.monotonic()
                                                                         + 3600.0)))
    waiter.start()
    waiter.join(LIMIT_S)
    assert not waiter.is_alive() and result == [False]  # it did not wait the hour
    prompt.gate.set()
    assert waited(worker.flush, worker)
    assert worker.settle(time.monotonic()) and not worker._late  # caught up: waited again
    other.gate.set()
    assert waited(slow.flush, slow)
    assert sinks.close() == []


def test_the_prediction_outlets_are_a_prompt_sink() -> None:
    from promp.live.outlets import EventSink, PredictionSink

    assert PredictionSink.prompt and not getattr(EventSink, "prompt", False)
