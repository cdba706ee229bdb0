"""The live time base: samples of inputs at different rates put on one clock as they arrive,
equal to the XDF reader's :func:`promp.rigs.streams.on_one_clock` over the whole recording."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose, assert_array_equal

from promp.live.timebase import TimeBase
from promp.rigs.streams import Stream, on_one_clock


def chunks(rng, n):
    """Random chunk boundaries over n samples (1 to 12 samples each)."""
    edges = np.cumsum(rng.integers(1, 13, size=n))
    return [0, *edges[edges < n].tolist(), n]


def feed(base: TimeBase, streams, rng):
    """Push the streams' samples in random chunks, interleaved by time; all rows given."""
    cursors = [chunks(rng, s.times.size) for s in streams]
    k = [0] * len(streams)
    rows, gaps = [], []
    while any(k[i] < len(cursors[i]) - 1 for i in range(len(streams))):
        i = int(rng.integers(len(streams)))
        if k[i] >= len(cursors[i]) - 1:
            continue
        a, b = cursors[i][k[i]], cursors[i][k[i] + 1]
        k[i] += 1
        s = streams[i]
        gaps.append(base.push(s.name, s.times[a:b], s.values[a:b], s.units))
        out = base.advance({"hand": 100.0, "device": 40.0, "head": 40.0})
        if out is not None:
            rows.append(out)
    times = np.concatenate([r.times for r in rows])
    return times, np.concatenate([r.values for r in rows]), gaps


def test_one_input_gives_its_samples_exactly_whatever_the_chunks() -> None:
    rng = np.random.default_rng(0)
    t = 500.0 + np.cumsum(rng.uniform(0.009, 0.011, 300))
    v = rng.normal(size=(300, 3))
    base = TimeBase(["hand"], [3])
    times, values, gaps = feed(base, [Stream("hand", t, v, ("m",) * 3)], rng)
    assert_array_equal(times, t)  # the first row waits for a second one, given with it
    assert_array_equal(values, v)
    assert not any(gaps)


def test_two_rates_equal_the_xdf_readers_clock_over_the_whole_recording() -> None:
    rng = np.random.default_rng(1)
    t_hand = 100.0 + np.arange(250) * 0.01
    t_head = 100.003 + np.arange(100) * 0.025  # slower: the time base
    hand = np.column_stack([np.sin(t_hand), np.cos(t_hand), t_hand % 1])
    head = np.column_stack([np.angle(np.exp(1j * 3 * t_head)), 0.1 * t_head, -t_head])  # wraps
    streams = [Stream("hand", t_hand, hand, ("m",) * 3), Stream("head", t_head, head, ("rad",) * 3)]
    base = TimeBase(["hand", "head"], [3, 3])
    times, values, _ = feed(base, streams, rng)
    ref_times, ref_values = on_one_clock(streams, 100.0, 102.49, None, "whole")
    ref = np.hstack(ref_values)
    start = int(np.searchsorted(ref_times, times[0]))
    assert base.base == 1
    assert_array_equal(times, ref_times[start:start + times.size])
    assert_allclose(values, ref[start:start + times.size], rtol=0, atol=1e-12)
    assert times.size >= ref_times.size - 3  # only the last rows wait for the faster input


def test_a_regular_grid_is_at_multiples_of_its_rate() -> None:
    rng = np.random.default_rng(2)
    t = 20.0 + np.arange(300) * 0.01 + rng.uniform(0, 0.002, 300)
    v = np.column_stack([t, 2 * t, 3 * t])
    base = TimeBase(["hand"], [3], rate=50.0)
    times, values, _ = feed(base, [Stream("hand", t, v, ("m",) * 3)], rng)
    assert_allclose(times * 50.0, np.round(times * 50.0), atol=1e-6)
    assert np.all(np.diff(times) > 0.019)
    assert_allclose(values, np.column_stack([times, 2 * times, 3 * times]), atol=1e-9)


def test_a_lagging_input_holds_the_rows_back_never_extrapolated() -> None:
    base = TimeBase(["hand", "head"], [1, 1])
    base.push("hand", np.arange(10) * 0.1, np.arange(10.0)[:, None], ("m",))
    base.push("head", np.arange(3) * 0.25, np.zeros((3, 1)), ("rad",))
    rows = base.advance({"hand": 10.0, "head": 4.0})
    assert rows is not None and rows.times[-1] <= 0.5
    assert base.advance({"hand": 10.0, "head": 4.0}) is None
    base.push("head", np.array([0.75]), np.zeros((1, 1)), ("rad",))
    assert_array_equal(base.advance().times, [0.75])


def test_a_gap_is_said_and_no_row_lies_inside_it() -> None:
    base = TimeBase(["hand"], [1])
    t = np.arange(50) * 0.01
    assert base.push("hand", t, t[:, None], ("m",)) == ""
    first = base.advance()
    message = base.push("hand", 2.0 + t, (2.0 + t)[:, None], ("m",))
    assert "paused" in message and "'hand'" in message
    later = base.advance()
    assert first.times[-1] < 0.5 and later.times[0] >= 2.0
