"""Faults of live streams: NaNs, the wrong channels, a clock that jumps, a stall, a stream that
vanishes, comes back or restarts, a rate change, an ambiguous stream. Each is a clear status
(which stream, what, since when) and an event; the session never stops, a movement is never
observed across a break, and what is recorded stays a valid demonstration. (A sink's faults:
tests/test_promp_live_sinks.py; faults in sequences nobody listed:
tests/test_promp_live_session_machine.py.)"""

from __future__ import annotations

import numpy as np
import pytest

from promp.live.outlets import PredictionOutlets, outlet_specs
from promp.live.recorder import Recorder, recover
from promp.live.session import LiveOptions, LiveSession
from promp.live.status import Condition
from tests.live_fakes import FakeStream, FakeTransport, hand_model

RATE = 100.0


class Rig:
    """A session observing a 100 Hz hand stream (a slow circle, in metres), in call mode,
    recording every movement."""

    def __init__(self, folder, labels=("x", "y", "z"), start="call", **stream):
        self.transport = FakeTransport()
        self.stream = self.transport.add(FakeStream("Hand", labels, rate=RATE, **stream))
        self.recorder = Recorder(folder, ("x", "y", "z"))
        self.session = LiveSession(hand_model(), ["hand=Hand:0,1,2"], self.transport,
                                   LiveOptions(start=start), recorder=self.recorder)  # fmt: skip
        self.session.connect()
        self.session.step()
        self.stamp = self.transport.now  # the sender's clock

    def status(self):
        return self.session.snapshot().statuses[0]

    def texts(self):
        return [e.text for e in self.session.snapshot().events]

    def push(self, n, jump=0.0, values=None, step=1 / RATE, stream=None):
        """``n`` samples in real time (the sender's stamps ``jump`` s off from here on)."""
        self.stamp += jump
        for k in range(n):
            self.transport.now += 1 / RATE
            self.stamp += step
            t = self.stamp
            row = np.array([[0.1 * np.cos(t), 0.1 * np.sin(t), 0.0]]) if values is None \
                else values[k:k + 1]  # fmt: skip
            (stream or self.stream).push([t], row)
            if k % 3 == 2 or k == n - 1:
                self.session.step()
        self.session.flush()  # the recorder has journalled what it was given

    def wait(self, seconds):
        for _ in range(int(seconds * 60)):
            self.transport.now += 1 / 60
            self.session.step()


def test_nan_samples_are_left_out_and_said(tmp_path) -> None:
    rig = Rig(tmp_path)
    rig.session.begin()
    rig.push(50)
    bad = np.zeros((20, 3))
    bad[5:10, 1] = np.nan
    rig.push(20, values=bad)
    status = rig.status()
    assert status.condition is Condition.BAD_VALUES and "5 sample(s)" in status.detail
    assert status.healthy  # the other samples flow
    rig.push(120)  # clean for over a second
    assert rig.status().condition is Condition.OK
    movement = rig.session.snapshot().movement
    assert np.all(np.isfinite(movement.values)) and len(movement) >= 180
    assert rig.session.snapshot().counts["Hand"] == (190, 5)


def test_a_stream_sending_only_nans_is_bad_values_not_stalled(tmp_path) -> None:
    """Samples that all arrive bad for a second: one status and one event, never a stall in
    between (the stream is heard, its values are left out)."""
    rig = Rig(tmp_path)
    rig.push(50)
    events = rig.session.snapshot().n_events
    rig.push(100, values=np.full((100, 3), np.nan))
    assert rig.status().condition is Condition.BAD_VALUES and "100 sample(s)" in rig.status().detail
    assert rig.session.snapshot().n_events == events + 1
    rig.wait(1.0)  # nothing at all for a second: that is a stall
    assert rig.status().condition is Condition.STALLED


def test_a_stream_without_the_mappings_channels_is_not_used(tmp_path) -> None:
    rig = Rig(tmp_path, labels=("x", "y"))
    status = rig.status()
    assert status.condition is Condition.WRONG_CHANNELS and not status.healthy
    assert "no field(s) ['2']" in status.detail
    rig.stream.gone = True
    rig.transport.add(FakeStream("Hand", ("x", "y", "z"), rate=RATE))
    rig.session.connect()
    rig.session.step()
    assert rig.status().condition in (Condition.OK, Condition.RESTARTED)


