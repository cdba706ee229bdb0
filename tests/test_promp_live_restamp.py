"""A late sender's samples put back at their rate (promp/live/restamp.py): bursts of push-time
stamps re-spread whatever the chunks they arrive in, on-time and faster streams left as they
are, and the time base judging a pause against the stream's rate and recent lateness."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from promp.live.restamp import Respread
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
