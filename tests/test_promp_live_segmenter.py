"""The live segmenter: a movement's start and end from stillness, a marker stream or calls;
each movement its own rows."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from promp.live.segmenter import HISTORY_S, SLACK_S, Belief, Segmenter, StillRule
from promp.live.timebase import Rows
from promp.stillness import (
    MARGIN_S,
    MIN_MOVE_S,
    MIN_STILL_S,
    SMOOTH_S,
    MovingSpans,
    moving_spans,
)
from tests.live_fakes import flt_dataset, hand_model, held

HAND = [(slice(0, 3), "m")]


def fed(segmenter: Segmenter, times, values, per=7):
    """Feed rows in chunks of ``per``; the boundaries, in order."""
    out = []
    for a in range(0, times.size, per):
        out += segmenter.feed(Rows(times[a:a + per], values[a:a + per]))
    return out


def test_stillness_finds_each_movement_of_a_session() -> None:
    demos = [held(d, 1.0, 1.0) for d in (flt_dataset()["left"][0], flt_dataset()["top"][0])]
    times = np.concatenate([demos[0].times, demos[0].times[-1] + 0.01 + demos[1].times])
    first, second = (d.select(["x", "y", "z"]) for d in demos)
    values = np.vstack([first, second - second[0] + first[-1]])  # the hand does not teleport
    assert len(moving_spans(times, [(values, "m")])) == 2  # what the take trimming finds
    boundaries = fed(Segmenter("still", 3, HAND), times, values)
    kinds = [(b.kind, b.number) for b in boundaries]
    assert kinds == [("start", 1), ("end", 1), ("start", 2), ("end", 2)]
    for b, offset in ((boundaries[0], 0.0), (boundaries[2], demos[0].times[-1] + 0.01)):
        onset = offset + 1.0  # the movement's first sample after the held rest
        assert onset - MARGIN_S - 0.15 <= b.time <= onset + 0.05
    ended = boundaries[1].movement
    assert ended.ended == "still" and len(ended) > 50
    assert ended.times[-1] - ended.times[0] < demos[0].duration - 2.0 + 2 * MARGIN_S + 0.3
    assert boundaries[3].time < times[-1] - MIN_STILL_S + 0.1


def test_a_twitch_is_not_a_movement() -> None:
    times = np.arange(300) * 0.01
    values = np.zeros((300, 3))
    values[100:104, 0] = np.linspace(0, 0.004, 4)  # 10 cm/s for 0.04 s, then still again
    values[104:, 0] = 0.004
    assert moving_spans(times, [(values, "m")]) == []  # the take trimming drops it too
    assert fed(Segmenter("still", 3, HAND), times, values) == []


def test_markers_delimit_labelled_movements_even_when_they_arrive_late() -> None:
    times = 10.0 + np.arange(400) * 0.01
    values = np.arange(400.0)[:, None] * np.ones(3)
    seg = Segmenter("marker", 3, HAND)
    out = fed(seg, times[:150], values[:150])  # rows first, the markers after them
    seg.markers([(10.5, "start top"), (11.2, "end top"), (11.5, "hello")])
    out += fed(seg, times[150:], values[150:])
    seg.markers([(12.0, "start left")])
    out += seg.feed(None)
    assert [(b.kind, b.number) for b in out] == [("start", 1), ("end", 1), ("start", 2)]
    first = out[1].movement
    assert first.label == "top" and first.ended == "end marker"
    assert_array_equal(first.times, times[50:121])
    assert seg.unknown == [(11.5, "hello")]
    assert seg.movement.start == times[200]


def test_calls_start_and_end_a_movement_in_any_mode() -> None:
    times = np.arange(100) * 0.01
    seg = Segmenter("marker", 1, [(slice(0, 1), "m")])
    seg.begin(0.2, "take")
    seg.end(0.5)
    out = seg.feed(Rows(times, times[:, None]))
    assert [b.kind for b in out] == ["start", "end"]
    assert_array_equal(out[1].movement.times, times[20:51])


def test_a_broken_input_and_a_too_long_movement_end_it() -> None:
    times = np.arange(1000) * 0.01
    seg = Segmenter("call", 1, max_movement_s=3.0)
    seg.begin(0.0)
    seg.feed(Rows(times[:100], times[:100, None]))
    (end,) = seg.abort("input 'hand' broke off")
    assert end.reason == "input 'hand' broke off" and len(end.movement) == 100
    seg.begin(1.0)
    out = seg.feed(Rows(times[100:], times[100:, None]))
    assert out[-1].reason == "longer than 3 s" and seg.movement is None


def test_stillness_needs_an_input_in_metres_or_radians() -> None:
    with pytest.raises(ValueError, match="--start marker"):
        Segmenter("still", 3, [(slice(0, 3), "N")])
    with pytest.raises(ValueError, match="unknown movement start"):
        Segmenter("whenever", 3, HAND)


# ---------------------------------------------------------------------------- the still rule


def one_motion(n: int, first: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` rows at 100 Hz of a hand still but for 20 cm along y in the second from row
    ``first``."""
    times = np.arange(n) * 0.01
    values = np.zeros((n, 3))
    values[first:first + 100, 1] = np.linspace(0.0, 0.2, 100)
    values[first + 100:, 1] = 0.2
    return times, values