def test_samples_delivered_late_are_not_a_clock_jump(tmp_path) -> None:
    """On a busy machine the sender may fall behind and push its backlog at once, the
    session polling in the middle of it: a batch 0.4 s stale, then one on time, is no clock
    jump (the stamps never came sooner than they could)."""
    rig = Rig(tmp_path)
    rig.session.begin()
    rig.push(50)
    rig.transport.now += 0.8  # the sender stalled 0.8 s, then pushes what it owes
    backlog = rig.stamp + np.arange(1, 81) / RATE
    for k, t in enumerate(backlog):
        rig.stream.push([t], np.array([[0.1 * np.cos(t), 0.1 * np.sin(t), 0.0]]))
        if k == 39:
            rig.session.step()  # half of it: its newest sample 0.4 s old
    rig.stamp = float(backlog[-1])
    rig.session.step()  # the rest: on time again
    rig.push(30)
    assert rig.status().condition is Condition.OK, rig.texts()
    movement = rig.session.snapshot().movement
    assert movement is not None and len(movement) == 160  # one movement, nothing left out


def push_late(rig, stream, seconds, pauses, rng):
    """``seconds`` of 100 Hz samples from ``stream``, each stamped when it is pushed (the
    default stamp): during each pause ``(from, length)`` (s from now) the sender sleeps, then
    pushes what it owes at once; the session steps every 2-5 ms."""
    t0 = rig.transport.now
    true = t0 + np.arange(1, int(seconds * RATE) + 1) / RATE
    due = true.copy()
    for start, length in pauses:
        late = (true >= t0 + start) & (true < t0 + start + length)
        due[late] = t0 + start + length
    i = 0
    while i < true.size:
        rig.transport.now += rng.uniform(0.002, 0.005)
        while i < true.size and due[i] <= rig.transport.now:
            stamp = rig.transport.now + 1e-6 * i  # pushed one after the other
            stream.push([stamp], np.array([[0.1 * np.cos(true[i]), 0.1 * np.sin(true[i]), 0.0]]))
            i += 1
        rig.session.step()
    rig.stamp = rig.transport.now
    return true


def test_a_late_sender_neither_breaks_the_movement_nor_changes_the_rate(tmp_path) -> None:
    """A busy machine: the sender sleeps 0.1-0.35 s now and then and pushes its backlog at
    once, stamped at the push. No gap, no rate change, one movement whose samples are back
    at their times; a restart of the outlet is one event, then the same."""
    rng = np.random.default_rng(5)
    rig = Rig(tmp_path)
    rig.session.begin()
    before = rig.session.snapshot().n_events
    pauses = [(0.3, 0.12), (0.9, 0.32), (1.6, 0.2), (2.2, 0.35), (2.9, 0.1), (3.5, 0.25)]
    true = push_late(rig, rig.stream, 4.0, pauses, rng)
    movement = rig.session.snapshot().movement
    assert rig.session.snapshot().n_events == before + 1, rig.texts()  # "movement 1 started"
    assert movement is not None
    assert len(movement) == true.size
    assert np.abs(movement.times - true).max() < 0.006  # a poll: when a sample is pushed
    count = rig.session.snapshot().n_events
    rig.stream.gone = True
    rig.session.step()
    restarted = rig.transport.add(FakeStream("Hand", ("x", "y", "z"), rate=RATE))
    rig.session.connect()
    rig.session.step()
    rig.session.begin()
    push_late(rig, restarted, 4.0, [(0.0, 0.3), *pauses], rng)  # its backlog first
    texts = [e.text for e in rig.session.snapshot().events][count:]
    assert [t.split(": ")[1].split(" (")[0] for t in texts if "stream" in t] == \
        ["vanished", "restarted"], texts  # fmt: skip
    assert len(rig.session.snapshot().movement) == 400


@pytest.mark.parametrize("jump", [5.0, -3.0, 0.6])
def test_a_clock_jump_is_re_anchored_and_ends_the_movement(tmp_path, jump) -> None:
    rig = Rig(tmp_path)
    rig.session.begin()
    rig.push(60)
    rig.push(60, jump=jump)
    status = rig.status()
    assert status.condition is Condition.CLOCK_JUMP and f"{jump:+.3f} s" in status.detail
    snap = rig.session.snapshot()
    (ended,) = snap.ended
    assert "broke off" in ended.ended and len(ended) >= 55
    assert np.all(np.diff(ended.times) > 0)
    rig.session.begin()
    rig.push(30)
    movement = rig.session.snapshot().movement
    assert np.all(np.diff(movement.times) > 0) and len(movement) >= 25
    assert abs(movement.times[-1] - rig.transport.now) < 0.1  # back on the session's clock


