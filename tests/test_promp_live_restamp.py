"""A late sender's samples put back at their rate (promp/live/restamp.py): bursts of push-time
stamps re-spread whatever the chunks they arrive in, on-time and faster streams left as they
are, and the time base judging a pause against the stream's rate and recent lateness."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from promp.live.restamp import LATE_WINDOW_S, QUIET_S, RUN_GAPS, Respread
from promp.live.timebase import TimeBase

RATE = 100.0


def late_stamps(true: np.ndarray, pauses, rng, interrupted: bool = False) -> np.ndarray:
    """Push-time stamps of samples taken at ``true`` (s): during each pause ``(start,
    length)`` the sender sleeps, then pushes its backlog microseconds apart; ``interrupted``:
    a few times while it pushes, it is preempted for 1-5 ms (up to half a step at 100 Hz: a
    busy machine's scheduler, as a fresh-clone run with a core kept busy showed)."""
    stamps = true.copy()
    for start, length in pauses:
        late = np.flatnonzero((true >= start) & (true < start + length))
        pushes = 2e-5 * np.arange(late.size)
        if interrupted:  # after the first sample among others: a preemption anywhere
            for at in (1, *rng.integers(1, late.size, 3)):
                pushes[at:] += rng.uniform(1e-3, 5e-3)
        stamps[late] = start + length + pushes
    stamps += rng.uniform(0, 2e-4, true.size)  # the push itself, on time
    return np.maximum.accumulate(stamps + 1e-9 * np.arange(true.size))


def deliveries(spread: Respread, stamps: np.ndarray, rng, poll_s: float = 0.002):
    """The samples, as a session polling every ``poll_s`` gets them (a pull takes what was
    pushed by then, sometimes only part of a burst): per poll, (times, indices)."""
    values = np.arange(stamps.size, dtype=float)[:, None]
    out, i = [], 0
    now = stamps[0]
    while i < stamps.size or now < stamps[-1] + 1.0:
        now += poll_s * rng.uniform(0.5, 1.5)
        j = int(np.searchsorted(stamps, now, side="right"))
        t, v = spread.add(stamps[i:j], values[i:j], now) if j > i else spread.release(now)
        i = j
        out.append((t, v.ravel().astype(int), now))
    return out


def delivered(spread: Respread, stamps: np.ndarray, rng):
    """:func:`deliveries`, joined."""
    out = deliveries(spread, stamps, rng)
    return np.concatenate([t for t, _, _ in out]), np.concatenate([i for _, i, _ in out])


@pytest.mark.parametrize("interrupted", [False, True])
def test_a_late_senders_bursts_are_put_back_at_their_times(interrupted) -> None:
    rng = np.random.default_rng(0)
    true = 50.0 + np.arange(600) / RATE
    pauses = [(51.0, 0.12), (52.37, 0.35), (53.5, 0.2), (54.1, 0.32)]
    stamps = late_stamps(true, pauses, rng, interrupted)
    assert np.diff(stamps).max() > 0.3 and np.diff(stamps).min() < 1e-4
    spread = Respread(RATE)
    times, index = delivered(spread, stamps, rng)
    assert_array_equal(index, np.arange(true.size))  # every sample, once, in order
    assert np.all(np.diff(times) > 0)
    # the pushes' own jitter and order; an interrupted burst's last sample is late by the
    # interruptions (up to 4 x 5 ms), and the burst is put back one step at a time from it
    late = 0.02 if interrupted else 0.0
    assert np.abs(times - true).max() < 1e-3 + late
    assert np.diff(times).max() < 1.5 / RATE + late
    assert 0.3 < spread.lateness(stamps[-1]) < 0.36
    assert spread.lateness(stamps[-1] + 20.0) == 0.0  # forgotten after LATE_WINDOW_S


def test_on_time_faster_and_irregular_streams_are_left_as_they_are() -> None:
    rng = np.random.default_rng(1)
    for rate, step in ((RATE, 1 / RATE), (RATE, 0.4 / RATE), (0.0, 1 / RATE)):
        stamps = 10.0 + np.cumsum(step * rng.uniform(0.9, 1.1, 400))
        times, index = delivered(Respread(rate), stamps, rng)
        assert_array_equal(times, stamps)
        assert_array_equal(index, np.arange(stamps.size))


def test_a_faster_stream_resumed_after_a_pause_keeps_its_stamps() -> None:
    # takes replayed at 2.5x a declared 100 Hz, a pause between them: the first samples after
    # the pause are the stream's own step apart, not a late sender's burst; so are those of a
    # take at 2.5x after one at the declared rate
    rng = np.random.default_rng(3)
    steps = (0.4 / RATE, 0.4 / RATE, 1.0 / RATE, 0.4 / RATE)
    takes = [t0 + np.cumsum(step * rng.uniform(0.95, 1.05, 300))
             for t0, step in zip((10.0, 12.2, 14.4, 18.2), steps, strict=True)]  # fmt: skip
    stamps = np.concatenate(takes)
    spread = Respread(RATE)
    times, index = delivered(spread, stamps, rng)
    assert_array_equal(times, stamps)
    assert_array_equal(index, np.arange(stamps.size))
    assert spread.lateness(stamps[-1]) == 0.0


@pytest.mark.parametrize("interrupted", [False, True])
def test_a_pause_the_sender_caught_up_is_no_gap_and_one_it_did_not_is(interrupted) -> None:
    rng = np.random.default_rng(2)
    true = 20.0 + np.arange(300) / RATE
    stamps = late_stamps(true, [(21.0, 0.3)], rng, interrupted)
    spread = Respread(RATE)
    base = TimeBase(["hand"], [3])
    said = [base.push("hand", t, np.zeros((t.size, 3)), ("m",) * 3, RATE, spread.lateness(now))
            for t, _, now in deliveries(spread, stamps, rng) if t.size]  # fmt: skip
    assert not any(said)
    # without re-spreading, the pause in the stamps is a gap at the rate alone
    base = TimeBase(["hand"], [3])
    said = [base.push("hand", stamps[a:a + 7], np.zeros((stamps[a:a + 7].size, 3)), ("m",) * 3,
                      RATE) for a in range(0, stamps.size, 7)]  # fmt: skip
    assert any(said)
    # the same pause without the backlog (samples lost): a gap, judged at the rate
    lost = np.concatenate([true[:100], true[130:]])
    base = TimeBase(["hand"], [3])
    said = [base.push("hand", lost[a:a + 7], np.zeros((lost[a:a + 7].size, 3)), ("m",) * 3,
                      RATE) for a in range(0, lost.size, 7)]  # fmt: skip
    assert sum(bool(s) for s in said) == 1 and "paused 0.310 s" in "".join(said)
    # 0.11 s without samples at 100 Hz is a gap; on a sender late by 0.3 s lately, not
    short = np.concatenate([true[:100], true[111:]])
    for late, expected in ((0.0, 1), (0.3, 0)):
        base = TimeBase(["hand"], [3])
        said = [base.push("hand", short[a:a + 7], np.zeros((short[a:a + 7].size, 3)),
                          ("m",) * 3, RATE, late) for a in range(0, short.size, 7)]  # fmt: skip
        assert sum(bool(s) for s in said) == expected


# ---------------------------------------------------------------------------- one burst by hand


def on_time(spread: Respread, start: float, n: int, step: float = 1 / RATE) -> np.ndarray:
    """``n`` samples from ``start``, ``step`` apart, each added as it comes; those given."""
    times = start + step * np.arange(n)
    given = [spread.add(times[k:k + 1], np.array([[float(k)]]), times[k])[0] for k in range(n)]
    return np.concatenate(given)


def test_a_burst_is_put_back_one_step_before_the_next_its_last_keeping_its_stamp() -> None:
    spread = Respread(RATE)
    assert_array_equal(on_time(spread, 1.0, 30), 1.0 + np.arange(30) / RATE)  # up to 1.29
    burst = 1.5 - 2.0**-16 * np.arange(21)[::-1]  # taken at 1.30 to 1.50, pushed at once
    times, values = spread.add(burst, np.arange(21.0)[:, None], 1.5)
    assert_allclose(times, 1.5 - (20 - np.arange(21)) / RATE, atol=1e-12)
    assert_array_equal(values[:, 0], np.arange(21.0))
    assert spread.lateness(1.5) == pytest.approx(burst[0] - times[0], abs=1e-12)
    assert spread.lateness(1.5 + LATE_WINDOW_S) > 0  # within the window still
    assert spread.lateness(1.5 + LATE_WINDOW_S + 0.01) == 0.0
    spread.reset()
    assert spread.lateness(1.5) == 0.0


def test_a_burst_longer_than_its_pause_is_spread_evenly_after_the_last_sample() -> None:
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)  # up to 1.09
    burst = 1.20 + 1e-5 * np.arange(30)  # 30 samples after a pause that held 10
    times, _ = spread.add(burst, np.zeros((30, 1)), 1.2004)
    even = 1.09 + (burst[-1] - 1.09) * np.arange(1, 31) / 30
    assert_allclose(times, np.maximum(burst[-1] - (29 - np.arange(30)) / RATE, even),
                    atol=1e-12)  # fmt: skip
    assert times[0] > 1.09 and np.all(np.diff(times) > 0)


