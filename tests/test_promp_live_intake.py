"""The live intake (promp.live.intake): a look opens the wanted streams (not the session's own
outputs, not an ambiguous match, not a refused stream), a step's arrivals hold what was opened,
pulled, called and noted, and settling closes the inlets the pipeline let go. On the fake
transport (tests/live_fakes.py), no thread, no network."""

from __future__ import annotations

import numpy as np

from promp.live.intake import Intake
from promp.live.pipeline import Call
from promp.live.source import Pulled, Wanted
from promp.live.transport import Selector, StreamLost
from tests.live_fakes import FakeStream, FakeTransport


def wanted(feed: int, name: str, markers: bool = False, refused: str = "") -> Wanted:
    return Wanted(feed, Selector.parse(name), markers, refused)


def opened_by(intake: Intake, now: float = 0.0) -> list:
    return list(intake.arrivals(now).opened)


def test_a_look_opens_each_wanted_stream_and_the_step_pulls_it():
    transport = FakeTransport()
    hand = transport.add(FakeStream("Hand", ("x", "y")))
    marks = transport.add(FakeStream("Marks", ("label",), markers=True))
    transport.add(FakeStream("Other", ("x",)))
    intake = Intake(transport, (wanted(0, "Hand"), wanted(1, "Marks", markers=True)))
    intake.look(0.1)
    assert [d.name for d in intake.found] == ["Hand", "Marks", "Other"]
    hand.push([1.0, 1.01], [[1.0, 2.0], [3.0, 4.0]])
    marks.push([1.005], ["start left"])
    arrivals = intake.arrivals(5.0)
    assert arrivals.now == 5.0
    assert [(o.feed, o.stream.uid, o.problem) for o in arrivals.opened] == [
        (0, hand.description.uid, ""), (1, marks.description.uid, "")]
    assert sorted(arrivals.pulled) == [0, 1]
    np.testing.assert_array_equal(arrivals.pulled[0].times, [1.0, 1.01])
    np.testing.assert_array_equal(arrivals.pulled[0].values, [[1.0, 2.0], [3.0, 4.0]])
    assert not arrivals.pulled[0].lost and arrivals.pulled[0].offset == 0.0
    intake._inlets[0].offset = lambda: 0.25  # the transport's clock correction, kept
    assert intake.arrivals(5.5).pulled[0].offset == 0.25
    assert list(arrivals.pulled[1].values) == ["start left"]
    # opened once: the next step has nothing new opened, and pulls what came since
    hand.push([1.02], [[5.0, 6.0]])
    again = intake.arrivals(6.0)
    assert again.opened == ()
    np.testing.assert_array_equal(again.pulled[0].times, [1.02])


def test_a_marker_feed_opens_only_a_marker_stream_and_a_sample_feed_only_samples():
    transport = FakeTransport()
    transport.add(FakeStream("S", ("x",)))
    intake = Intake(transport, (wanted(0, "S", markers=True),))
    intake.look(0.1)
    assert opened_by(intake) == []
    marks = transport.add(FakeStream("M", ("label",), markers=True))
    intake = Intake(transport, (wanted(0, "M"), wanted(1, "M", markers=True)))
    intake.look(0.1)
    assert [(o.feed, o.stream.uid) for o in opened_by(intake)] == [(1, marks.description.uid)]


def test_the_session_s_own_output_is_not_read_back():
    transport = FakeTransport()
    own = transport.add(FakeStream("Events", ("label",), markers=True, source_id="me"))
    intake = Intake(transport, (wanted(0, "Events", markers=True),), own=lambda: ["me"])
    intake.look(0.1)
    [entry] = opened_by(intake)
    assert entry.feed == 0 and entry.stream is None and entry.problem
    assert intake.arrivals(1.0).pulled == {}
    # another outlet of that name, not the session's, is read
    other = transport.add(FakeStream("Events", ("label",), markers=True, source_id="them"))
    intake.look(0.1)
    [entry] = opened_by(intake)
    assert entry.stream.uid == other.description.uid and not entry.problem
    assert own.description.uid != other.description.uid


def test_several_matching_streams_open_none_and_say_so():
    transport = FakeTransport()
    transport.add(FakeStream("Hand", ("x",), source_id="a"))
    transport.add(FakeStream("Hand", ("x",), source_id="b"))
    intake = Intake(transport, (wanted(0, "Hand"),))
    intake.look(0.1)
    [entry] = opened_by(intake)
    assert entry.stream is None
    assert all(s.description.summary() in entry.problem for s in transport.streams)  # both
    assert intake.arrivals(1.0).pulled == {}


def test_a_refused_stream_is_not_opened_again_but_a_new_one_is():
    transport = FakeTransport()
    old = transport.add(FakeStream("Hand", ("x",)))
    intake = Intake(transport, (wanted(0, "Hand", refused=old.description.uid),))
    intake.look(0.1)
    assert opened_by(intake) == [] and intake.arrivals(1.0).pulled == {}
    old.gone = True
    new = transport.add(FakeStream("Hand", ("x", "y")))
    intake.look(0.1)
    assert [o.stream.uid for o in opened_by(intake)] == [new.description.uid]


