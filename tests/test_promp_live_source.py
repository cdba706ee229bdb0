"""The source stage driven by hand (no session, no transport): what a look opened adopted,
each poll's samples converted and split among the inputs of one stream, and each fault (bad
values, the wrong channels, stamps going back, a clock jump, a stall, a rate change, a
vanished stream) a status, an event and, where the samples do not continue, a break."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from promp.live.source import (
    CLEAN_S,
    JUMP_S,
    STALL_MIN_S,
    LiveInput,
    Opened,
    Pulled,
    Source,
)
from promp.live.status import Condition
from promp.live.transport import Selector, StreamDescription

STEP = 0.01  # the streams' declared 100 Hz


def stream(uid="u-1", labels=("x", "y", "z", "g"), units=("mm", "mm", "mm", "N"),
           rate=100.0, fmt="float32", name="Hand") -> StreamDescription:  # fmt: skip
    return StreamDescription(name, "Mocap", "", uid, "lab-pc", rate, tuple(labels),
                             tuple(units), fmt)  # fmt: skip


def markers_stream(uid="m-1") -> StreamDescription:
    return StreamDescription("Markers", "Markers", "", uid, "lab-pc", 0.0, ("m",), ("",),
                             "string")  # fmt: skip


def hand_and_grip(now=0.0, **kwargs) -> Source:
    """Two inputs of one stream (one feed), adopted at ``now``."""
    source = Source([LiveInput.parse("hand=Hand:x,y,z@mm"), LiveInput.parse("grip=Hand:3")],
                    now=now)  # fmt: skip
    source.adopt([Opened(0, stream(**kwargs))], now)
    return source


def rows(times, width=4, first=0.0):
    """Samples at ``times``: row k is ``first + k`` in every channel."""
    times = np.asarray(times, dtype=float)
    return Pulled(times, (first + np.arange(times.size, dtype=float))[:, None] * np.ones(width))


def regular(start, n, step=STEP):
    return start + step * np.arange(n)


def condition(source, k=0):
    return source.statuses()[k].condition


def test_a_source_needs_inputs_of_distinct_names_and_a_marker_stream_of_its_own() -> None:
    hand = LiveInput.parse("hand=Hand:0,1,2")
    with pytest.raises(ValueError):
        Source([])
    with pytest.raises(ValueError):
        Source([hand, LiveInput.parse("hand=Other:0")])
    with pytest.raises(ValueError):
        Source([hand], markers=Selector.parse("Hand"))
    grip, head = LiveInput.parse("grip=Hand:3"), LiveInput.parse("head=Head:0")
    source = Source([hand, grip, head], markers=Selector.parse("type=Markers"), now=7.0)
    assert source.inputs == (hand, grip, head)
    assert all(isinstance(s.detail, str) and s.detail for s in source.statuses())
    wanted = source.wanted()
    assert [(w.feed, str(w.selector), w.markers, w.refused) for w in wanted] == [
        (0, "Hand", False, ""), (1, "Head", False, ""), (2, "type=Markers", True, "")]
    assert [(s.stream, s.condition, s.since) for s in source.statuses()] == [
        ("Hand", Condition.WAITING, 7.0), ("Head", Condition.WAITING, 7.0),
        ("type=Markers", Condition.WAITING, 7.0)]  # fmt: skip
    assert source.connected() == frozenset()
    assert source.counts() == {"Hand": (0, 0), "Head": (0, 0), "type=Markers": (0, 0)}


def test_an_adopted_stream_is_read_converted_and_split_among_its_inputs() -> None:
    source = Source([LiveInput.parse("hand=Hand:x,y,z@mm"), LiveInput.parse("grip=Hand:3")],
                    now=1.0)  # fmt: skip
    events = source.adopt([Opened(0, stream())], 2.0)
    assert len(events) == 1 and events[0].time == 2.0
    assert (condition(source), source.statuses()[0].since) == (Condition.OK, 2.0)
    assert source.connected() == frozenset({0}) and source.wanted() == ()
    assert source.nominal_rate("grip") == 100.0
    times = regular(2.0, 3)
    values = np.array([[1.0, 2.0, 3.0, 4.0], [5.0, 6.0, 7.0, 8.0], [9.0, 10.0, 11.0, 12.0]])
    batch = source.poll({0: Pulled(times, values)}, 2.05)
    assert batch.events == [] and batch.broken == set() and batch.markers == []
    hand_times, hand, hand_units = batch.samples["hand"]
    grip_times, grip, grip_units = batch.samples["grip"]
    assert_array_equal(hand_times, times)
    assert_array_equal(grip_times, times)
    assert_allclose(hand, values[:, :3] * 1e-3)
    assert_allclose(grip, values[:, 3:])
    assert (hand_units, grip_units) == (("m", "m", "m"), ("N",))
    assert source.counts() == {"Hand": (3, 0)}
    assert source.poll({}, 2.06).samples == {}  # a feed absent gave nothing


def test_a_marker_streams_labels_are_markers_on_the_sessions_clock() -> None:
    source = Source([LiveInput.parse("hand=Hand:0,1,2")], markers=Selector.parse("Markers"))
    source.adopt([Opened(0, stream()), Opened(1, markers_stream())], 1.0)
    assert source.connected() == frozenset({0, 1})
    batch = source.poll({1: Pulled(np.array([2.0, 3.5]), ["start top", "end top"])}, 4.0)
    assert batch.markers == [(2.0, "start top"), (3.5, "end top")]
    assert batch.samples == {} and source.counts()["Markers"] == (2, 0)
    assert condition(source, 1) is Condition.OK
    batch = source.poll({1: Pulled.LOST}, 5.0)  # a marker stream lost breaks no input
    assert batch.broken == set() and condition(source, 1) is Condition.VANISHED


def test_a_marker_pull_of_more_stamps_than_labels_is_left_out_and_said_never_raised() -> None:
    source = Source([LiveInput.parse("hand=Hand:0,1,2")], markers=Selector.parse("Markers"))
    source.adopt([Opened(0, stream()), Opened(1, markers_stream())], 1.0)
    for labels in (["start top"], ["start top", "end top", "start top"]):
        batch = source.poll({1: Pulled(np.array([2.0, 3.5]), labels)}, 4.0)
        assert batch.markers == [] and batch.broken == set()
        assert len(batch.events) == 1 and condition(source, 1) is Condition.WRONG_CHANNELS
    assert source.counts()["Markers"] == (4, 4)
    batch = source.poll({1: Pulled(np.array([5.0]), ["end top"])}, 5.0)  # right again: kept
    assert batch.markers == [(5.0, "end top")]


def test_a_stream_found_twice_keeps_the_first_and_comes_back_or_restarts() -> None:
    source = Source([LiveInput.parse("hand=Hand:x,y,z")])
    source.adopt([Opened(0, stream("u-1")), Opened(0, stream("u-2"))], 1.0)
    assert condition(source) is Condition.OK
    batch = source.poll({0: Pulled.LOST}, 2.0)
    assert condition(source) is Condition.VANISHED and source.statuses()[0].since == 2.0
    assert batch.broken == {"hand"} and len(batch.events) == 1
    assert source.connected() == frozenset() and source.wanted()[0].feed == 0
    source.adopt([Opened(0, None, "not found")], 2.5)  # still gone: still vanished
    assert condition(source) is Condition.VANISHED
    source.adopt([Opened(0, stream("u-1"))], 3.0)  # the first one kept: it is back
    assert condition(source) is Condition.BACK and source.statuses()[0].since == 3.0
    source.poll({0: Pulled.LOST}, 4.0)
    source.adopt([Opened(0, stream("u-3"))], 5.0)
    assert condition(source) is Condition.RESTARTED


@pytest.mark.parametrize("uid", ["u-1", "u-2"], ids=["back", "restarted"])
def test_the_same_outlet_back_keeps_its_re_anchoring_and_a_new_one_starts_afresh(uid) -> None:
    """An outlet whose clock jumped is re-anchored; when it vanishes and comes back (the same
    uid: the same clock) its stamps are shifted as before, so it stays on the others' clock (a
    hypothesis sequence of the live session machine: the hand's clock went back 15 s, then
    the outlet came back unshifted, 15 s behind the head's, and its samples waited 16 s for
    the head in the time base, beyond the memory bound). A new outlet (a new uid) has its own
    clock: nothing shifted."""
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 3))}, 1.02)
    source.poll({0: rows(regular(1.03 - 15.0, 3))}, 1.05)  # back 15 s: re-anchored
    source.poll({0: Pulled.LOST}, 1.1)
    source.adopt([Opened(0, stream(uid))], 2.0)
    batch = source.poll({0: rows(regular(2.0 - 15.0, 3))}, 2.02)
    shift = 15.0 if uid == "u-1" else 0.0
    assert_allclose(batch.samples["hand"][0], regular(2.0 - 15.0 + shift, 3), atol=1e-9)
    assert batch.events == []  # (no jump said: the stream's clock goes on)


def test_a_stream_not_found_waits_and_one_without_the_channels_is_refused() -> None:
    source = Source([LiveInput.parse("hand=Hand:x,y,z")], now=0.0)
    events = source.adopt([Opened(0, None, "two streams match")], 1.0)
    assert len(events) == 1 and condition(source) is Condition.WAITING
    assert source.statuses()[0].since == 1.0
    assert source.adopt([Opened(0, None, "two streams match")], 2.0) == []  # said once
    source.adopt([Opened(0, stream("u-9", labels=("a", "b", "c", "d")))], 3.0)
    assert condition(source) is Condition.WRONG_CHANNELS
    assert source.connected() == frozenset()
    assert [(w.feed, w.refused) for w in source.wanted()] == [(0, "u-9")]
    source.adopt([Opened(0, stream("u-10"), "it vanished before it opened")], 4.0)
    assert condition(source) is Condition.WAITING and source.connected() == frozenset()
    source.adopt([Opened(0, stream("u-10"))], 5.0)
    assert condition(source) is Condition.OK  # never read before: not back, not restarted


def test_samples_of_the_wrong_shape_are_left_out_until_right_ones_come() -> None:
    source = hand_and_grip()
    batch = source.poll({0: rows(regular(1.0, 3), width=2)}, 1.0)
    assert batch.samples == {} and len(batch.events) == 1
    assert condition(source) is Condition.WRONG_CHANNELS
    assert isinstance(source.statuses()[0].detail, str) and source.statuses()[0].detail
    assert source.counts() == {"Hand": (3, 3)}
    source.poll({0: Pulled(np.array([[1.0, 1.01]]), np.ones((1, 4)))}, 1.0)  # times (1, 2)
    assert source.counts() == {"Hand": (4, 4)}
    batch = source.poll({0: rows(regular(1.02, 2))}, 1.03)
    assert condition(source) is Condition.OK and len(batch.events) == 1
    assert_array_equal(batch.samples["hand"][0], regular(1.02, 2))


def test_bad_values_are_left_out_counted_and_said_until_clean_for_a_while() -> None:
    source = hand_and_grip(rate=0.0)  # irregular: the samples after those left out are not held
    values = np.ones((5, 4))
    values[1, 0] = np.nan
    values[2, 3] = np.inf
    values[3, 1] = 2e15  # mm: 2e12 m, beyond MAX_MAGNITUDE once in metres
    batch = source.poll({0: Pulled(regular(1.0, 5), values)}, 1.0)
    assert_array_equal(batch.samples["hand"][0], [1.0, 1.04])
    assert condition(source) is Condition.BAD_VALUES and len(batch.events) == 1
    assert source.statuses()[0].detail.split(" ")[0] == "3"
    times = np.array([1.05, np.nan, 1.07])  # a stamp that is not a number: left out too
    batch = source.poll({0: Pulled(times, np.ones((3, 4)))}, 1.1)
    assert batch.events == [] and source.statuses()[0].detail.split(" ")[0] == "4"
    assert source.statuses()[0].since == 1.0 and source.counts() == {"Hand": (8, 4)}
    assert_array_equal(batch.samples["hand"][0], [1.05, 1.07])
    assert source.poll({0: rows(regular(1.08, 2))}, 1.2).events == []
    assert source.poll({0: rows(regular(1.10, 2))}, 1.2 + CLEAN_S - 0.01).events == []
    batch = source.poll({0: rows(regular(1.12, 2))}, 1.2 + CLEAN_S)
    assert condition(source) is Condition.OK and len(batch.events) == 1
    source.poll({0: Pulled(np.array([1.2]), np.full((1, 4), np.nan))}, 3.0)
    assert condition(source) is Condition.BAD_VALUES  # a new episode
    source.poll({0: rows([1.21])}, 3.1)
    source.poll({0: Pulled(np.array([1.22]), np.full((1, 4), np.nan))}, 3.2)
    source.poll({0: rows([1.23])}, 3.3)  # clean again from 3.3, not 3.1
    assert source.poll({0: rows([1.24])}, 3.1 + CLEAN_S + 0.05).events == []
    assert condition(source) is Condition.BAD_VALUES


def test_stamps_going_back_a_little_are_left_out() -> None:
    source = hand_and_grip()
    batch = source.poll({0: rows([1.0, 1.01, 1.005, 1.01, 1.02])}, 1.0)
    assert_array_equal(batch.samples["hand"][0], [1.0, 1.01, 1.02])
    assert_allclose(batch.samples["grip"][1][:, 0], [0.0, 1.0, 4.0])
    batch = source.poll({0: rows([1.02, 1.03 - JUMP_S + 0.02, 1.03])}, 1.03)
    assert_array_equal(batch.samples["hand"][0], [1.03])
    assert batch.events == [] and batch.broken == set()
    assert source.counts() == {"Hand": (8, 4)}


@pytest.mark.parametrize("leap", [-JUMP_S - 0.02, -5.0, JUMP_S + 0.02, 100.0])
def test_a_clock_jump_is_re_anchored_one_step_after_the_last_stamp(leap) -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 3))}, 1.02)
    batch = source.poll({0: rows(regular(1.03 + leap, 3))}, 1.05)
    assert_allclose(batch.samples["hand"][0], regular(1.03, 3), atol=1e-9)
    assert batch.broken == {"hand", "grip"} and len(batch.events) == 1
    assert condition(source) is Condition.CLOCK_JUMP and source.statuses()[0].since == 1.05
    batch = source.poll({0: rows(regular(1.06 + leap, 2))}, 1.07)  # the shift stays
    assert_allclose(batch.samples["hand"][0], regular(1.06, 2), atol=1e-9)
    assert batch.broken == set() and batch.events == []


@pytest.mark.parametrize("first", [False, True], ids=["after clean ones", "from the start"])
def test_a_jump_after_bad_values_is_found_by_their_stamps(first) -> None:
    """Bad values' stamps are the stream's clock all the same: a leap after them is a clock
    jump, re-anchored one step after the last bad sample's stamp, also when every sample was
    bad so far (a marker occluded from the start: a faults test of the studio sent one NaN
    sample, then jumped 5 s, and nothing was said; the stream stayed 5 s ahead of the
    session's clock). They are never given."""
    source = hand_and_grip()
    if not first:
        source.poll({0: rows(regular(0.97, 3))}, 1.0)
    bad = Pulled(regular(1.0, 3), np.full((3, 4), np.nan))
    jumped = rows(regular(6.03, 3))
    both = Pulled(np.concatenate([bad.times, jumped.times]),
                  np.concatenate([bad.values, jumped.values]))  # fmt: skip
    if first:
        source.poll({0: bad}, 1.02)
        batch = source.poll({0: jumped}, 1.05)
    else:
        batch = source.poll({0: both}, 1.05)
    assert_allclose(batch.samples["hand"][0], regular(1.03, 3), atol=1e-9)
    assert batch.broken == {"hand", "grip"} and condition(source) is Condition.CLOCK_JUMP
    assert source.counts() == {"Hand": (6 + 3 * (not first), 3)}
    batch = source.poll({0: rows([6.05, 6.06])}, 1.07)  # the shift stays
    assert_allclose(batch.samples["hand"][0], [1.06], atol=1e-9)
    assert source.counts() == {"Hand": (8 + 3 * (not first), 4)}


@pytest.mark.parametrize("to", [0.2, 5.0], ids=["back", "a leap ahead"])
def test_a_jump_within_a_poll_is_re_anchored_where_it_happens(to) -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 3))}, 1.02)
    times = np.concatenate([regular(1.03, 2), regular(to, 2)])
    batch = source.poll({0: rows(times)}, 1.06)
    assert_allclose(batch.samples["hand"][0], regular(1.03, 4), atol=1e-9)
    assert batch.broken == {"hand", "grip"}


