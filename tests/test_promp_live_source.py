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
    source = Source([hand, LiveInput.parse("grip=Hand:3"), LiveInput.parse("head=Head:0")],
                    markers=Selector.parse("type=Markers"), now=7.0)  # fmt: skip
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


def test_a_jump_within_a_poll_is_re_anchored_where_it_happens() -> None:
    source = hand_and_grip()
    source.poll({0: rows(regular(1.0, 3))}, 1.02)
    times = np.concatenate([regular(1.03, 2), regular(0.2, 2)])
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