def test_a_burst_short_of_its_backlog_waits_for_the_rest_then_for_a_quiet_time() -> None:
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)
    part = 1.30 + 1e-5 * np.arange(5)  # 5 of the 21 due
    assert spread.add(part, np.zeros((5, 1)), 1.3001)[0].size == 0  # held, to come whole
    assert spread.release(1.3001 + QUIET_S - 0.001)[0].size == 0  # heard lately: may go on
    rest = 1.33 + 1e-5 * np.arange(16)
    times, _ = spread.add(rest, np.zeros((16, 1)), 1.3302)  # whole now: 21 due, 21 came
    assert times.size == 21
    assert_allclose(times, rest[-1] - (20 - np.arange(21)) / RATE, atol=1e-12)
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)
    spread.add(part, np.zeros((5, 1)), 1.3001)
    times, _ = spread.release(1.3001 + QUIET_S + 0.001)  # nothing for a quiet time: given
    assert_allclose(times, part[-1] - (4 - np.arange(5)) / RATE, atol=1e-12)


def test_a_burst_still_coming_is_given_after_as_long_as_its_pause() -> None:
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)  # up to 1.09: a pause of 0.21 s, then a burst that trickles in
    sizes = []
    for k in range(9):  # pushed microseconds apart, arriving every 0.04 s (a quiet time: 0.05)
        stamp, now = 1.30 + 1e-5 * k, 1.30 + 0.04 * k
        sizes.append(spread.add(np.array([stamp]), np.zeros((1, 1)), now)[0].size)
    # held from 1.30 for the pause and a quiet time (0.26 s): given at 1.58, with the 8 so far
    assert sizes == [0] * 7 + [8, 1]


