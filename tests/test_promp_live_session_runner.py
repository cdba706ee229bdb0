"""The live session's runner (promp.live.session.LiveSession), stepped by hand on the fake
transport: what a step reports (worked or not), what it hands its sinks, when it publishes a
new snapshot, the Record calls (their times, as the sinks get them), the inlets it keeps and
closes, what flush and close say of a failing sink, and when."""

from __future__ import annotations

import threading

import numpy as np

from promp.live.options import LiveOptions
from promp.live.session import FIND_WAIT_S, LiveSession
from tests.conftest import PATIENCE_S, wait_until
from tests.live_fakes import FakeStream, FakeTransport, Tap, synthetic_model

INPUTS = ["hand=Hand:0,1,2"]


def moving(t0: float, n: int, rate: float = 100.0):
    t = t0 + np.arange(1, n + 1) / rate
    return t, np.column_stack([np.sin(t), np.cos(t), t]) * 0.1


def connected(sinks=(), **kwargs):
    transport = FakeTransport(now=10.0)
    stream = transport.add(FakeStream("Hand", ("x", "y", "z")))
    tap = Tap()
    predictions = []
    session = LiveSession(synthetic_model(), INPUTS, transport, LiveOptions(start="call"),
                          on_prediction=predictions.append, sinks=[tap, *sinks],
                          **kwargs)  # fmt: skip
    session.connect(0.0)
    assert session.step()  # the stream opened
    session.flush()
    return transport, stream, session, tap, predictions


def test_a_step_works_only_when_something_arrived_or_happened():
    transport, stream, session, tap, _ = connected()
    offered = len(tap.outputs)
    first = session.snapshot()
    transport.now += 0.01
    assert session.step() is False
    assert session.snapshot() is first  # nothing changed: no new snapshot
    session.flush()
    assert len(tap.outputs) == offered  # nothing offered
    stream.push(*moving(10.0, 5))
    transport.now += 0.05
    assert session.step() is True
    session.flush()
    assert len(tap.outputs) == offered + 1
    assert session.snapshot().version > first.version
    assert session.snapshot().counts["Hand"][0] == 5


def test_a_step_that_only_took_a_record_call_worked():
    transport, stream, session, tap, _ = connected()
    session.end()  # no movement going on: nothing happens, but a call arrived
    transport.now += 0.01
    assert session.step() is True
    session.flush()
    assert calls(tap) == [("end", 10.0, "")]


def test_the_session_starts_at_the_time_given_or_at_the_clock():
    transport = FakeTransport(now=10.0)
    given = LiveSession(synthetic_model(), INPUTS, transport, now=3.0)
    assert dict(given.state.newest) == {"hand": 3.0}  # (no sample yet: since the start)
    assert dict(LiveSession(synthetic_model(), INPUTS, transport).state.newest) == {"hand": 10.0}


def test_connect_looks_as_long_as_it_is_told():
    transport, stream, session, tap, _ = connected()
    waits = []
    transport.find = lambda wait: waits.append(wait) or FakeTransport.find(transport, wait)
    session.connect(0.25)
    session.connect()
    assert waits == [0.25, FIND_WAIT_S]


def test_a_started_session_finds_its_stream_and_steps_on_its_own_threads():
    transport = FakeTransport(now=10.0)
    stream = transport.add(FakeStream("Hand", ("x", "y", "z")))
    session = LiveSession(synthetic_model(), INPUTS, transport, LiveOptions(start="call"))
    stream.push(*moving(10.0, 5))
    session.start()
    try:
        wait_until(lambda: session.snapshot().counts["Hand"][0] == 5, timeout=10.0,
                   what="the samples read by the session's threads")  # fmt: skip
    finally:
        session.close()


def test_record_calls_start_and_end_at_the_clock_or_at_the_time_given():
    transport, stream, session, tap, predictions = connected()
    session.begin("left")  # now: 10.0
    stream.push(*moving(10.0, 30))
    transport.now = 10.3
    assert session.step()
    session.end(time=10.2)
    stream.push(*moving(10.3, 10))
    transport.now = 10.4
    session.step()
    session.flush()
    bounds = [b for o in tap.outputs for b in o.boundaries]
    assert [(b.kind, b.time) for b in bounds] == [("start", 10.0), ("end", 10.2)]
    assert bounds[1].movement.label == "left"
    assert predictions and predictions[-1].last <= 10.2 + 1e-9
    snap = session.snapshot()
    assert snap.predictions == len(predictions) and snap.prediction is predictions[-1]
    assert len(session.compute_s) == len(predictions)
    assert all(s >= 0 for s in session.compute_s)
    session.begin(time=11.0)
    session.end()  # at the clock, 10.4: before the start, which comes later
    stream.push(*moving(10.4, 100))
    transport.now = 11.5
    session.step()
    session.flush()
    bounds = [b for o in tap.outputs for b in o.boundaries]
    assert [(b.kind, b.time) for b in bounds][2:] == [("start", 11.0)]


def test_a_lost_stream_s_inlet_is_closed_and_a_new_stream_is_read():
    transport, stream, session, tap, _ = connected()
    [inlet] = session._intake._inlets.values()
    stream.gone = True
    transport.now += 0.1
    assert session.step()
    assert inlet.closed and session._intake._inlets == {}
    again = transport.add(FakeStream("Hand", ("x", "y", "z")))
    session.connect(0.0)
    assert session.step()
    [inlet] = session._intake._inlets.values()
    assert inlet.description.uid == again.description.uid and not inlet.closed
    again.push(*moving(transport.now, 3))
    transport.now += 0.05
    session.step()
    assert session.snapshot().counts["Hand"][0] == 3