def test_an_irregular_stream_is_re_anchored_by_its_median_step() -> None:
    source = hand_and_grip(rate=0.0)
    source.poll({0: rows(regular(1.0, 3, 0.02))}, 1.04)
    batch = source.poll({0: rows(regular(5.0, 5, 0.02))}, 1.06)
    assert_allclose(batch.samples["hand"][0], regular(1.06, 5, 0.02), atol=1e-9)
    assert batch.broken == {"hand", "grip"}


def test_samples_delivered_late_catch_up_without_a_jump() -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 3))}, 1.5)  # delivered 0.48 s after their stamps
    batch = source.poll({0: rows(regular(1.03, 60))}, 1.6)  # the backlog, caught up
    assert batch.broken == set() and batch.events == []
    assert_allclose(batch.samples["hand"][0], regular(1.03, 60))
    on_time = hand_and_grip()
    on_time.poll({0: rows(regular(1.0, 3))}, 1.02)
    assert on_time.poll({0: rows(regular(1.03, 60))}, 1.1).broken == {"hand", "grip"}


@pytest.mark.parametrize("rate, limit", [(100.0, STALL_MIN_S), (5.0, 10 / 5.0)])
def test_a_stall_is_said_once_from_the_last_sample_heard(rate, limit) -> None:
    source = hand_and_grip(rate=rate)
    assert source.poll({}, 5.0).events == []  # nothing given yet: no stall
    source.poll({0: rows([1.0])}, 1.0)
    assert source.poll({}, 1.0 + limit - 0.01).events == []
    batch = source.poll({}, 1.0 + limit + 0.01)
    assert len(batch.events) == 1 and batch.events[0].time == 1.0
    assert condition(source) is Condition.STALLED and source.statuses()[0].since == 1.0
    assert source.poll({}, 1.0 + 2 * limit).events == []
    batch = source.poll({0: rows([1.0 + 2 * limit])}, 1.0 + 2 * limit)
    assert condition(source) is Condition.OK and len(batch.events) == 1