def test_samples_resumed_at_the_rate_after_a_pause_are_given_at_once() -> None:
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)
    resumed = 1.30 + np.arange(3) / RATE  # three, a step apart: the sender resumed on time
    assert spread.add(resumed[:1], np.zeros((1, 1)), 1.3)[0].size == 0  # one alone: may be a burst
    assert spread.add(resumed[1:2], np.zeros((1, 1)), 1.31)[0].size == 0
    times, _ = spread.add(resumed[2:], np.zeros((1, 1)), 1.32)
    assert_array_equal(times, resumed)
    assert spread.lateness(1.32) == 0.0


def test_the_step_is_the_declared_one_unless_the_stream_runs_clearly_faster() -> None:
    assert Respread(0.0).step == 0.0 and Respread(-5.0).step == 0.0
    assert Respread(RATE).step == 1 / RATE
    fast = Respread(RATE)
    on_time(fast, 1.0, RUN_GAPS, 0.005)  # 31 steps given: not yet judged
    assert fast.step == 1 / RATE
    on_time(fast, 1.0 + RUN_GAPS * 0.005, 1, 0.005)
    assert fast.step == pytest.approx(0.005)
    jitter = Respread(RATE)
    on_time(jitter, 1.0, RUN_GAPS + 1, 0.8 / RATE)  # over 3/4 of the step: its own rate
    assert jitter.step == 1 / RATE


