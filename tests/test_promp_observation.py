"""promp.observation: the early part of a movement, taken as the evaluation and the studio take
it (the first p % of a demonstration, or of samples taken as a movement happens)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from promp.learn import fit
from promp.model import Settings
from promp.observation import Observation
from promp.timing import n_observed_for
from tests.synthetic import LAYOUT, make_dataset

SETTINGS = Settings(n_basis=6, width=1.0)


@pytest.fixture(scope="module")
def model_and_demo():
    dataset = make_dataset(seed=5)
    model = fit(dataset, LAYOUT, SETTINGS)
    return model, next(iter(dataset.values()))[0]


@pytest.mark.parametrize("percent", [0.5, 10, 33.3, 40, 99.9, 100])
def test_first_is_the_demonstrations_first_share(model_and_demo, percent) -> None:
    model, demo = model_and_demo
    modalities = LAYOUT.names[:1]
    first = Observation.first(model, demo, percent, modalities)
    n = n_observed_for(percent, demo.n_samples)
    expected = Observation.from_demo(model, demo, n, modalities)
    assert first.n_observed == n
    assert_array_equal(first.times, expected.times)
    assert_array_equal(first.values, expected.values)
    assert first.modalities == expected.modalities


def test_first_refuses_a_share_outside_0_to_100(model_and_demo) -> None:
    model, demo = model_and_demo
    for percent in (0, -5, 100.5, float("nan")):
        with pytest.raises(ValueError, match="observed percentage"):
            Observation.first(model, demo, percent, LAYOUT.names[:1])


def test_first_live_takes_the_share_of_every_sample_then_leaves_the_missed_out() -> None:
    times = 10.0 + 0.1 * np.arange(10)  # a clock that did not start at the movement
    values = np.arange(20.0).reshape(10, 2)
    values[[0, 3, 8], 1] = np.nan  # a sensor that saw nothing then
    live = Observation.first_live(times, values, 50, ("a",))
    # the first 5 samples (of 10, missed ones counted), the missed 0 and 3 left out,
    # the times from the first kept
    assert_array_equal(live.values, values[[1, 2, 4]])
    assert_array_equal(live.times, times[[1, 2, 4]] - times[1])
    assert live.modalities == ("a",)


def test_first_live_without_a_miss_is_first_of_the_same_samples(model_and_demo) -> None:
    model, demo = model_and_demo
    modalities = LAYOUT.names
    values = model.layout.extract(demo)[:, model.layout.dims(modalities)]
    for percent in (20, 70, 100):
        live = Observation.first_live(demo.times - demo.times[0], values, percent, modalities)
        first = Observation.first(model, demo, percent, modalities)
        assert_array_equal(live.values, first.values)
        np.testing.assert_allclose(live.elapsed, first.elapsed, rtol=0, atol=1e-12)


def test_first_live_refuses_nothing_usable() -> None:
    values = np.array([[1.0, np.nan], [2.0, np.nan], [3.0, 4.0]])
    with pytest.raises(ValueError, match="first 2 samples has a value missing"):
        Observation.first_live(np.arange(3.0), values, 50, ("a",))
    with pytest.raises(ValueError, match="at least one sample"):
        Observation.first_live(np.zeros(0), np.zeros((0, 2)), 50, ("a",))