def test_a_stream_that_vanishes_before_it_opens_is_said_with_its_description():
    transport = FakeTransport()
    stream = transport.add(FakeStream("Hand", ("x",)))

    def lost(description):
        raise StreamLost("the outlet went away")

    transport.open = lost
    intake = Intake(transport, (wanted(0, "Hand"),))
    intake.look(0.1)
    [entry] = opened_by(intake)
    assert entry.stream.uid == stream.description.uid
    assert "the outlet went away" in entry.problem  # why, as the transport said it
    assert intake.arrivals(1.0).pulled == {}


def test_a_look_that_finds_nothing_wanted_queues_nothing_and_waits_as_told():
    transport = FakeTransport()
    waits = []
    find = transport.find
    transport.find = lambda wait: waits.append(wait) or find(wait)
    intake = Intake(transport, (wanted(0, "Hand"),))
    assert intake.found == ()  # nothing looked for yet
    intake.look(0.25)
    assert waits == [0.25]
    assert intake.found == ()
    assert intake.arrivals(1.0).opened == ()


def test_a_feed_found_twice_keeps_its_first_inlet_and_closes_the_second():
    transport = FakeTransport()
    stream = transport.add(FakeStream("Hand", ("x",)))
    intake = Intake(transport, (wanted(0, "Hand"),))
    inlets = []
    opener = transport.open
    transport.open = lambda d: inlets.append(opener(d)) or inlets[-1]
    intake.look(0.1)
    intake.look(0.1)
    assert len(opened_by(intake)) == 1
    assert [i.closed for i in inlets] == [False, True]
    stream.push([1.0], [[2.0]])
    np.testing.assert_array_equal(intake.arrivals(2.0).pulled[0].times, [1.0])


def test_a_lost_stream_and_a_failing_inlet_are_lost_and_only_the_failure_is_said():
    transport = FakeTransport()
    gone = transport.add(FakeStream("A", ("x",)))
    transport.add(FakeStream("B", ("x",)))
    fine = transport.add(FakeStream("C", ("x",)))
    intake = Intake(transport, (wanted(0, "A"), wanted(1, "B"), wanted(2, "C")))
    intake.look(0.1)
    intake.arrivals(1.0)
    gone.gone = True
    inlet = intake._inlets[1]

    def broken():
        raise RuntimeError("defect")

    inlet.pull = broken
    fine.push([1.0], [[3.0]])
    arrivals = intake.arrivals(2.0)
    assert arrivals.pulled[0] is Pulled.LOST and arrivals.pulled[1] is Pulled.LOST
    assert not arrivals.pulled[2].lost
    [note] = arrivals.notes
    assert note.time == 2.0
    assert arrivals.calls == ()


def test_calls_and_notes_reach_the_next_step_in_order_once():
    transport = FakeTransport(now=7.0)
    intake = Intake(transport, ())
    intake.call("start", 3, "left")
    intake.note("something")
    intake.call("end", 4.5)
    arrivals = intake.arrivals(8.0)
    assert arrivals.calls == (Call("start", 3.0, "left"), Call("end", 4.5, ""))
    assert isinstance(arrivals.calls[0].time, float)
    assert [n.time for n in arrivals.notes] == [7.0]
    again = intake.arrivals(9.0)
    assert again.calls == () and again.notes == ()


def test_settling_closes_the_inlets_let_go_and_looks_for_what_is_wanted_now():
    transport = FakeTransport()
    a = transport.add(FakeStream("A", ("x",)))
    transport.add(FakeStream("B", ("x",)))
    intake = Intake(transport, (wanted(0, "A"), wanted(1, "B")))
    intake.look(0.1)
    intake.arrivals(1.0)
    first, second = intake._inlets[0], intake._inlets[1]
    intake.settle(frozenset({1}), (wanted(0, "A"),))
    assert first.closed and not second.closed
    assert sorted(intake.arrivals(2.0).pulled) == [1]
    intake.look(0.1)  # looks for feed 0 only now
    [entry] = opened_by(intake)
    assert entry.feed == 0 and entry.stream.uid == a.description.uid


def test_closing_closes_every_inlet_and_those_opened_but_not_yet_taken():
    transport = FakeTransport()
    transport.add(FakeStream("A", ("x",)))
    transport.add(FakeStream("B", ("x",)))
    intake = Intake(transport, (wanted(0, "A"),))
    intake.look(0.1)
    intake.arrivals(1.0)
    held = intake._inlets[0]
    intake.settle(frozenset({0}), (wanted(1, "B"),))
    inlets = []
    opener = transport.open
    transport.open = lambda d: inlets.append(opener(d)) or inlets[-1]
    intake.look(0.1)  # opened, not yet taken by a step
    intake.close()
    assert held.closed and [i.closed for i in inlets] == [True]
    assert intake.arrivals(2.0).pulled == {} and intake.arrivals(2.0).opened == ()


def test_a_look_that_finds_a_feed_again_still_opens_the_next_feeds():
    transport = FakeTransport()
    a = transport.add(FakeStream("A", ("x",)))
    intake = Intake(transport, (wanted(0, "A"), wanted(1, "B")))
    intake.look(0.1)
    assert [o.feed for o in opened_by(intake)] == [0]
    b = transport.add(FakeStream("B", ("x",)))
    intake.look(0.1)  # A again (its inlet kept, the new one closed), and B
    assert [(o.feed, o.stream.uid) for o in opened_by(intake)] == [(1, b.description.uid)]
    assert intake._inlets[0].description.uid == a.description.uid
    assert sorted(intake.arrivals(2.0).pulled) == [0, 1]