def test_bad_values_are_heard_a_stream_sending_them_is_not_stalled() -> None:
    source = hand_and_grip()
    source.poll({0: rows([1.0])}, 1.0)
    source.poll({0: Pulled(np.array([1.3]), np.full((1, 4), np.nan))}, 1.3)
    source.poll({}, 1.0 + STALL_MIN_S + 0.1)
    assert condition(source) is Condition.BAD_VALUES


def test_a_rate_change_is_said_once_and_an_undeclared_rate_is_measured() -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 150))}, 2.5)
    assert source.nominal_rate("hand") == 100.0
    events = source.poll({0: rows(regular(2.5, 63, 0.04))}, 5.0).events
    assert len(events) == 1 and condition(source) is Condition.RATE_CHANGED
    assert source.nominal_rate("hand") == pytest.approx(25.0)
    batch = source.poll({0: rows(regular(5.02, 50, 0.04))}, 7.0)
    assert batch.events == []
    for start in (7.02, 7.42):  # the late sender's rule steps at 25 Hz: 0.04 s is no pause
        batch = source.poll({0: rows(regular(start, 10, 0.04))}, start + 0.4)
        assert batch.samples["hand"][0][-1] == regular(start, 10, 0.04)[-1]  # none held
    irregular = hand_and_grip(rate=0.0)
    assert irregular.nominal_rate("grip") == 0.0
    irregular.poll({0: rows(regular(1.0, 4, 0.04))}, 1.2)
    assert irregular.nominal_rate("grip") == 0.0  # too few yet
    batch = irregular.poll({0: rows(regular(1.16, 30, 0.04))}, 2.4)
    assert batch.events == [] and irregular.nominal_rate("grip") == pytest.approx(25.0)