def test_an_irregular_stream_is_given_as_it_comes_even_in_bursts() -> None:
    spread = Respread(0.0)
    times = np.array([1.0, 1.5, 1.50001, 1.50002])
    got, values = spread.add(times, np.ones((4, 2)), 1.6)
    assert_array_equal(got, times)
    assert values.shape == (4, 2)
    assert spread.release(2.0)[0].size == 0 and spread.lateness(2.0) == 0.0


def test_a_burst_of_two_after_a_sample_of_the_same_batch_is_put_back_after_that_sample() -> None:
    """The shortest burst (two samples pushed together after a pause), behind an on-time
    sample of the same pull: re-spread one step before its last, after that sample."""
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)  # up to 1.09
    pushed = np.array([1.10, 1.125, 1.125 + 1e-5])  # on time, then 2.5 steps, then two at once
    times, values = spread.add(pushed, np.arange(3.0)[:, None], 1.12502)
    assert_allclose(times, [1.10, 1.125 + 1e-5 - 1 / RATE, 1.125 + 1e-5], atol=1e-12)
    assert_array_equal(values[:, 0], [0.0, 1.0, 2.0])


def test_nothing_arrived_or_held_gives_nothing_of_the_streams_width() -> None:
    fresh = Respread(RATE)
    for times, values in (fresh.add(np.zeros(0), np.zeros((0, 3)), 1.0), fresh.release(1.0)):
        assert times.shape == (0,) and values.shape[0] == 0
    on_time(fresh, 1.0, 5)
    times, values = fresh.release(1.2)  # everything given already
    assert times.shape == (0,) and values.shape == (0, 1)


def test_the_step_follows_the_latest_steps_when_a_stream_speeds_up_later() -> None:
    """The stream is judged on its latest RUN_GAPS steps, again at every sample: one that ran
    at its declared rate, then clearly faster, runs at the faster step."""
    spread = Respread(RATE)
    end = on_time(spread, 1.0, RUN_GAPS + 8)[-1]  # at the declared rate: judged, not faster
    assert spread.step == 1 / RATE
    on_time(spread, end + 0.004, RUN_GAPS + 1, 0.004)
    assert spread.step == pytest.approx(0.004)


def test_back_to_back_bursts_in_one_pull_are_each_put_back() -> None:
    """Two bursts in one pull: right after each other (the second's pause starts at the
    first's end), or after a burst whose push was preempted for over two steps (a pause
    within it), each re-spread one step apart up to its last stamp."""
    for first, second in (
        (1.20 + 1e-5 * np.arange(11), 1.45 + 1e-5 * np.arange(25)),  # 11, then 25 due
        (np.concatenate([1.40 + 1e-5 * np.arange(6), 1.425 + 1e-5 * np.arange(6, 31)]),
         1.70 + 1e-5 * np.arange(27)),  # 31 with a 25 ms hole, then 27
    ):
        spread = Respread(RATE)
        on_time(spread, 1.0, 10)  # up to 1.09
        pushed = np.concatenate([first, second])
        times, values = spread.add(pushed, np.arange(pushed.size, dtype=float)[:, None],
                                   pushed[-1] + 1e-5)  # fmt: skip
        want = [burst[-1] - (burst.size - 1 - np.arange(burst.size)) / RATE
                for burst in (first, second)]  # fmt: skip
        assert_allclose(times, np.concatenate(want), atol=1e-12)
        assert_array_equal(values[:, 0], np.arange(pushed.size))