def test_a_step_publishes_what_the_sinks_delivered_since_even_when_idle():
    reading = []
    holds = Holds(lambda o: bool(reading))
    transport, stream, session, tap, _ = connected(sinks=[holds])
    reading.append(True)
    stream.push(*moving(10.0, 5))
    transport.now += 0.05
    assert session.step()
    before = session.snapshot()
    holds.go.set()
    assert session._sinks.flush(PATIENCE_S)  # delivered: the snapshot does not show it yet
    transport.now += 0.01
    assert session.step() is False  # nothing arrived, nothing happened
    after = session.snapshot()
    assert after.version > before.version and after.sinks == session._sinks.states()
    assert after.sinks[2].delivered == before.sinks[2].delivered + 1


def test_a_stream_found_but_not_opened_changes_the_snapshot_s_list():
    transport, stream, session, tap, _ = connected()
    before = session.snapshot()
    assert len(before.found) == 1
    transport.add(FakeStream("Other", ("a",)))
    session.connect(0.0)
    session.step()
    assert len(session.snapshot().found) == 2 and session.snapshot() is not before


def test_a_stream_replaced_by_another_in_one_look_changes_the_snapshot_s_list():
    """One stream gone and another come between two looks (a device restarted under a new
    id, a marker stream started as another stopped): the same count, another list."""
    transport, stream, session, tap, _ = connected()
    other = transport.add(FakeStream("Other", ("a",)))
    session.connect(0.0)
    session.step()
    other.gone = True
    transport.add(FakeStream("Third", ("b",)))
    session.connect(0.0)
    session.step()
    names = [s.name for s in session.snapshot().found]
    assert "Third" in names and "Other" not in names


def test_close_closes_the_inlets_and_the_sinks_and_publishes_last():
    transport, stream, session, tap, _ = connected()
    [inlet] = session._intake._inlets.values()
    before = session.snapshot()
    transport.now += 1.0
    session.close()
    assert inlet.closed
    assert session.snapshot().version > before.version
    assert session.snapshot().time == transport.now


class Broken:
    """A sink that fails: each delivery once armed (after ``go`` is set), and its close."""

    name, lossless = "broken", False

    def __init__(self) -> None:
        self.armed, self.go = False, threading.Event()

    def view(self, output):
        return output if self.armed else None

    def take(self, output):
        self.go.wait()
        raise RuntimeError("disk full")

    def close(self) -> None:
        raise OSError("gone")


class Holds:
    """A sink that holds each output it reads (``reads(output)``) until ``go`` is set."""

    name, lossless = "holds", True

    def __init__(self, reads) -> None:
        self.reads, self.go = reads, threading.Event()

    def view(self, output):
        return output if self.reads(output) else None

    def take(self, output):
        self.go.wait()
        return ()

    def close(self) -> None:
        self.go.set()


def calls(tap):
    return [(c.kind, c.time, c.label) for o in tap.outputs for a in o.arrivals for c in a.calls]


def test_the_sinks_get_the_record_calls_as_made():
    transport, stream, session, tap, _ = connected()
    session.begin()  # no label: the movement has none
    stream.push(*moving(10.0, 30))
    transport.now = 10.3
    session.step()
    session.end(time=10.25)
    transport.now = 10.4
    session.step()
    session.flush()
    assert calls(tap) == [("start", 10.0, ""), ("end", 10.25, "")]
    assert [o.time for o in tap.outputs if o.arrivals][-2:] == [10.3, 10.4]  # the steps' clock
    [start, end] = [b for o in tap.outputs for b in o.boundaries]
    assert (end.kind, end.time, end.movement.label) == ("end", 10.25, "")


def failing(*sinks):
    """A connected session whose last step's output a :class:`Broken` sink will fail on, once
    let go (nothing said of it yet); the events said so far."""
    broken = Broken()
    transport, stream, session, tap, _ = connected(sinks=[broken, *sinks])
    broken.armed = True
    stream.push(*moving(transport.now, 5))
    transport.now += 0.05
    session.step()
    assert session.snapshot().sinks[2].failures == 0
    return transport, session, tap, broken, session.snapshot().n_events


def test_flush_says_a_sink_s_failure_at_its_own_time():
    transport, session, tap, broken, n = failing()
    transport.now += 1.0
    broken.go.set()
    assert session.flush()
    snap = session.snapshot()
    assert snap.sinks[2].failures == 1 and snap.sinks[2].failing
    assert snap.n_events == n + 1 and snap.events[-1].time == transport.now
    said = [o for o in tap.outputs if not o.arrivals]
    assert [(o.time, o.events) for o in said] == [(transport.now, (snap.events[-1],))]


def test_a_step_says_a_sink_s_failure_at_its_own_time():
    transport, session, tap, broken, n = failing()
    broken.go.set()
    assert session._sinks.flush(PATIENCE_S)  # delivered (failed), not said yet
    transport.now += 0.01  # (too soon for the stream to be late)
    assert session.step() is True  # what changed of the sinks
    snap = session.snapshot()
    assert snap.n_events == n + 1 and snap.events[-1].time == transport.now


def test_flush_is_false_while_a_sink_has_not_delivered_what_it_said():
    holds = Holds(lambda o: o.events and not o.arrivals)  # the sinks' news
    transport, session, tap, broken, _ = failing(holds)
    broken.go.set()
    assert session.flush(timeout=1.0) is False  # the failure's news is held
    holds.go.set()
    assert session.flush()


def test_close_says_what_failed_at_the_close_s_time():
    transport, session, tap, broken, n = failing()
    transport.now += 1.0
    broken.go.set()  # its last delivery fails while closing, then its close
    session.close()
    snap = session.snapshot()
    assert snap.sinks[2].failures == 1
    assert snap.n_events == n + 2  # the close's failure and the delivery's
    assert [e.time for e in snap.events[-2:]] == [transport.now] * 2