@pytest.mark.parametrize("rule", [
    dict(pauses={"a": -0.1}), dict(pauses={"a": math.nan}), dict(pauses={"a": math.inf}),
    dict(before=-0.01), dict(after=math.inf), dict(before=math.nan),
])  # fmt: skip
def test_a_still_rule_refuses_a_stillness_that_is_not_seconds(rule) -> None:
    with pytest.raises(ValueError):
        StillRule(**rule)


def test_a_still_rule_of_zero_seconds_is_allowed() -> None:
    rule = StillRule({"a": 0.0}, 0.0, 0.0)
    assert (rule.pauses["a"], rule.before, rule.after) == (0.0, 0.0, 0.0)


def with_stillness(model, stillness):
    """``model`` whose primitives (in order) were still as ``stillness`` says (one dict of
    part to seconds per primitive, for the modality ``hand``; None: none learned)."""
    primitives = [dataclasses.replace(p, stillness={} if s is None else {"hand": s})
                  for p, s in zip(model.primitives, stillness, strict=False)]  # fmt: skip
    return dataclasses.replace(model, primitives=tuple(primitives))


def test_the_still_rule_of_a_model_is_the_median_of_its_demonstrations() -> None:
    model = hand_model()
    first, second = (p.name for p in model.primitives[:2])
    learned = [
        {"lead": [0.1, 0.5], "pause": [0.2, 0.3], "trail": [0.3, 0.9]},
        {"lead": [0.2], "pause": [0.4], "trail": [0.6]},
    ] + [None] * (len(model.primitives) - 2)  # fmt: skip
    model = with_stillness(model, learned)
    rule = StillRule.of(model, ["hand"])
    assert rule.before == pytest.approx(0.2) and rule.after == pytest.approx(0.6)
    assert rule.pauses[first] == model.primitives[0].pause(["hand"]) > 0
    assert rule.pauses[second] == model.primitives[1].pause(["hand"]) > 0
    assert rule.pauses[model.primitives[2].name] == 0.0
    nothing = StillRule.of(model, ["head"])  # a modality none learned
    assert (nothing.before, nothing.after) == (MARGIN_S, MARGIN_S)
    assert set(nothing.pauses.values()) == {0.0}


def test_the_pause_allowed_follows_the_latest_prediction_of_the_movement() -> None:
    seg = Segmenter("still", 3, HAND, rule=StillRule({"a": 0.8, "b": 5.0, "c": 0.3, "d": 0.0}))
    longest = np.nextafter(5.0, math.inf)
    assert seg.longest_pause == longest and seg.allowed_pause() == longest
    assert seg.history_s == pytest.approx(longest + MIN_MOVE_S + SMOOTH_S + MARGIN_S)
    seg.begin(0.0)
    times = np.arange(10) * 0.01
    seg.feed(Rows(times, np.zeros((10, 3))), Belief(1, "a", 1.0))
    assert seg.allowed_pause() == np.nextafter(0.8, math.inf)  # it may have reached its end
    for belief in (Belief(1, "a", 0.99), Belief(2, "a", 1.0), Belief(1, "e", 1.0)):
        seg.feed(None, belief)
        assert seg.allowed_pause() == longest, belief
    for name in ("c", "d"):
        seg.feed(None, Belief(1, name, 1.5))
        assert seg.allowed_pause() == MIN_STILL_S  # never less
    seg.feed(None)  # no new prediction: the latest holds
    assert seg.allowed_pause() == MIN_STILL_S
    assert Segmenter("still", 3, HAND).allowed_pause() == MIN_STILL_S  # none learned
    assert Segmenter("still", 3, HAND).history_s == HISTORY_S


