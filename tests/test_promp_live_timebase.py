"""The live time base: samples of inputs at different rates put on one clock as they arrive,
equal to the XDF reader's :func:`promp.rigs.streams.on_one_clock` over the whole recording."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from promp.live.timebase import KEEP_S, TimeBase
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


def test_a_rate_must_be_a_positive_finite_number_of_hz() -> None:
    for bad in (0.0, -50.0, math.inf, math.nan):
        with pytest.raises(ValueError):
            TimeBase(["hand"], [3], rate=bad)
    assert TimeBase(["hand"], [3], rate=0.5).rate == 0.5
    with pytest.raises(ValueError):
        TimeBase(["hand", "head"], [3])  # a width for each input


def test_the_base_is_the_lowest_declared_rate_else_the_longest_step() -> None:
    base = TimeBase(["hand", "head"], [1, 1])
    base.push("hand", np.arange(10) * 0.01, np.zeros((10, 1)), ("m",))  # steps 0.01 s
    base.push("head", np.arange(10) * 0.1, np.zeros((10, 1)), ("rad",))  # steps 0.1 s
    base.choose_base({"hand": 0.5, "head": 200.0})  # declared: hand is the slower
    assert base.base == 0
    base.choose_base({"hand": 0.5})  # one rate unknown: the steps decide
    assert base.base == 1
    base.choose_base({})
    assert base.base == 1


def test_an_angle_is_interpolated_through_its_unwrapped_path() -> None:
    base = TimeBase(["head", "hand"], [1, 1])
    base.push("head", np.array([0.0, 0.01, 0.02, 0.03]), np.array([[3.0], [3.1], [-3.1], [-3.0]]),
              ("rad",))
    base.push("hand", np.array([0.0, 0.015, 0.03]), np.zeros((3, 1)), ("m",))
    rows = base.advance({"head": 100.0, "hand": 10.0})
    assert_allclose(rows.times, [0.0, 0.015, 0.03])
    # halfway between 3.1 and -3.1 rad the head crossed pi, not 0
    assert_allclose(np.abs(rows.values[1, 0]), np.pi, atol=0.05)


def test_a_pause_beyond_ten_steps_and_the_recent_lateness_is_a_gap() -> None:
    t = np.arange(20) * 0.01

    def after(pause, late=None, rate=0.0):
        base = TimeBase(["hand"], [1])
        base.push("hand", t, t[:, None], ("m",), rate=rate)
        more = t[-1] + pause + np.arange(3) * 0.01
        if late is None:
            return base.push("hand", more, more[:, None], ("m",), rate=rate)
        return base.push("hand", more, more[:, None], ("m",), rate=rate, late=late)

    assert after(0.3) and not after(0.05)  # ten steps of 0.01 s: 0.1 s
    assert not after(0.3, late=0.25) and after(0.3, late=0.1)
    assert after(0.3, late=-1.0)  # a negative lateness is none
    # a declared rate sets the step: 0.15 s is a gap at 100 Hz, not at 50 Hz
    assert after(0.15, rate=100.0) and not after(0.15, rate=50.0)


def test_a_declared_rate_is_the_step_even_when_the_samples_disagree() -> None:
    base = TimeBase(["hand"], [1])
    t = np.array([0.0, 0.1, 0.2])  # 10 Hz so far
    base.push("hand", t, t[:, None], ("m",), rate=1.0)
    assert base.push("hand", np.array([1.5]), np.array([[1.5]]), ("m",), rate=1.0) == ""
    base = TimeBase(["hand"], [1])
    base.push("hand", t, t[:, None], ("m",), rate=100.0)
    assert base.push("hand", np.array([0.5]), np.array([[0.5]]), ("m",), rate=100.0)


def test_a_gap_among_the_first_samples_or_after_two_is_said() -> None:
    base = TimeBase(["hand"], [1])
    t = np.array([0.0, 1.0, 1.01, 1.02])
    assert base.push("hand", t, t[:, None], ("m",), rate=100.0)
    base = TimeBase(["hand"], [1])
    base.push("hand", np.array([0.0, 0.01]), np.zeros((2, 1)), ("m",), rate=100.0)
    assert base.push("hand", np.array([1.0]), np.zeros((1, 1)), ("m",), rate=100.0)
    for first in (np.array([0.0]), np.array([0.0, 1.0])):  # two samples alone, at a rate
        base = TimeBase(["hand"], [1])
        said = [base.push("hand", first, np.zeros((first.size, 1)), ("m",), rate=100.0)]
        if first.size == 1:
            said.append(base.push("hand", np.array([1.0]), np.zeros((1, 1)), ("m",), 100.0))
        assert said[-1]
    base = TimeBase(["hand"], [1])  # without a rate, two samples are no gap: their step
    assert base.push("hand", np.array([0.0, 1.0]), np.zeros((2, 1)), ("m",)) == ""


def test_after_a_gap_the_rows_are_exactly_the_samples_after_it() -> None:
    base = TimeBase(["hand"], [1])
    t = np.arange(50) * 0.01
    base.push("hand", t, t[:, None], ("m",))
    assert_array_equal(base.advance().times, t)
    later = 2.0 + t
    assert base.push("hand", later, later[:, None], ("m",))
    rows = base.advance()
    assert_array_equal(rows.times, later)
    assert_array_equal(rows.values[:, 0], later)


def test_a_restarted_input_forgets_its_samples() -> None:
    base = TimeBase(["hand", "head"], [2, 1])
    base.push("hand", np.arange(5) * 0.1, np.ones((5, 2)), ("m", "m"))
    base.push("head", np.arange(5) * 0.1, np.ones((5, 1)), ("rad",))
    base.restart("hand")
    assert base.advance({"hand": 10.0, "head": 10.0}) is None  # hand has no sample now
    base.push("hand", 1.0 + np.arange(3) * 0.1, 2 * np.ones((3, 2)), ("m", "m"))
    base.push("head", 0.5 + np.arange(8) * 0.1, np.ones((8, 1)), ("rad",))
    rows = base.advance({"hand": 10.0, "head": 10.0})
    assert rows.times[0] >= 1.0 - 1e-9 and rows.values.shape[1] == 3
    assert_allclose(rows.values[:, :2], 2.0)


def test_a_grid_starts_and_ends_on_its_multiples_and_gives_each_once() -> None:
    base = TimeBase(["hand"], [1], rate=50.0)
    t = 1.0 + np.arange(11) * 0.01  # 1.00 to 1.10: grid times 1.00, 1.02, ..., 1.10
    base.push("hand", t[:6], t[:6, None], ("m",))
    first = base.advance()
    base.push("hand", t[6:], t[6:, None], ("m",))
    second = base.advance()
    times = np.concatenate([first.times, second.times])
    assert_allclose(times, 1.0 + np.arange(6) * 0.02, atol=1e-12)
    assert_allclose(np.concatenate([first.values, second.values])[:, 0], times, atol=1e-12)


def test_the_base_is_chosen_once_every_input_has_two_samples() -> None:
    base = TimeBase(["hand", "head"], [1, 1])
    t = np.arange(30) * 0.01
    base.push("hand", t, t[:, None], ("m",))
    base.push("head", t[:1], t[:1, None], ("rad",))
    assert base.advance() is None and base.base is None
    fast = 0.001 * np.arange(1, 290)  # head is the faster input (steps 1 ms)
    base.push("head", fast, fast[:, None], ("rad",))
    rows = base.advance()
    assert base.base == 0  # hand's steps are the longest
    assert np.all(np.diff(rows.times) > 0.009)


def test_a_grid_row_is_given_as_soon_as_every_input_covers_it() -> None:
    base = TimeBase(["hand"], [1], rate=50.0)
    t = 1.0 + np.arange(13) * 0.01
    base.push("hand", t[:11], t[:11, None], ("m",))
    assert_allclose(base.advance().times, 1.0 + np.arange(6) * 0.02, atol=1e-12)
    base.push("hand", t[11:12], t[11:12, None], ("m",))  # 1.11: no new grid time
    assert base.advance() is None
    base.push("hand", t[12:], t[12:, None], ("m",))  # 1.12: the next one, alone
    assert_allclose(base.advance().times, [1.12], atol=1e-12)


def test_rows_come_once_every_input_has_two_samples_over_a_common_span() -> None:
    base = TimeBase(["hand", "head"], [1, 1])
    t = np.array([0.0, 0.1])
    base.push("hand", t, t[:, None], ("m",))
    base.push("head", t, 2 * t[:, None], ("rad",))
    rows = base.advance()
    assert_allclose(rows.times, t)
    assert_allclose(rows.values, [[0.0, 0.0], [0.1, 0.2]])
    assert base.base == 0


def test_a_pause_let_through_for_a_late_sender_is_interpolated_across() -> None:
    base = TimeBase(["hand", "head"], [1, 1])
    steady = np.arange(101) * 0.01  # the base, 100 Hz, to 1.0 s
    fast = np.arange(41) * 0.01  # 100 Hz to 0.4 s, then 0.3 s without a sample
    after = 0.7 + np.arange(31) * 0.01
    base.push("hand", steady, steady[:, None], ("m",), rate=100.0)
    assert base.push("head", fast, fast[:, None], ("rad",), rate=100.0) == ""
    assert base.push("head", after, after[:, None], ("rad",), rate=100.0, late=0.35) == ""
    rows = base.advance({"hand": 100.0, "head": 100.0})
    assert_allclose(rows.times, steady)
    assert_allclose(rows.values[:, 1], steady)  # inside the pause: from the samples around


def test_an_input_without_units_is_put_on_the_clock() -> None:
    base = TimeBase(["force"], [2])
    t = np.arange(5) * 0.01
    base.push("force", t, np.ones((5, 2)), ())
    rows = base.advance()
    assert_allclose(rows.times, t)
    assert_allclose(rows.values, np.ones((5, 2)))


def test_the_samples_kept_are_those_of_the_last_second_before_the_rows_given() -> None:
    base = TimeBase(["hand", "head"], [1, 1])
    t = np.arange(1000) * 0.01  # 10 s at 100 Hz
    for a in range(0, 1000, 50):
        base.push("hand", t[a:a + 50], t[a:a + 50, None], ("m",))
        base.push("head", t[a:a + 50], t[a:a + 50, None], ("rad",))
        base.advance({"hand": 100.0, "head": 100.0})
    for name in ("hand", "head"):
        kept = base._buffers[name].times
        assert kept[0] == pytest.approx(t[-1] - KEEP_S, abs=0.015) and kept[-1] == t[-1]


def test_a_gap_inside_a_pushed_chunk_keeps_only_the_samples_after_it() -> None:
    """A chunk whose gap is after its first samples: the rows go on from the samples after
    the gap, never across it (the chunk's samples before it are dropped with the old ones)."""
    base = TimeBase(["hand"], [1])
    t = np.arange(50) * 0.01
    base.push("hand", t, t[:, None], ("m",))
    assert_array_equal(base.advance().times, t)
    chunk = np.concatenate([[0.50, 0.51], 2.0 + np.arange(5) * 0.01])
    assert base.push("hand", chunk, chunk[:, None], ("m",))
    rows = base.advance()
    assert_array_equal(rows.times, chunk[2:])
    assert_array_equal(rows.values[:, 0], chunk[2:])


def test_the_base_chosen_by_the_declared_rates_stays_when_the_steps_disagree() -> None:
    """A head that declares 50 Hz but runs at 200 Hz is the base (the lowest declared rate),
    chosen once: the later rows, asked without rates, stay on its times."""
    base = TimeBase(["hand", "head"], [1, 1])
    hand, head = np.arange(30) * 0.01, np.arange(120) * 0.0025
    base.push("hand", hand, hand[:, None], ("m",))
    base.push("head", head, head[:, None], ("rad",))
    base.advance({"hand": 100.0, "head": 50.0})
    assert base.base == 1
    more_hand, more_head = 0.3 + np.arange(10) * 0.01, 0.3 + np.arange(40) * 0.0025
    base.push("hand", more_hand, more_hand[:, None], ("m",))
    base.push("head", more_head, more_head[:, None], ("rad",))
    rows = base.advance()
    assert base.base == 1
    assert_allclose(np.diff(rows.times), 0.0025, atol=1e-12)


def test_an_input_restarted_one_sample_at_the_next_row_waits_for_its_next_sample() -> None:
    """An input restarted whose one new sample is at the next row's time (within the time
    base's 1e-9 of the last row given): nothing to interpolate from yet, so the rows wait
    (before, the XDF reader's clock refused a span of one row: the step failed); with its next
    sample, that row and the next are given, read at its samples."""
    base = TimeBase(["a", "b"], [1, 1])
    t = np.array([4.98, 4.99, 5.0])
    base.push("a", t, np.full((3, 1), 1.0), ("m",))
    base.push("b", t, np.full((3, 1), 2.0), ("m",))
    assert_array_equal(base.advance({"a": 100.0, "b": 100.0}).times, t)
    base.restart("b")
    at = 5.0 + 5e-10
    base.push("a", np.array([at, 5.01]), np.array([[3.0], [4.0]]), ("m",))
    base.push("b", np.array([at]), np.array([[5.0]]), ("m",))
    assert base.advance() is None
    base.push("b", np.array([5.01]), np.array([[6.0]]), ("m",))
    rows = base.advance()
    assert_array_equal(rows.times, [at, 5.01])
    assert_array_equal(rows.values, [[3.0, 5.0], [4.0, 6.0]])


def test_a_restarted_input_s_first_samples_behind_the_others_still_make_rows() -> None:
    """The head restarts; the hand streams on for 0.2 s while the head is silent; the head's
    samples then come from just after the last row: the rows go on from them (the hand's
    samples meanwhile were kept, not cut to its last two while the head had none)."""
    base = TimeBase(["hand", "head"], [1, 1])
    t = np.arange(101) * 0.01  # up to 1.0
    base.push("hand", t, t[:, None], ("m",))
    base.push("head", t, t[:, None], ("rad",))
    assert base.advance({"hand": 100.0, "head": 100.0}).times[-1] == 1.0
    base.restart("head")
    more = 1.0 + np.arange(1, 21) * 0.01  # 1.01 to 1.20
    for k in range(20):
        base.push("hand", more[k:k + 1], more[k:k + 1, None], ("m",))
        assert base.advance() is None  # the head has no sample: no row
    base.push("head", more, more[:, None], ("rad",))
    rows = base.advance()
    assert_allclose(rows.times, more, atol=1e-12)
    assert_allclose(rows.values, np.column_stack([more, more]), atol=1e-12)


def test_the_rows_input_restarted_on_another_phase_waits_for_two_of_its_samples() -> None:
    """The rows' input (the slower, at 25 Hz) restarts on another phase: its samples are no
    longer at the last row's time. One new sample after that row is one sample on the time
    base, which the XDF reader's clock refuses (before, the step raised: found by the live
    session machine); the rows wait for its next sample, then go on from the last row."""
    base = TimeBase(["hand", "head"], [1, 1])
    slow = 1.0 + np.arange(6) * 0.04  # 1.00 to 1.20
    fast = 1.0 + np.arange(25) * 0.01  # 1.00 to 1.24
    base.push("hand", slow, slow[:, None], ("m",))
    base.push("head", fast, fast[:, None], ("rad",))
    assert_allclose(base.advance({"hand": 25.0, "head": 100.0}).times, slow)
    base.restart("hand")
    shifted = np.array([1.18, 1.22])  # the restarted hand, 0.02 s off its old phase
    base.push("hand", shifted, shifted[:, None], ("m",))
    assert base.advance() is None  # one base sample after the row at 1.20: wait
    base.push("hand", np.array([1.26]), np.array([[1.26]]), ("m",))
    base.push("head", np.array([1.25, 1.26]), np.array([[1.25], [1.26]]), ("rad",))
    rows = base.advance()
    assert_allclose(rows.times, [1.22, 1.26], atol=1e-12)
    assert_allclose(rows.values, [[1.22, 1.22], [1.26, 1.26]], atol=1e-12)
