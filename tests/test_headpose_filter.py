"""One-Euro filter: pass-through of constants, bounded lag on steps, noise reduction."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.headpose.filter import OneEuroConfig, OneEuroFilter

FPS = 60.0


def run(filt: OneEuroFilter, signal: np.ndarray) -> np.ndarray:
    return np.array([filt(x, i / FPS) for i, x in enumerate(signal)])


def test_constant_signal_passes_through():
    filt = OneEuroFilter(OneEuroConfig(min_cutoff=0.5, beta=2.0, d_cutoff=1.0))
    signal = np.tile([0.3, -0.2, 1.1], (200, 1))
    assert_allclose(run(filt, signal), signal, atol=1e-12)


def test_step_is_followed_with_bounded_lag_when_beta_is_positive():
    step = np.concatenate([np.zeros(60), np.full(120, 0.8)])  # a 46-degree head turn
    slow = run(OneEuroFilter(OneEuroConfig(min_cutoff=0.5, beta=0.0)), step)
    fast = run(OneEuroFilter(OneEuroConfig(min_cutoff=0.5, beta=4.0)), step)

    def settle_frames(output: np.ndarray) -> int:
        """Frames after the step until the output stays within 10 % of the step."""
        far = np.flatnonzero(np.abs(output[60:] - 0.8) > 0.08)
        return int(far[-1]) + 1 if far.size else 0

    assert settle_frames(fast) <= 12  # 0.2 s at 60 fps
    assert settle_frames(fast) < settle_frames(slow) / 3
    assert np.all(fast <= 0.8 + 1e-9)  # no overshoot
    assert_allclose(fast[-1], 0.8, atol=1e-3)


def test_noise_is_reduced():
    rng = np.random.default_rng(0)
    noise = rng.normal(0.0, np.radians(1.0), size=(600, 3))
    filtered = run(OneEuroFilter(OneEuroConfig(min_cutoff=1.0, beta=0.5)), noise)
    assert np.std(filtered[30:]) < 0.4 * np.std(noise[30:])


def test_reset_forgets_history():
    filt = OneEuroFilter()
    filt(np.array([1.0]), 0.0)
    filt(np.array([1.0]), 0.1)
    filt.reset()
    assert_allclose(filt(np.array([-2.0]), 0.0), [-2.0])


def test_input_is_not_modified():
    filt = OneEuroFilter()
    first = np.array([0.0, 0.0])
    second = np.array([1.0, 1.0])
    filt(first, 0.0)
    out = filt(second, 0.1)
    assert_allclose(second, [1.0, 1.0])
    assert not np.shares_memory(out, second)


def test_bad_input_is_rejected():
    filt = OneEuroFilter()
    filt(np.zeros(3), 1.0)
    with pytest.raises(ValueError, match="timestamps must increase"):
        filt(np.zeros(3), 1.0)
    with pytest.raises(ValueError, match="shape"):
        filt(np.zeros(2), 2.0)
    with pytest.raises(ValueError, match="finite"):
        filt(np.array([np.nan, 0.0, 0.0]), 3.0)
    with pytest.raises(ValueError, match="min_cutoff"):
        OneEuroConfig(min_cutoff=0.0)
    with pytest.raises(ValueError, match="beta"):
        OneEuroConfig(beta=-1.0)