def test_a_rate_is_measured_afresh_after_a_pause() -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 110))}, 2.1)
    # 0.6 s of silence, then the same rate: the pause is not a slower rate
    source.poll({0: rows(regular(2.7, 110))}, 3.8)
    assert source.nominal_rate("hand") == 100.0
    assert all(s.condition is not Condition.RATE_CHANGED for s in source.statuses())


def test_a_late_senders_burst_is_re_spread_and_its_lateness_kept() -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 50))}, 1.5)
    assert source.lateness("hand", 1.5) == 0.0
    burst = 1.69 + 1e-5 * np.arange(20)  # 0.2 s late, 20 samples pushed at once
    batch = source.poll({0: rows(burst)}, 1.7)
    assert_allclose(batch.samples["grip"][0], regular(1.50, 20), atol=2e-4)
    assert source.lateness("grip", 1.7) == pytest.approx(0.19, abs=1e-3)
    assert source.lateness("hand", 1.7 + 10.5) == 0.0
    assert batch.broken == set()


def test_a_burst_short_of_its_backlog_is_given_once_nothing_more_comes() -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 50))}, 1.5)
    burst = 1.8 + 1e-5 * np.arange(5)  # the start of a backlog: held to come whole
    assert "hand" not in source.poll({0: rows(burst)}, 1.8).samples
    batch = source.poll({}, 1.9)  # nothing more came: released
    assert_allclose(batch.samples["hand"][0], regular(1.76, 5), atol=2e-4)
    assert math.isfinite(batch.samples["hand"][0][-1])


