"""The live session's runner (promp.live.session.LiveSession), stepped by hand on the fake
transport: what a step reports (worked or not), what it hands its sinks, when it publishes a
new snapshot, the Record calls' times, the inlets it keeps and closes, what close says."""

from __future__ import annotations

import numpy as np

from promp.live.options import LiveOptions
from promp.live.session import LiveSession
from tests.live_fakes import FakeStream, FakeTransport, Tap, synthetic_model

INPUTS = ["hand=Hand:0,1,2"]


def moving(t0: float, n: int, rate: float = 100.0):
    t = t0 + np.arange(1, n + 1) / rate
    return t, np.column_stack([np.sin(t), np.cos(t), t]) * 0.1


def connected(**kwargs):
    transport = FakeTransport(now=10.0)
    stream = transport.add(FakeStream("Hand", ("x", "y", "z")))
    tap = Tap()
    predictions = []
    session = LiveSession(synthetic_model(), INPUTS, transport, LiveOptions(start="call"),
                          on_prediction=predictions.append, sinks=[tap], **kwargs)  # fmt: skip
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


def test_a_stream_found_but_not_opened_changes_the_snapshot_s_list():
    transport, stream, session, tap, _ = connected()
    before = session.snapshot()
    assert len(before.found) == 1
    transport.add(FakeStream("Other", ("a",)))
    session.connect(0.0)
    session.step()
    assert len(session.snapshot().found) == 2 and session.snapshot() is not before


def test_close_closes_the_inlets_and_the_sinks_and_publishes_last():
    transport, stream, session, tap, _ = connected()
    [inlet] = session._intake._inlets.values()
    before = session.snapshot()
    transport.now += 1.0
    session.close()
    assert inlet.closed
    assert session.snapshot().version > before.version
    assert session.snapshot().time == transport.now
