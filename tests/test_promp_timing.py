"""promp.timing: the one convention of alpha, durations and phases (alpha = s_bar / n, a
movement of n samples lasting (n - 1) dt), the samples seen at a percentage, and the refusals
of what has no meaning (a speed that is not positive and finite, a duration that is not, a
percentage outside (0, 100])."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.timing import (
    alpha_from_duration,
    check_alpha,
    demo_phases,
    duration_from_alpha,
    n_observed_for,
    n_samples_from_alpha,
    phases,
)


@pytest.mark.parametrize("alpha", [1.0, 1e-6, np.array([0.5, 2.0, 3e3])])
def test_a_positive_finite_speed_is_accepted(alpha) -> None:
    check_alpha(alpha)


@pytest.mark.parametrize("alpha", [
    0.0, -1.0, math.nan, math.inf, -math.inf, np.array([1.0, 0.0]), np.array([1.0, -2.0]),
    np.array([1.0, math.nan]), np.array([math.inf, 1.0]),
])  # fmt: skip
def test_a_speed_not_positive_and_finite_is_refused(alpha) -> None:
    with pytest.raises(ValueError):
        check_alpha(alpha)


def test_alpha_is_the_reference_length_over_the_samples() -> None:
    # 0.99 s at 100 Hz: 100 samples; s_bar 100 makes alpha 1, s_bar 50 one half
    assert alpha_from_duration(0.99, 0.01, 100.0) == pytest.approx(1.0, rel=1e-12)
    assert alpha_from_duration(1.99, 0.01, 50.0) == pytest.approx(0.25, rel=1e-12)
    assert alpha_from_duration(0.0, 0.01, 100.0) == pytest.approx(100.0, rel=1e-12)  # 1 sample
    assert type(alpha_from_duration(3, 1, 8)) is float  # 8 / 4 = 2.0, a float either way


def test_samples_and_duration_follow_from_alpha() -> None:
    alphas = np.array([0.5, 1.0, 4.0])
    assert_allclose(n_samples_from_alpha(alphas, 100.0), [200.0, 100.0, 25.0], rtol=1e-15)
    assert_allclose(duration_from_alpha(alphas, 0.01, 100.0), [1.99, 0.99, 0.24], rtol=1e-12)
    assert n_samples_from_alpha(3, 6.0) == pytest.approx(2.0, rel=1e-15)  # an int speed too
    assert duration_from_alpha(2.0, 0.5, 10.0) == pytest.approx(2.0, rel=1e-15)
    for duration in (0.0, 0.37, 12.5):  # the two directions agree
        alpha = alpha_from_duration(duration, 0.004, 100.0)
        assert duration_from_alpha(alpha, 0.004, 100.0) == pytest.approx(duration, abs=1e-12)


@pytest.mark.parametrize("alpha", [0.0, -1.0, math.nan, np.array([1.0, 0.0])])
def test_samples_and_duration_refuse_a_bad_speed(alpha) -> None:
    with pytest.raises(ValueError):
        n_samples_from_alpha(alpha, 100.0)
    with pytest.raises(ValueError):
        duration_from_alpha(alpha, 0.01, 100.0)


def test_a_phase_is_the_time_over_the_duration() -> None:
    assert_allclose(phases([0, 1, 3], 4.0), [0.0, 0.25, 0.75], rtol=0)
    assert_allclose(phases(np.array([0, 1, 2]), 2), [0.0, 0.5, 1.0], rtol=0)  # ints
    assert phases([5.0], 2.0)[0] == 2.5  # past the end: a phase above 1, not clipped
    assert_allclose(phases([0.1, 0.25], 0.5), [0.2, 0.5], rtol=1e-15)  # a short movement


def test_single_precision_input_is_computed_in_double() -> None:
    """Samples counted, phases and a demonstration's phases are float64 whatever the input's
    precision (a float32 recording or speed is not divided in float32)."""
    alpha = np.array([0.3, 0.7], dtype=np.float32)
    samples = n_samples_from_alpha(alpha, 100.0)
    assert samples.dtype == np.float64
    assert_allclose(samples, 100.0 / alpha.astype(float), rtol=1e-15)
    elapsed = np.array([0.1, 0.3], dtype=np.float32)
    assert phases(elapsed, 0.7).dtype == np.float64
    assert_allclose(phases(elapsed, 0.7), elapsed.astype(float) / 0.7, rtol=1e-15)
    times = np.array([1.0, 1.1, 2.3], dtype=np.float32)
    assert demo_phases(times).dtype == np.float64
    assert_allclose(demo_phases(times), (times.astype(float) - 1.0) / 1.2999999523162842,
                    rtol=1e-15)  # fmt: skip


@pytest.mark.parametrize("duration", [0.0, -1.0, math.nan, math.inf, -math.inf])
def test_a_phase_needs_a_positive_finite_duration(duration) -> None:
    with pytest.raises(ValueError):
        phases([0.0, 1.0], duration)


def test_a_demonstrations_phases_run_from_0_to_1() -> None:
    assert_allclose(demo_phases([2, 3, 4, 6]), [0.0, 0.25, 0.5, 1.0], rtol=0)
    assert_allclose(demo_phases(np.array([10.0, 10.5, 12.0])), [0.0, 0.25, 1.0], rtol=0)


@pytest.mark.parametrize(("percent", "n", "seen"), [
    (100, 147, 147), (90, 147, 133), (50, 100, 50), (40, 101, 41), (1, 50, 1), (0.01, 10, 1),
    (100.0, 1, 1), (30, 10, 3), (70, 10, 7), (2.5, 200, 5),
])  # fmt: skip
def test_the_samples_seen_at_a_percentage(percent, n, seen) -> None:
    """ceil(p / 100 n), exact where p / 100 n is a whole number (30 % of 10 is 3, not 4 by
    the round-off of 0.3 * 10), at least one sample."""
    assert n_observed_for(percent, n) == seen


@pytest.mark.parametrize(("percent", "n"), [
    (0, 10), (-5, 10), (100.001, 10), (math.nan, 10), (math.inf, 10), (50, 0), (50, -3),
])  # fmt: skip
def test_a_percentage_outside_0_to_100_or_no_samples_is_refused(percent, n) -> None:
    with pytest.raises(ValueError):
        n_observed_for(percent, n)
