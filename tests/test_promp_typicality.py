"""Typicality means "unlike the others": blind to the sampling rate and to a uniform change of
speed, sensitive to shape and place; a take stopped early is judged on the part it covers.
(Before: the same path 10x slower was "typical (100th pct)", shifted 8 cm "outlier", shifted
*and* slow "100th pct" again, and a normal partial take an outlier.)"""

from __future__ import annotations

import numpy as np
import pytest

from promp.data import Demonstration
from promp.model import Settings
from promp.typicality import typicality

SETTINGS = Settings(n_basis=7, width=1.0, noise_scale=1.5)
HAND = [0, 1, 2]  # x, y, z in the studio's columns


@pytest.fixture(scope="module")
def curved():
    from robots.icub.scenario import generate_scenario

    return generate_scenario(seed=0)["curved"]


def slower(demo: Demonstration, factor: float) -> Demonstration:
    """The same path, ``factor`` times slower, sampled at the same rate."""
    period = demo.sample_period
    times = np.arange(int(round(factor * demo.duration / period)) + 1) * period
    source = demo.times[0] + times / factor
    values = np.column_stack([np.interp(source, demo.times, v) for v in demo.values.T])
    return Demonstration(times, values, demo.columns, "slower")


def denser(demo: Demonstration, factor: int) -> Demonstration:
    times = np.linspace(demo.times[0], demo.times[-1], factor * demo.n_samples)
    values = np.column_stack([np.interp(times, demo.times, v) for v in demo.values.T])
    return Demonstration(times, values, demo.columns, "denser")


def shifted(demo: Demonstration, metres: float) -> Demonstration:
    values = demo.values.copy()
    values[:, HAND[0]] += metres
    return Demonstration(demo.times, values, demo.columns, "shifted")


def score(curved, demo: Demonstration):
    from robots.icub.layout import STUDIO_LAYOUT as LAYOUT

    others = [d for d in curved if d.name != curved[5].name]
    return typicality(demo, others, LAYOUT, SETTINGS)


def test_the_same_path_slower_or_denser_is_as_typical_as_itself(curved) -> None:
    own = score(curved, curved[5])
    assert own.label == "typical"
    for variant in (slower(curved[5], 10.0), denser(curved[5], 10)):
        other = score(curved, variant)
        assert other.label == "typical" and other.percentile == own.percentile
        assert other.score == pytest.approx(own.score, rel=0.05)


def test_a_shifted_path_is_an_outlier_however_slow(curved) -> None:
    away = score(curved, shifted(curved[5], 0.08))
    slow_away = score(curved, slower(shifted(curved[5], 0.08), 10.0))
    for result in (away, slow_away):
        assert result.label == "outlier" and result.percentile == 0.0
    assert slow_away.score == pytest.approx(away.score, rel=0.05)


def test_a_take_stopped_early_is_typical_for_its_part(curved) -> None:
    demo = curved[5]
    k = int(0.6 * demo.n_samples)
    part = Demonstration(demo.times[:k], demo.values[:k], demo.columns, "part")
    result = score(curved, part)
    assert result.label == "typical" and result.coverage == pytest.approx(0.6, abs=0.1)
    wrong_place = score(curved, shifted(part, 0.08))
    assert wrong_place.label == "outlier"


def test_typicality_needs_three_others(curved) -> None:
    from robots.icub.layout import STUDIO_LAYOUT as LAYOUT

    assert typicality(curved[0], curved[1:3], LAYOUT, SETTINGS) is None
