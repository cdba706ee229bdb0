"""The live segmenter: a movement's start and end from stillness, a marker stream or calls;
each movement its own rows."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from promp.live.segmenter import Segmenter
from promp.live.timebase import Rows
from promp.stillness import MARGIN_S, MIN_STILL_S, moving_spans
from tests.live_fakes import flt_dataset, held

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