def hand_and_head(now=0.0) -> Source:
    """Two streams (two feeds): ``hand`` of Hand (100 Hz) and ``head`` of Head (irregular)."""
    source = Source([LiveInput.parse("hand=Hand:x,y,z"), LiveInput.parse("head=Head:0")], now=now)
    source.adopt([Opened(0, stream("u-1")), Opened(1, stream("h-1", name="Head", rate=0.0))],
                 now)  # fmt: skip
    return source


def test_a_clock_left_at_its_default_starts_the_statuses_at_zero() -> None:
    source = Source([LiveInput.parse("hand=Hand:x,y,z")])
    assert source.statuses()[0].since == 0.0


def test_one_look_adopts_every_feed_it_opened_and_says_each() -> None:
    inputs = [LiveInput.parse(text) for text in ("a=A:x,y,z", "b=B:x,y,z", "c=C:x,y,z")]
    source = Source(inputs)
    found = stream("c-1", name="C")
    events = source.adopt([Opened(1, stream("b-1", labels="abcd")), Opened(2, found),
                           Opened(0, None, "not found")], 1.0)  # fmt: skip
    assert len(events) == 3 and [e.time for e in events] == [1.0, 1.0, 1.0]
    assert [(s.stream, s.condition, s.since) for s in source.statuses()] == [
        ("A", Condition.WAITING, 1.0), ("B", Condition.WRONG_CHANNELS, 1.0),
        ("C", Condition.OK, 1.0)]  # fmt: skip
    assert source.statuses()[2].detail == found.summary()
    assert source.connected() == frozenset({2})
    # a feed read already is skipped, the others of the same look still adopted
    events = source.adopt([Opened(2, stream("c-2", name="C")), Opened(0, stream("a-1", name="A"))],
                          2.0)  # fmt: skip
    assert len(events) == 1 and source.connected() == frozenset({0, 2})
    assert source.statuses()[2].since == 1.0  # the first one kept