def test_the_still_rule_keeps_its_stillness_before_and_after_the_motion() -> None:
    times, values = one_motion(500, 150)
    rule = StillRule(before=0.3, after=0.05)
    seg = Segmenter("still", 3, HAND, rule=rule)
    events = MovingSpans(["m"], [3]).push(times, values, seg.allowed_pause())
    assert [e.kind for e in events] == ["start", "end"]
    out = seg.feed(Rows(times, values))
    assert [(b.kind, b.number) for b in out] == [("start", 1), ("end", 1)]
    first = int(np.searchsorted(times, events[0].first - 0.3))
    assert out[0].time == times[first]
    assert out[1].time == events[1].last + 0.05 and out[1].reason == "still"
    stop = int(np.searchsorted(times, events[1].last + 0.05, side="right"))
    assert_array_equal(out[1].movement.times, times[first:stop])
    assert_array_equal(out[1].movement.values, values[first:stop])
    assert out[1].movement.number == 1 and out[1].movement.label == ""


def test_a_call_overrides_the_still_rule_while_its_movement_goes_on() -> None:
    times, values = one_motion(500, 150)
    seg = Segmenter("still", 3, HAND)
    seg.begin(0.5, "take")
    out = fed(seg, times[:200], values[:200])
    assert [(b.kind, b.number) for b in out] == [("start", 1)]  # the motion's start: none
    assert seg.movement.label == "take" and seg.movement.start == 0.5
    (end,) = seg.abort("input 'hand' broke off")
    assert end.time == times[199] and len(end.movement) == 150
    out = seg.feed(Rows(times[200:], values[200:]))  # after a break: rows anew
    assert [(b.kind, b.number) for b in out] == [("start", 2), ("end", 2)]
    assert out[0].time == times[200] == out[1].movement.times[0]
    seg = Segmenter("still", 3, HAND)
    seg.begin(0.5, "take")
    out = fed(seg, times, values)  # the stillness ends it
    assert [(b.kind, b.number) for b in out] == [("start", 1), ("end", 1)]
    assert out[1].reason == "still" and out[1].movement.label == "take"
    assert out[1].movement.times[0] == 0.5


# ---------------------------------------------------------------------------- calls, markers


def test_markers_are_set_aside_unless_markers_start_movements() -> None:
    for start in ("call", "still"):
        seg = Segmenter(start, 3, HAND)
        seg.markers([(1.0, "start top"), (2.0, "end top")])
        assert seg.unknown == [(1.0, "start top"), (2.0, "end top")]
        assert seg.feed(Rows(np.arange(300) * 0.01, np.zeros((300, 3)))) == []
    seg = Segmenter("marker", 3, HAND)
    seg.markers([(np.float32(0.5), "start top")])
    out = seg.feed(Rows(np.arange(100) * 0.01, np.zeros((100, 3))))
    assert [(b.kind, b.time) for b in out] == [("start", 0.5)] and seg.unknown == []
    assert seg.movement.label == "top"


def test_a_start_while_a_movement_goes_on_ends_it_there() -> None:
    times = np.arange(100) * 0.01
    seg = Segmenter("call", 1)
    seg.begin(0.2, "a")
    seg.begin(0.6, "b")
    out = seg.feed(Rows(times, times[:, None]))
    assert [(b.kind, b.number, b.time) for b in out] == [
        ("start", 1, 0.2), ("end", 1, 0.6), ("start", 2, 0.6)]  # fmt: skip
    assert_array_equal(out[1].movement.times, times[20:61])
    assert out[1].movement.label == "a" and out[1].movement.ended != ""
    assert_array_equal(seg.movement.times, times[61:])
    assert seg.movement.label == "b"
    assert seg.movement.number == 2


def test_an_end_waits_for_the_rows_up_to_it() -> None:
    times = np.arange(100) * 0.01
    seg = Segmenter("call", 1)
    seg.end(0.1)  # nothing goes on: nothing ends
    seg.begin(0.2)
    seg.end(0.5)
    assert [b.kind for b in seg.feed(Rows(times[:40], times[:40, None]))] == ["start"]
    assert seg.feed(Rows(times[40:50], times[40:50, None])) == []  # up to 0.49 s
    (end,) = seg.feed(Rows(times[50:], times[50:, None]))
    assert end.kind == "end" and end.time == 0.5
    assert_array_equal(end.movement.times, times[20:51])


def test_a_movement_begun_after_the_last_row_starts_empty() -> None:
    seg = Segmenter("call", 1)
    seg.begin(5.0)
    (start,) = seg.feed(Rows(np.arange(3) * 0.01, np.zeros((3, 1))))
    assert start.time == 5.0 and len(seg.movement) == 0 and math.isnan(seg.movement.start)
    (end,) = seg.abort("input 'hand' broke off")
    assert end.time == 0.02 and len(end.movement) == 0
    empty = Segmenter("call", 1)
    empty.begin(1.0)
    empty.feed(None)
    (end,) = empty.abort("input 'hand' broke off")  # no row ever: it ends at no time
    assert end.time == math.inf and len(end.movement) == 0