def test_a_stall_is_said_and_a_gap_ends_the_movement(tmp_path) -> None:
    rig = Rig(tmp_path)
    rig.session.begin()
    rig.push(50)
    last = rig.transport.now
    rig.wait(1.0)
    status = rig.status()
    assert status.condition is Condition.STALLED and not status.healthy
    assert status.since == pytest.approx(last, abs=0.02)
    assert "stalled for 1.0 s" in status.message(rig.transport.now)
    rig.stamp += 1.0  # the sender was silent: its stamps resume 1 s later
    rig.push(40)
    assert rig.status().condition is Condition.OK
    assert any("paused" in t for t in rig.texts())
    assert rig.session.snapshot().ended[0].ended.startswith("input 'hand' paused")


def test_a_vanished_stream_comes_back_or_restarts(tmp_path) -> None:
    rig = Rig(tmp_path, start="still")
    rig.session.begin()
    rig.push(40)
    rig.stream.gone = True
    rig.session.step()
    assert rig.status().condition is Condition.VANISHED
    assert rig.session.snapshot().ended[-1].ended == "input 'hand' broke off"
    rig.stream.gone = False
    rig.session.connect()
    rig.session.step()
    assert rig.status().condition is Condition.BACK
    rig.stream.gone = True
    rig.session.step()
    restarted = rig.transport.add(FakeStream("Hand", ("x", "y", "z"), rate=RATE))
    rig.session.connect()
    rig.session.step()
    assert rig.status().condition is Condition.RESTARTED
    count = rig.session.snapshot().predictions
    rig.session.begin()
    rig.push(40, stream=restarted)
    assert rig.session.snapshot().predictions > count  # observing again, a new movement
    assert rig.session.snapshot().movement.number == 2


def test_a_vanished_stream_the_network_still_lists_stays_vanished(tmp_path, monkeypatch) -> None:
    """LSL lists an outlet for seconds after it is gone: opening it fails, and the status
    says vanished (what happened), not waiting (as if it had never been found)."""
    rig = Rig(tmp_path)
    rig.push(40)
    listed = rig.transport.find(0.0)
    rig.stream.gone = True
    rig.session.step()
    assert rig.status().condition is Condition.VANISHED
    monkeypatch.setattr(rig.transport, "find", lambda wait: listed)
    rig.session.connect()
    rig.session.step()
    assert rig.status().condition is Condition.VANISHED
    assert "looking for it again" in rig.status().detail


def test_a_rate_change_is_said(tmp_path) -> None:
    rig = Rig(tmp_path)
    rig.push(250)
    assert rig.status().condition is Condition.OK
    rig.push(150, step=2 / RATE)
    status = rig.status()
    assert status.condition is Condition.RATE_CHANGED
    assert status.detail == "from 100 Hz to 50 Hz" and status.healthy


def test_a_rate_that_wavers_is_said_at_most_once_a_half_window(tmp_path) -> None:
    """Steps of 6 or 14 ms at random (10 ms on average): the median step of the window flips
    from one to the other as the window slides. Each change said restarts the window, so the
    status changes at most once per half window, not at every poll."""
    from promp.live.source import RATE_WINDOW_S

    rig = Rig(tmp_path)
    rng = np.random.default_rng(3)
    steps = rng.choice([0.006, 0.014], size=600)
    for k in range(0, 600, 3):
        stamps = rig.stamp + np.cumsum(steps[k:k + 3])
        rig.stamp = float(stamps[-1])
        rig.transport.now = rig.stamp
        rig.stream.push(stamps, np.zeros((3, 3)))
        rig.session.step()
    said = [t for t in rig.texts() if "rate changed" in t]
    assert 1 <= len(said) <= steps.sum() / (0.5 * RATE_WINDOW_S)


