"""Typicality means "unlike the others": blind to the sampling rate and to a uniform change of
speed, sensitive to shape and place; a take stopped early is judged on the part it covers.
(Before: the same path 10x slower was "typical (100th pct)", shifted 8 cm "outlier", shifted
*and* slow "100th pct" again, and a normal partial take an outlier.)"""

from __future__ import annotations

import numpy as np
import pytest

from promp.data import Demonstration
from promp.model import Settings
from promp.typicality import Typicality, typicalities, typicality

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


def test_a_primitive_scored_at_once_is_scored_as_each_take_would_be(curved) -> None:
    """An import's demonstrations are scored together (one fit per demonstration): each by
    the model of the others, as a take would be, ranked among the others' own such scores;
    one left out of learning (flagged) is scored by the model of all the others and is no
    one's reference."""
    from robots.icub.layout import STUDIO_LAYOUT as LAYOUT

    demos = [*curved[:8], shifted(curved[8], 0.08)]
    learned = [True] * 8 + [False]
    batch = typicalities(demos, LAYOUT, SETTINGS, learned)
    for i in (0, 4):  # a learned one: the take's score against the 7 other learned ones
        alone = typicality(demos[i], [d for j, d in enumerate(demos[:8]) if j != i], LAYOUT,
                           SETTINGS)  # fmt: skip
        assert batch[i].score == pytest.approx(alone.score, rel=1e-9)
        assert batch[i].coverage == alone.coverage
    # the flagged one: exactly what typicality() says of it against the learned ones
    assert batch[8] == typicality(demos[8], demos[:8], LAYOUT, SETTINGS)
    assert batch[8].label == "outlier" and batch[8].percentile == 0.0
    # each learned one ranked among the 7 others: its rank
    assert sorted(t.percentile for t in batch[:8]) == pytest.approx([k / 7 for k in range(8)])
    # learned by everyone, the shifted one drags the references of the others: it is still
    # the least typical of all
    everyone = typicalities(demos, LAYOUT, SETTINGS)
    assert min(range(9), key=lambda i: everyone[i].score) == 8
    assert everyone[8].percentile == 0.0
    # three others at least, as for a take
    assert typicalities(demos[:3], LAYOUT, SETTINGS) == [None] * 3
    assert None not in typicalities(demos[:4], LAYOUT, SETTINGS)
    assert typicalities(demos[:4], LAYOUT, SETTINGS, [True, True, False, False]) == [None] * 4
    assert typicalities(demos[:4], LAYOUT, SETTINGS, [True, True, True, False])[3] is not None


def test_a_typicality_reads_back_from_json_and_refuses_nonsense() -> None:
    given = Typicality(-0.31, 0.64, 0.9)
    assert Typicality.from_json(given.to_json()) == given
    for bad in ({"score": "x", "percentile": 0.5}, {"percentile": 0.5},
                {"score": 0.0, "percentile": 1.5}, {"score": float("nan"), "percentile": 0.5},
                {"score": 0.0, "percentile": 0.5, "coverage": 0}, []):  # fmt: skip
        with pytest.raises(ValueError, match="not a typicality"):
            Typicality.from_json(bad)