def test_a_movement_ends_once_it_is_longer_than_the_longest_allowed() -> None:
    times = np.arange(40) * 0.25
    seg = Segmenter("call", 1, max_movement_s=3.0)
    seg.begin(0.0)
    assert [b.kind for b in seg.feed(Rows(times[:13], times[:13, None]))] == ["start"]  # 3 s
    (end,) = seg.feed(Rows(times[13:14], times[13:14, None]))
    assert end.time == 3.25
    assert_array_equal(end.movement.times, times[:14])
    assert seg.movement is None


def test_rows_before_a_movement_are_kept_for_a_late_marker_within_the_history() -> None:
    times = np.arange(1000) * 0.01  # 10 s
    seg = Segmenter("marker", 1, [(slice(0, 1), "m")])
    fed(seg, times, times[:, None], per=50)
    seg.markers([(5.0, "start top"), (8.0, "start left")])
    out = seg.feed(None)
    assert [(b.kind, b.number) for b in out] == [("start", 1), ("end", 1), ("start", 2)]
    kept = times[-1] - HISTORY_S  # older rows are gone
    assert out[1].movement.times[0] == times[np.searchsorted(times, kept)]
    assert_array_equal(seg.movement.times, times[801:])  # 8.0 s ended the first


def test_an_aborted_still_segmenter_starts_again_from_the_next_rows() -> None:
    times, values = one_motion(400, 100)
    seg = Segmenter("still", 3, HAND)
    assert seg.feed(Rows(times[:50], values[:50])) == []
    assert seg.abort("input 'hand' broke off") == []  # nothing went on
    assert seg.movement is None
    out = fed(seg, times[50:], values[50:])
    assert [(b.kind, b.number) for b in out] == [("start", 1), ("end", 1)]
    assert out[1].movement.times[0] >= times[50]


def test_a_start_ahead_of_the_rows_takes_no_row_before_it() -> None:
    times = np.arange(100) * 0.01
    for start in ("marker", "call"):
        seg = Segmenter(start, 1, [(slice(0, 1), "m")])
        seg.feed(Rows(times[:10], times[:10, None]))  # the rows lag: up to 0.09 s
        if start == "marker":
            seg.markers([(0.5, "start top"), (0.8, "end top")])
        else:
            seg.begin(0.5, "top")
            seg.end(0.8)
        out = seg.feed(None)
        assert [(b.kind, b.time) for b in out] == [("start", 0.5)] and len(seg.movement) == 0
        out = fed(seg, times[10:], times[10:, None])
        assert [(b.kind, b.time) for b in out] == [("end", 0.8)]
        assert_array_equal(out[0].movement.times, times[50:81])


def test_a_call_or_marker_within_the_slack_of_a_row_takes_it() -> None:
    times = np.arange(12) * 0.25  # exact in binary: a row lies exactly at a call's slack
    seg = Segmenter("call", 1)
    seg.begin(0.25 + SLACK_S)
    seg.end(0.75 - SLACK_S)
    out = seg.feed(Rows(times, times[:, None]))
    assert [b.kind for b in out] == ["start", "end"] and out[0].movement is None
    assert_array_equal(out[1].movement.times, [0.25, 0.5, 0.75])
    assert out[1].movement.label == ""  # a call names no class unless told


def test_a_belief_about_another_movement_than_the_one_going_on_changes_nothing() -> None:
    seg = Segmenter("still", 3, HAND, rule=StillRule({"a": 0.8, "b": 5.0}))
    seg.feed(None, Belief(1, "a", 1.0))  # nothing goes on: movement 1 is not under way
    assert seg.allowed_pause() == seg.longest_pause


def test_the_still_rule_after_a_break_starts_from_the_rows_after_it() -> None:
    times, values = one_motion(500, 150)  # moving from 1.5 s
    seg = Segmenter("still", 3, HAND)
    assert seg.feed(Rows(times[:160], values[:160])) == []  # 0.1 s of motion: not yet
    assert seg.abort("input 'hand' broke off") == []
    out = seg.feed(Rows(times[160:], values[160:]))
    assert [(b.kind, b.number) for b in out] == [("start", 1), ("end", 1)]
    assert out[0].time == times[160]  # not 0.1 s before the motion, before the break
    ended = out[1].movement
    assert ended.times[0] == times[160] and len(ended.values) == len(ended)
    assert_array_equal(ended.values, values[160:160 + len(ended)])