def test_a_stream_refused_after_it_vanished_restarts_when_a_right_one_comes() -> None:
    source = Source([LiveInput.parse("hand=Hand:x,y,z")])
    source.adopt([Opened(0, stream("u-1"))], 1.0)
    source.poll({0: Pulled.LOST}, 2.0)
    source.adopt([Opened(0, stream("u-2", labels=("a", "b", "c", "d")))], 3.0)
    assert condition(source) is Condition.WRONG_CHANNELS
    source.adopt([Opened(0, stream("u-3"))], 4.0)
    assert condition(source) is Condition.RESTARTED


def test_a_stream_without_a_uid_that_vanished_is_back() -> None:
    source = Source([LiveInput.parse("hand=Hand:x,y,z")])
    source.adopt([Opened(0, stream(""))], 1.0)
    source.poll({0: Pulled.LOST}, 2.0)
    source.adopt([Opened(0, stream(""))], 3.0)
    assert condition(source) is Condition.BACK


def test_each_feed_of_a_poll_is_read_and_its_events_all_kept() -> None:
    source = Source([LiveInput.parse("hand=Hand:x,y,z"), LiveInput.parse("head=Head:0")])
    source.adopt([Opened(1, stream("h-1", name="Head", rate=0.0))], 1.0)  # Hand not found
    batch = source.poll({1: rows([1.0])}, 1.0)  # a feed not read before one that is
    assert_array_equal(batch.samples["head"][0], [1.0])
    source = hand_and_head()
    batch = source.poll({1: rows([1.0])}, 1.0)  # a feed that gave nothing before one that did
    assert_array_equal(batch.samples["head"][0], [1.0])
    source.poll({0: rows([1.0])}, 1.0)
    # the hand's stream lost, the head's stall checked: the hand's event stays
    batch = source.poll({0: Pulled.LOST}, 1.1)
    assert len(batch.events) == 1 and condition(source) is Condition.VANISHED
    source = hand_and_head()  # the hand's samples of the wrong shape, then the head's lost
    batch = source.poll({0: rows([1.0], width=2), 1: Pulled.LOST}, 1.0)
    assert [e.time for e in batch.events] == [1.0, 1.0]
    assert [condition(source, k) for k in (0, 1)] == [Condition.WRONG_CHANNELS,
                                                      Condition.VANISHED]  # fmt: skip


NAN = Pulled(np.array([1.1]), np.full((1, 4), np.nan))


@pytest.mark.parametrize("fault, before, then, at, after", [
    ("shape", [], rows([1.2], width=2), 1.2, Condition.WRONG_CHANNELS),
    ("bad values", [], Pulled(np.array([1.2]), np.full((1, 4), np.nan)), 1.2,
     Condition.BAD_VALUES),
    ("usable again", [(rows([1.1], width=2), 1.1)], rows([1.2]), 1.2, Condition.OK),
    ("clean again", [(NAN, 1.1), (rows([1.2]), 1.2)], rows([1.3]), 1.2 + CLEAN_S, Condition.OK),
    ("jump", [], rows([9.0]), 1.2, Condition.CLOCK_JUMP),
])  # fmt: skip
def test_an_event_of_a_second_feed_keeps_the_firsts(fault, before, then, at, after) -> None:
    source = hand_and_head()
    source.poll({0: rows([1.0]), 1: rows([1.0])}, 1.0)
    for pulled, now in before:
        source.poll({0: rows([now]), 1: pulled}, now)
    batch = source.poll({0: Pulled.LOST, 1: then}, at)
    assert [e.time for e in batch.events] == [at, at]
    assert condition(source, 0) is Condition.VANISHED
    assert condition(source, 1) is after
    assert source.statuses()[1].stream == "Head"


def test_the_marker_streams_labels_are_counted_across_polls() -> None:
    source = Source([LiveInput.parse("hand=Hand:0,1,2")], markers=Selector.parse("Markers"))
    source.adopt([Opened(0, stream()), Opened(1, markers_stream())], 1.0)
    source.poll({1: Pulled(np.array([2.0, 3.5]), ["start top", "end top"])}, 4.0)
    source.poll({1: Pulled(np.array([4.0]), ["start top"])}, 4.5)
    assert source.counts()["Markers"] == (3, 0)


