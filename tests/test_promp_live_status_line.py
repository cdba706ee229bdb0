"""The headless command's status line: the movement under way, its latest prediction (the
most likely primitive, the phase and the time left with their intervals), the prediction
rate, and each stream or sink that is not healthy; read back here as numbers."""

from __future__ import annotations

import re
from dataclasses import replace

import pytest

from promp.live.session import LiveOptions, LiveSession
from promp.live.sinks import SinkState
from promp.live.status import Condition, StreamStatus
from promp.live.status_line import status_line
from tests.live_fakes import FakeStream, FakeTransport, replay, synthetic_model
from tests.synthetic import make_dataset

NUMBER = r"(-?\d+(?:\.\d+)?)"


@pytest.fixture(scope="module")
def snap():
    """A session's snapshot in the middle of an unseen 'right' movement (started by a call)."""
    transport = FakeTransport()
    stream = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    session = LiveSession(synthetic_model(), ["hand=Hand:0,1,2"], transport,
                          LiveOptions(start="call"))  # fmt: skip
    session.connect()
    session.step()
    demo = make_dataset(seed=11, n_demos=1)["right"][0]
    half = demo.times.size // 2
    session.begin()
    replay(session, transport, stream, demo.times[:half] - demo.times[0],
           demo.select(["x", "y", "z"])[:half])  # fmt: skip
    return session.snapshot()


def test_the_line_gives_the_movement_and_its_latest_prediction(snap) -> None:
    m, p = snap.movement, snap.prediction
    assert m is not None and p is not None and p.movement == m.number
    line = status_line(snap, 57.6)
    found = re.search(rf"movement (\d+) \({NUMBER} s, (\d+) rows\): (\w+) {NUMBER} · phase "
                      rf"{NUMBER} \[{NUMBER}-{NUMBER}\] · ends in {NUMBER} s \[{NUMBER}-{NUMBER}\]"
                      rf" · (\d+) predictions/s", line)  # fmt: skip
    assert found, line
    number, span, rows, primitive, top, phase, lo, hi, left, left_lo, left_hi, rate = \
        found.groups()  # fmt: skip
    assert int(number) == m.number and int(rows) == len(m)
    assert float(span) == pytest.approx(m.times[-1] - m.times[0], abs=0.005)
    assert primitive == p.primitive == "right"
    assert float(top) == pytest.approx(p.probabilities[p.inference.index], abs=0.005)
    for text, value in ((phase, p.phase.value), (lo, p.phase.low), (hi, p.phase.high),
                        (left, p.remaining.value), (left_lo, p.remaining.low),
                        (left_hi, p.remaining.high)):  # fmt: skip
        assert float(text) == pytest.approx(value, abs=0.005)
    assert int(rate) == 58
    assert line.endswith("streams ok")


def test_the_line_names_each_unhealthy_stream_and_sink_and_no_healthy_one(snap) -> None:
    stalled = StreamStatus("Hand", Condition.STALLED, snap.time - 1.5, "no sample")
    statuses = (stalled, StreamStatus("Head", Condition.OK, snap.time - 3.0))
    sinks = (SinkState("disk", failing=True, error="disk full"), SinkState("slow", full=True),
             SinkState("fine", delivered=3))  # fmt: skip
    line = status_line(replace(snap, statuses=statuses, sinks=sinks), 10.0)
    assert stalled.message(snap.time) in line
    assert "'Head'" not in line and "'fine'" not in line and "streams ok" not in line
    disk, slow = line.index("'disk'"), line.index("'slow'")
    assert "disk full" in line[disk:slow] and "failing" in line[disk:slow]
    assert "failing" not in line[slow:]


def test_without_a_movement_the_line_says_it_waits(snap) -> None:
    line = status_line(replace(snap, movement=None), 0.0)
    assert "movement" in line and "rows" not in line and "phase" not in line
    assert line.startswith("waiting")
    empty = replace(snap.movement, times=snap.movement.times[:0], values=snap.movement.values[:0])
    line = status_line(replace(snap, movement=empty), 0.0)
    found = re.search(rf"\({NUMBER} s, (\d+) rows\)", line)
    assert found and float(found.group(1)) == 0.0 and int(found.group(2)) == 0  # begun, no row yet
    later = replace(snap, movement=replace(snap.movement, number=snap.movement.number + 1))
    assert "phase" not in status_line(later, 0.0)  # the prediction was of another movement


def test_a_stream_s_line_gives_how_long_its_condition_lasts_and_its_detail() -> None:
    status = StreamStatus("Hand", Condition.STALLED, 100.0, "no sample")
    seconds = re.search(rf"for {NUMBER} s", status.message(101.46))
    assert seconds and float(seconds.group(1)) == 1.5
    assert "(no sample)" in status.message(101.46)
    assert float(re.search(rf"for {NUMBER} s", status.message(99.0)).group(1)) == 0.0
    bare = StreamStatus("Hand", Condition.VANISHED, 100.0).message(100.25)
    assert "(" not in bare and float(re.search(rf"for {NUMBER} s", bare).group(1)) == 0.2