def test_a_slow_streams_quiet_time_is_two_of_its_steps() -> None:
    """At 25 Hz a burst short of its backlog is held while something came within two steps
    (0.08 s, longer than QUIET_S), then given."""
    slow = Respread(25.0)
    on_time(slow, 1.0, 10, 0.04)  # up to 1.36
    part = 1.80 + 1e-5 * np.arange(3)  # 3 of the 11 due after a 0.44 s pause
    assert slow.add(part, np.zeros((3, 1)), 1.8001)[0].size == 0
    assert slow.release(1.8001 + QUIET_S + 0.02)[0].size == 0  # under two steps: may go on
    assert slow.release(1.8001 + 0.1)[0].size == 3  # two steps quiet: given


def test_a_burst_one_short_of_its_backlog_waits_for_its_last_sample() -> None:
    """11 samples were due during a pause of 11 steps: 10 of them are held, and the 11th
    brings the burst whole, re-spread one step apart."""
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)  # up to 1.09
    burst = 1.20 + 1e-5 * np.arange(11)
    assert spread.add(burst[:10], np.zeros((10, 1)), 1.2001)[0].size == 0
    times, _ = spread.add(burst[10:], np.zeros((1, 1)), 1.2002)
    assert_allclose(times, burst[-1] - (10 - np.arange(11)) / RATE, atol=1e-12)


def test_samples_after_a_pause_at_half_the_rate_apart_are_held_as_a_backlog_may_be() -> None:
    """Three samples half a step apart after a pause are not at the rate (their steps under
    three quarters of a step): they may be the start of a backlog, and are held."""
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)  # up to 1.09
    after = 1.20 + 0.005 * np.arange(3)
    assert spread.add(after, np.zeros((3, 1)), 1.2101)[0].size == 0


def test_a_burst_that_fits_after_the_last_sample_keeps_its_steps_and_one_that_does_not_is_even(
        ) -> None:  # fmt: skip
    """A pause of 9.5 steps before a burst of 10: the burst, one step apart up to its last
    stamp, starts after the last sample given, and is kept so. A pause of 2.5 steps before a
    burst of 4: one step apart, its first would be before the last sample given: the burst is
    spread evenly after it."""
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)  # up to 1.09
    burst = 1.185 + 1e-5 * np.arange(10)
    times, _ = spread.add(burst, np.zeros((10, 1)), 1.1851)
    assert_allclose(times, burst[-1] - (9 - np.arange(10)) / RATE, atol=1e-12)
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)
    burst = 1.115 + 1e-5 * np.arange(4)
    times, _ = spread.add(burst, np.zeros((4, 1)), 1.1151)
    assert_allclose(times, 1.09 + (burst[-1] - 1.09) * np.arange(1, 5) / 4, atol=1e-12)
    assert times[0] > 1.09 and np.all(np.diff(times) > 0)


def test_a_burst_behind_an_on_time_sample_of_its_pull_is_spread_after_that_sample() -> None:
    """An on-time sample, then a pause of 2.5 steps and a burst of 4, in one pull: one step
    apart, the burst's first would be before that sample: it is spread evenly after it (not
    after the sample given before the pull)."""
    spread = Respread(RATE)
    on_time(spread, 1.0, 10)  # up to 1.09
    pushed = np.concatenate([[1.10], 1.125 + 1e-5 * np.arange(4)])
    times, _ = spread.add(pushed, np.zeros((5, 1)), 1.1251)
    assert times[0] == 1.10
    assert_allclose(times[1:], 1.10 + (pushed[-1] - 1.10) * np.arange(1, 5) / 4, atol=1e-12)
    assert np.all(np.diff(times) > 0)