def test_three_inputs_of_one_stream_each_get_their_channels() -> None:
    source = Source([LiveInput.parse("a=Hand:0"), LiveInput.parse("b=Hand:1,2"),
                     LiveInput.parse("c=Hand:3")])  # fmt: skip
    source.adopt([Opened(0, stream())], 1.0)
    values = np.array([[1.0, 2.0, 3.0, 4.0]])
    batch = source.poll({0: Pulled(np.array([1.0]), values)}, 1.0)
    got = [batch.samples[n][1] for n in "abc"]  # Hand's x, y, z in mm
    assert_allclose(np.concatenate(got, axis=1), [[1e-3, 2e-3, 3e-3, 4.0]])
    assert [g.shape for g in got] == [(1, 1), (1, 2), (1, 1)]


def test_a_value_at_the_largest_magnitude_is_kept() -> None:
    from promp.data import MAX_MAGNITUDE

    source = hand_and_grip()
    values = np.full((1, 4), MAX_MAGNITUDE)  # the grip's newtons: not scaled
    batch = source.poll({0: Pulled(np.array([1.0]), values)}, 1.0)
    assert_array_equal(batch.samples["grip"][1], [[MAX_MAGNITUDE]])
    assert condition(source) is Condition.OK


def test_bad_values_said_again_keep_the_streams_name_and_clean_ends_them_at_clean_s() -> None:
    source = hand_and_grip()
    for now in (1.0, 1.5):
        source.poll({0: Pulled(np.array([now]), np.full((1, 4), np.nan))}, now)
    status = source.statuses()[0]
    assert (status.stream, status.condition, status.since) == ("Hand", Condition.BAD_VALUES, 1.0)
    source.poll({0: rows([2.0])}, 2.0)  # clean from 2.0
    batch = source.poll({0: rows([2.01])}, 2.0 + CLEAN_S)  # clean exactly CLEAN_S: usable
    status = source.statuses()[0]
    assert (status.condition, status.since) == (Condition.OK, 2.0 + CLEAN_S)
    assert isinstance(status.detail, str) and status.detail
    assert [e.time for e in batch.events] == [2.0 + CLEAN_S]


def test_usable_samples_after_the_wrong_shape_are_said_at_their_time() -> None:
    source = hand_and_grip()
    source.poll({0: rows([1.0], width=2)}, 1.0)
    source.poll({0: rows([1.25])}, 1.25)
    status = source.statuses()[0]
    assert (status.condition, status.since) == (Condition.OK, 1.25)
    assert isinstance(status.detail, str) and status.detail


def test_a_stamp_exactly_jump_s_back_is_a_jump_and_one_exactly_jump_s_ahead_is_not() -> None:
    source = hand_and_grip(rate=0.0)
    source.poll({0: rows([1.0])}, 1.0)
    batch = source.poll({0: rows([1.0 - JUMP_S])}, 1.0)
    assert batch.broken == {"hand", "grip"} and condition(source) is Condition.CLOCK_JUMP
    source = hand_and_grip(rate=0.0)
    source.poll({0: rows([1.0])}, 1.0)
    # 0.5 s of stamps in 0.25 s here, delivered on time: JUMP_S ahead, not beyond
    batch = source.poll({0: rows([1.5])}, 1.25)
    assert batch.broken == set() and condition(source) is Condition.OK


def test_two_clock_jumps_add_up() -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 3))}, 1.02)
    source.poll({0: rows(regular(11.03, 3))}, 1.05)  # 10 s ahead
    source.poll({0: rows(regular(31.06, 3))}, 1.08)  # 20 s more
    batch = source.poll({0: rows(regular(31.09, 2))}, 1.1)
    assert_allclose(batch.samples["hand"][0], regular(1.09, 2), atol=1e-9)
    assert batch.broken == set() and batch.events == []  # no jump seen again


def test_stamps_left_out_are_counted_in_each_poll() -> None:
    source = hand_and_grip()
    source.poll({0: rows([1.0, 1.01, 1.005, 1.01, 1.02])}, 1.0)
    assert source.counts() == {"Hand": (5, 2)}


def test_the_rate_is_measured_from_five_samples_over_half_the_window() -> None:
    for times, rate in [([1.0, 1.25, 1.5, 1.75, 2.0], 4.0),  # span exactly half the window
                        ([1.0, 2.25, 2.5, 2.75, 3.0], 4.0),  # exactly the window: all kept
                        ([1.0, 1.25, 1.5, 1.75], 0.0)]:  # fmt: skip
        source = hand_and_grip(rate=0.0)
        source.poll({0: rows(times)}, times[-1])
        assert source.nominal_rate("hand") == pytest.approx(rate), times