def test_a_movement_keeps_its_last_moving_row_when_nothing_is_kept_after() -> None:
    times, values = one_motion(500, 150)
    rule = StillRule(before=0.0, after=0.0)
    seg = Segmenter("still", 3, HAND, rule=rule)
    events = MovingSpans(["m"], [3]).push(times, values, seg.allowed_pause())
    out = seg.feed(Rows(times, values))
    assert out[1].time == events[1].last
    assert out[1].movement.times[-1] == events[1].last
    assert out[0].time == out[1].movement.times[0] == events[0].first


def test_stillness_watches_angles_too() -> None:
    """A head's angles (radians) alone are watched: their turn is a movement."""
    times, values = one_motion(400, 100)
    seg = Segmenter("still", 3, [(slice(0, 3), "rad")])
    out = fed(seg, times, values * 5.0)  # a turn of 1 rad in a second
    assert [(b.kind, b.number) for b in out] == [("start", 1), ("end", 1)]


def test_a_still_movement_broken_off_starts_again_from_the_rows_after_the_break() -> None:
    """An input breaks mid-motion: the movement ends with its rows, the still rule starts
    again, and the motion that goes on after the break is a new movement of its own rows."""
    times, values = one_motion(500, 100)  # moving from 1.0 to 2.0 s
    seg = Segmenter("still", 3, HAND)
    out = fed(seg, times[:150], values[:150])
    assert [b.kind for b in out] == ["start"]
    (end,) = seg.abort("input 'hand' broke off")
    assert end.movement.times[-1] == times[149]
    assert seg.movement is None
    out = fed(seg, times[150:], values[150:])
    assert [(b.kind, b.number) for b in out] == [("start", 2), ("end", 2)]
    again = out[1].movement
    assert again.times[0] >= times[150] and len(again.values) == len(again)
    first = int(np.searchsorted(times, again.times[0]))
    assert_array_equal(again.times, times[first:first + len(again)])
    assert_array_equal(again.values, values[first:first + len(again)])


def test_the_longest_movement_is_measured_from_its_own_start() -> None:
    """On the session's clock (100 s on), a movement of 2 s is not longer than 4 s; one
    begun and made longer than its limit in one feed gives both its start and its end."""
    times = 100.0 + np.arange(200) * 0.01
    seg = Segmenter("call", 1, max_movement_s=4.0)
    seg.begin(100.0)
    assert [b.kind for b in seg.feed(Rows(times, times[:, None]))] == ["start"]
    assert seg.movement is not None and len(seg.movement) == 200
    seg = Segmenter("call", 1, max_movement_s=1.0)
    seg.begin(100.0)
    out = seg.feed(Rows(times, times[:, None]))
    assert [b.kind for b in out] == ["start", "end"] and out[1].reason == "longer than 1 s"


def test_an_end_takes_the_rows_within_its_slack_and_comes_once_a_row_passes_it() -> None:
    """An end at 0.5 s waits while the rows are before 0.5 s + SLACK_S; a row within the slack
    belongs inside; the end comes with the feed whose last row passes it."""
    seg = Segmenter("call", 1)
    seg.begin(0.0)
    times = np.arange(50) * 0.01  # up to 0.49
    seg.feed(Rows(times, times[:, None]))
    seg.end(0.5)
    assert seg.feed(Rows(np.array([0.499]), np.array([[0.499]]))) == []
    within, after = 0.5 + SLACK_S / 2, 0.5 + SLACK_S * 1.5
    (end,) = seg.feed(Rows(np.array([within, after]), np.array([[within], [after]])))
    assert end.kind == "end" and end.movement.times[-1] == within


def test_a_long_stillness_before_and_after_a_movement_keeps_its_rows_and_memory_bounded() -> None:
    """5 s still (more than the history kept), a second of motion, 6 s still: the movement's
    rows start where its start says, and the rows kept stay within the history."""
    times, values = one_motion(1200, 500)
    seg = Segmenter("still", 3, HAND)
    out = fed(seg, times, values)
    assert [(b.kind, b.number) for b in out] == [("start", 1), ("end", 1)]
    ended = out[1].movement
    assert ended.times[0] == out[0].time
    first = int(np.searchsorted(times, ended.times[0]))
    assert_array_equal(ended.values, values[first:first + len(ended)])
    assert seg._times[-1] - seg._times[0] <= seg.history_s + 0.1