def test_what_is_recorded_across_faults_stays_a_valid_demonstration(tmp_path) -> None:
    rig = Rig(tmp_path)
    rig.session.begin()
    rig.push(40)
    rig.push(30, jump=2.0)  # ends the first; journal finished
    rig.session.begin()
    bad = np.full((5, 3), np.nan)  # a dropout shorter than a gap (promp.live.timebase)
    rig.push(30)
    rig.push(5, values=bad)
    rig.push(20)
    assert rig.recorder.acknowledged >= 45
    rig.session.close()  # stopped here: the journals keep both (neither was saved elsewhere)
    (first, ended), (second, going) = recover(tmp_path)
    assert first.name.startswith("live-001") and second.name.startswith("live-002")
    assert going.n_samples >= 45
    (movement,) = rig.session.snapshot().ended
    np.testing.assert_array_equal(ended.values, movement.values)
    (recorded,) = rig.session.snapshot().recorded  # the take the studio would save
    assert recorded.journal == first and recorded.number == 1
    np.testing.assert_array_equal(recorded.demo.values, movement.values)
    for demo in (ended, going):
        assert np.all(np.isfinite(demo.values)) and np.all(np.diff(demo.times) > 0)


def test_several_matching_streams_wait_for_a_choice_and_units_come_from_the_stream(
    tmp_path,
) -> None:
    transport = FakeTransport()
    for source in ("a", "b"):
        transport.add(FakeStream("Hand", ("x", "y", "z"), ("mm",) * 3, source_id=source))
    session = LiveSession(hand_model(), ["hand=Hand:x,y,z"], transport)
    session.connect()
    session.step()
    status = session.snapshot().statuses[0]
    assert status.condition is Condition.WAITING and "name one by source_id=" in status.detail
    chosen = LiveSession(hand_model(), ["hand=source_id=b:x,y,z"], transport,
                         LiveOptions(start="call"))  # fmt: skip
    chosen.connect()
    chosen.begin()
    transport.now += 0.1
    transport.streams[1].push(transport.now + np.arange(3) * 0.01, np.full((3, 3), 250.0))
    transport.now += 0.1
    chosen.step()
    assert np.all(chosen.snapshot().movement.values == 0.25)  # mm, converted to metres


class EchoTransport(FakeTransport):
    """A network where what the session publishes is listed as any other stream (as on LSL)."""

    def outlet(self, spec):
        outlet = super().outlet(spec)
        stream = self.add(FakeStream(spec.name, spec.labels, rate=0.0, type=spec.type,
                                     source_id=spec.source_id, markers=spec.format == "string"))
        pushed = outlet.push

        def push(rows, stamp):
            pushed(rows, stamp)
            stream.push([stamp] * len(rows), list(rows))

        outlet.push = push
        return outlet


def test_a_session_never_reads_its_own_events_back_as_markers(tmp_path) -> None:
    """``--markers type=Markers`` would match the session's own ``-events`` stream: each event
    about a marker left out, read back, became the next marker (a loop that filled the memory
    of a studio in minutes). Its own streams are not opened; another marker stream is."""
    transport = EchoTransport()
    hand = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=RATE))
    outlets = PredictionOutlets(outlet_specs(hand_model(), "icub", None), transport.outlet)
    session = LiveSession(hand_model(), ["hand=Hand:0,1,2"], transport,
                          LiveOptions(start="marker", markers="type=Markers"),
                          outlets=outlets)  # fmt: skip
    session.connect()
    session.step()
    markers = session.snapshot().statuses[-1]
    assert markers.condition is Condition.WAITING
    assert "icub-events is this session's own output, not read back" in markers.detail
    cue = transport.add(FakeStream("Cues", ("label",), rate=0.0, type="Markers", markers=True))
    session.connect()
    session.step()
    assert session.snapshot().statuses[-1].condition is Condition.OK
    cue.push([transport.now], ["hello " * 40])  # not start/end CLASS: an event, cut short
    for _ in range(200):
        transport.now += 0.01
        hand.push([transport.now], [[0.1, 0.0, 0.0]])
        session.step()
    snap = session.snapshot()
    left_out = [e.text for e in snap.events if "left out" in e.text]
    assert len(left_out) == 1 and len(left_out[0]) < 120
    assert snap.n_events < 10
    assert snap.counts["type=Markers"] == (1, 0)


def test_a_marker_stream_is_refused_unless_markers_start_movements() -> None:
    with pytest.raises(ValueError, match="only with --start marker, not --start still"):
        LiveSession(hand_model(), ["hand=Hand:0,1,2"], FakeTransport(),
                    LiveOptions(start="still", markers="Cues"))  # fmt: skip