def test_a_pause_of_exactly_stall_min_s_does_not_restart_the_rates_window() -> None:
    source = hand_and_grip(rate=0.0)
    source.poll({0: rows([1.0, 1.25, 1.5, 1.75])}, 1.75)
    source.poll({0: rows([1.75 + STALL_MIN_S])}, 1.75 + STALL_MIN_S)
    assert source.nominal_rate("hand") == pytest.approx(4.0)


def test_a_rate_change_is_said_at_its_time_and_exactly_the_tolerance_is_none() -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 150))}, 2.5)
    events = source.poll({0: rows(regular(2.5, 63, 0.04))}, 5.0).events
    assert [e.time for e in events] == [5.0] and source.statuses()[0].since == 5.0
    exact = hand_and_grip(rate=1.6)  # 2 Hz is 25 % over
    assert exact.poll({0: rows(regular(1.0, 5, 0.5))}, 3.0).events == []
    assert exact.nominal_rate("hand") == 1.6


def test_a_slow_declared_rate_that_changes_is_said_and_re_spreads_at_the_new_rate() -> None:
    source = hand_and_grip(rate=1.0)
    events = source.poll({0: rows(regular(1.0, 5, 0.25))}, 2.0).events  # 4 Hz, not 1
    assert len(events) == 1 and condition(source) is Condition.RATE_CHANGED
    assert source.nominal_rate("hand") == 4.0
    burst = 3.0 + 1e-5 * np.arange(4)  # 1 s late: four 4 Hz samples pushed at once
    batch = source.poll({0: rows(burst)}, 3.0)
    assert_allclose(batch.samples["hand"][0], [2.25, 2.5, 2.75, 3.0], atol=1e-4)


def test_an_undeclared_rate_that_changes_never_re_spreads_a_burst() -> None:
    source = hand_and_grip(rate=0.0)
    source.poll({0: rows(regular(1.0, 30, 0.04))}, 2.2)
    assert source.nominal_rate("hand") == pytest.approx(25.0)
    events = source.poll({0: rows(regular(2.2, 150, 0.01))}, 3.7).events
    assert len(events) == 1 and source.nominal_rate("hand") == pytest.approx(100.0)
    burst = 3.89 + 1e-5 * np.arange(20)
    batch = source.poll({0: rows(burst)}, 3.9)
    assert_array_equal(batch.samples["hand"][0], burst)


def test_a_stall_is_said_at_exactly_its_limit_with_a_detail() -> None:
    source = hand_and_grip()
    source.poll({0: rows([1.0])}, 1.0)
    source.poll({}, 1.0 + STALL_MIN_S)
    status = source.statuses()[0]
    assert status.condition is Condition.STALLED
    assert isinstance(status.detail, str) and status.detail


def test_a_rate_change_found_in_samples_released_by_an_idle_poll_is_said_at_its_time() -> None:
    # 12.5 Hz where 100 Hz is declared, one sample every 8 polls of a 100 Hz session: each
    # sample after such a pause is held (it may begin a backlog), then released by a poll
    # that brought nothing; the change is seen in what such a poll released
    source = hand_and_grip()
    said = []
    for i in range(400):
        now = 1.0 + 0.01 * i
        pulled = {0: rows([now])} if i % 8 == 0 else {}
        said += [(e.time, now, bool(pulled)) for e in source.poll(pulled, now).events]
    assert len(said) == 1 and condition(source) is Condition.RATE_CHANGED
    time, now, brought = said[0]
    assert time == now and not brought
    assert source.nominal_rate("hand") == pytest.approx(12.5)


def test_a_refused_stream_or_a_marker_pull_left_out_keeps_the_events_before_it() -> None:
    """A look that opens a right stream then one without the channels, and a poll whose
    marker pull is left out after an input's stream was lost: every event is kept, each at
    its time."""
    source = Source([LiveInput.parse(t) for t in ("a=A:x,y,z", "b=B:x,y,z")])
    events = source.adopt([Opened(0, stream("a-1", name="A")),
                           Opened(1, stream("b-1", name="B", labels="abcd"))], 1.0)  # fmt: skip
    assert [e.time for e in events] == [1.0, 1.0]
    assert [condition(source, k) for k in (0, 1)] == [Condition.OK, Condition.WRONG_CHANNELS]
    source = Source([LiveInput.parse("hand=Hand:0,1,2")], markers=Selector.parse("Markers"))
    source.adopt([Opened(0, stream()), Opened(1, markers_stream())], 1.0)
    batch = source.poll({0: Pulled.LOST, 1: Pulled(np.array([2.0, 3.5]), ["start top"])}, 4.0)
    assert [e.time for e in batch.events] == [4.0, 4.0]
    assert [condition(source, k) for k in (0, 1)] == [Condition.VANISHED,
                                                      Condition.WRONG_CHANNELS]  # fmt: skip
    assert source.statuses()[1].since == 4.0
