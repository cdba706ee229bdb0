"""A take before it becomes a demonstration (no browser): the still time at both ends trimmed by
hand and head speed, and where a primitive's demonstrations start. The recording in a real
browser is in tests/test_teach_tab.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.live.takes import MARGIN_S, active_span, mean_start, speed
from promp.data import Demonstration
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT

RATE = 50.0


def take(still_before: float, moving: float, still_after: float, seed: int = 0):
    """A hand that waits, moves 20 cm up with minimum-jerk timing, and waits again, with
    0.2 mm of sensor noise; a head that follows it."""
    rng = np.random.default_rng(seed)
    times = np.arange(0.0, still_before + moving + still_after, 1.0 / RATE)
    s = np.clip((times - still_before) / moving, 0.0, 1.0)
    z = 0.2 * (10 * s**3 - 15 * s**4 + 6 * s**5)
    hand = np.column_stack([np.full_like(z, -0.27), np.full_like(z, -0.1), z])
    hand += rng.normal(scale=2e-4, size=hand.shape)
    head = np.column_stack([np.zeros_like(z), 0.3 - z, np.zeros_like(z)])
    return times, hand, head


def test_speed_is_the_smoothed_norm_of_the_derivative() -> None:
    times = np.arange(0.0, 2.0, 0.02)
    values = np.column_stack([0.03 * times, 0.04 * times])  # 5 cm/s
    np.testing.assert_allclose(speed(times, values), 0.05, rtol=1e-9)
    assert speed(times[:1], values[:1]).shape == (1,)


def test_the_still_ends_are_trimmed_and_the_movement_kept() -> None:
    times, hand, head = take(1.5, 2.0, 2.5)
    trim = active_span(times, hand, head)
    assert trim is not None and trim.trimmed and trim.n == times.size
    before, after = trim.seconds(times)
    # Minimum-jerk motion is slow at its ends: the cut lands a little inside the movement,
    # less the margin kept.
    assert 1.2 <= before <= 1.5 + MARGIN_S and 2.2 <= after <= 2.5 + MARGIN_S
    kept = hand[trim.start : trim.stop, 2]
    assert kept[0] < 0.01 and kept[-1] > 0.19  # the whole rise is in


def test_a_take_without_still_ends_is_kept_and_a_still_one_is_none() -> None:
    times, hand, head = take(0.0, 2.0, 0.0)
    trim = active_span(times, hand, head)
    # At most the slowest tenth of a second of the minimum-jerk ends goes.
    assert trim is not None and trim.start <= 0.1 * RATE and trim.stop >= times.size - 0.1 * RATE
    still_times = np.arange(0.0, 3.0, 0.02)
    still = np.tile([-0.27, -0.1, 0.0], (still_times.size, 1))
    noisy = still + np.random.default_rng(1).normal(scale=2e-4, size=still.shape)
    assert active_span(still_times, noisy, np.zeros_like(still)) is None


def test_the_head_moving_alone_counts_as_motion() -> None:
    """The gaze leads the hand: a partner who turns to the bin before the hand moves has
    started the movement."""
    times, hand, head = take(2.0, 2.0, 1.0)
    turn = np.clip((times - 1.0) / 0.5, 0.0, 1.0) * math.radians(20)  # 40 deg/s at 1-1.5 s
    head = head.copy()
    head[:, 2] = turn
    with_head = active_span(times, hand, head)
    hand_only = active_span(times, hand, None)
    assert with_head.start < hand_only.start
    assert times[with_head.start] == pytest.approx(1.0 - MARGIN_S, abs=0.1)
    # A higher head threshold ignores the turn.
    ignored = active_span(times, hand, head, head_threshold=math.radians(60))
    assert ignored.start == hand_only.start


def test_bad_takes_and_thresholds_are_refused() -> None:
    times, hand, head = take(0.5, 1.0, 0.5)
    with pytest.raises(ValueError, match="no speed"):
        active_span(times[:1], hand[:1])
    with pytest.raises(ValueError, match="threshold must be positive"):
        active_span(times, hand, head, hand_threshold=0.0)
    with pytest.raises(ValueError, match="threshold must be positive"):
        active_span(times, hand, head, head_threshold=float("nan"))
    with pytest.raises(ValueError, match="samples for"):
        active_span(times, hand[:-1])


def test_mean_start_is_where_the_demonstrations_begin() -> None:
    demos = []
    for k in range(3):
        times, hand, head = take(0.0, 1.0, 0.0, seed=k)
        hand = hand + [0.01 * k, 0.0, 0.0]
        demos.append(Demonstration(times, np.column_stack([hand, head]), LAYOUT.columns))
    np.testing.assert_allclose(
        mean_start(demos, LAYOUT), np.mean([d.values[0, :3] for d in demos], axis=0)
    )
    assert mean_start([], LAYOUT) is None
