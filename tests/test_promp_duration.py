"""The duration's posterior: quantiles, the calibrated interval, the oracle, the errors."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from promp import metrics
from promp.duration import choose_temperature, summarise, timing, weighted_quantiles
from promp.evidence.pipeline import infer, log_likelihoods, recognise
from promp.inference import Observation
from promp.io import model_from_dict, model_to_dict
from promp.learn import fit
from promp.model import Settings
from promp.timing import alpha_from_duration, duration_from_alpha
from tests.synthetic import LAYOUT, make_dataset

SMALL = Settings(n_basis=6, width=1.0, noise_scale=1.5)


@pytest.fixture(scope="module")
def dataset():
    return make_dataset(seed=3, n_demos=8)


@pytest.fixture(scope="module")
def model(dataset):
    return fit(dataset, LAYOUT, SMALL)


def test_quantiles_of_a_fine_grid_are_those_of_the_density() -> None:
    x = np.linspace(-6.0, 6.0, 801)
    masses = stats.norm.pdf(x, 0.5, 1.3) * np.gradient(x)
    qs = np.array([0.05, 0.5, 0.95])
    assert_allclose(weighted_quantiles(x, masses, qs), stats.norm.ppf(qs, 0.5, 1.3), atol=2e-3)
    # the order of the nodes does not matter; one node is every quantile
    reversed_ = weighted_quantiles(x[::-1], masses[::-1], qs)
    assert_allclose(reversed_, weighted_quantiles(x, masses, qs))
    assert_allclose(weighted_quantiles(np.array([2.0]), np.array([1.0]), qs), [2.0, 2.0, 2.0])


def test_the_summary_takes_its_point_and_its_interval_from_two_posteriors() -> None:
    x = np.linspace(0.0, 10.0, 201)
    sharp = stats.norm.pdf(x, 3.0, 0.2)
    wide = stats.norm.pdf(x, 5.0, 1.0)
    s = summarise(x, sharp, wide)
    assert s.value == pytest.approx(3.0, abs=0.02)
    assert s.low <= s.value  # stretched to hold the point
    assert s.high == pytest.approx(5.0 + 1.645, abs=0.05)
    assert s.covers(s.value) and not s.covers(9.5)


def _trials(rng: np.random.Generator, claimed: float, actual: float, n: int = 400):
    """Held-out trials whose likelihood claims a spread ``claimed`` around its peak while the
    truth lies ``actual`` away (one batch, 40 nodes each, a flat prior)."""
    nodes = np.tile(np.linspace(-2.0, 2.0, 40), (n, 1))
    truth = rng.normal(0.0, 0.4, n)
    peak = truth + rng.normal(0.0, actual, n)
    log_lik = -0.5 * ((nodes - peak[:, None]) / claimed) ** 2
    log_w = np.log(np.gradient(nodes, axis=1))
    return [(nodes, log_lik, log_w, truth)]


def test_the_temperature_widens_an_overconfident_likelihood_and_not_an_honest_one() -> None:
    rng = np.random.default_rng(1)
    tau, coverage = choose_temperature(_trials(rng, claimed=0.05, actual=0.2))
    # a likelihood 4x too sure: the power 1/16 is what fits (a step of sqrt 2 either way)
    assert 1 / 32 <= tau <= 1 / 8
    assert coverage[1.0] < 0.5 and coverage[tau] >= 361 / 400  # ceil(0.9 * 401) / 400
    # the largest such power: the next one up covers too little
    assert all(coverage[t] < 361 / 400 for t in coverage if t > tau)
    honest, _ = choose_temperature(_trials(rng, claimed=0.2, actual=0.2))
    assert honest >= 0.5
    assert choose_temperature([]) == (1.0, {})


def test_the_chosen_temperature_covers_new_trials_as_often_as_it_claims() -> None:
    """Nested conformal: chosen on 30 held-out trials, the intervals cover fresh ones of the
    same kind at least 90 % of the time on average (over many choices)."""
    rng = np.random.default_rng(2)
    rates = []
    for _ in range(40):
        tau, _ = choose_temperature(_trials(rng, claimed=0.05, actual=0.2, n=30))
        (nodes, log_lik, log_w, truth), = _trials(rng, claimed=0.05, actual=0.2, n=200)
        masses = np.exp(tau * log_lik + log_w)
        bounds = np.array([weighted_quantiles(x, w, np.array([0.05, 0.95]))
                           for x, w in zip(nodes, masses, strict=True)])  # fmt: skip
        rates.append(np.mean((bounds[:, 0] <= truth) & (truth <= bounds[:, 1])))
    assert np.mean(rates) >= 0.88


def test_a_known_duration_scores_every_primitive_at_its_speed(model, dataset) -> None:
    demo = dataset["left"][0]
    obs = Observation.from_demo(model, demo, 20, ("hand",))
    reco = recognise(model, obs, duration=demo.duration)
    alpha = alpha_from_duration(demo.duration, model.sample_period, model.settings.s_bar)
    for k, prim in enumerate(model.primitives):
        assert_allclose(reco.candidates[k], [alpha])
        assert_allclose(reco.log_evidence[k], log_likelihoods(model, prim, obs, [alpha])[0])
    result = infer(model, obs, duration=demo.duration, truth=demo)
    assert result.duration == pytest.approx(demo.duration, rel=1e-9)
    assert result.errors.duration == pytest.approx(0.0, abs=1e-9)
    assert result.errors.duration_covered
    with pytest.raises(ValueError, match="at least the observation"):
        recognise(model, obs, duration=0.5 * float(obs.elapsed[-1]))


def test_the_prediction_is_drawn_at_the_posterior_median_and_measured(model, dataset) -> None:
    demo = dataset["right"][1]
    obs = Observation.from_demo(model, demo, 25, ("hand", "head"))
    result = infer(model, obs, truth=demo)
    t = result.timing
    alphas, masses = result.recognition.speed_posterior()
    durations = duration_from_alpha(alphas, model.sample_period, model.settings.s_bar)
    median = weighted_quantiles(durations, masses, np.array([0.5]))[0]
    assert result.duration == pytest.approx(max(median, result.observed_until), rel=1e-9)
    assert t.duration.low <= result.duration <= t.duration.high
    assert 0.0 <= t.observed_fraction.low <= t.observed_fraction.value <= t.observed_fraction.high
    assert t.remaining_after(result.observed_until).value == pytest.approx(result.remaining)
    # the errors are the evaluation's metrics on the prediction's own samples
    dims = LAYOUT.dims(["hand"])
    truth = LAYOUT.extract(demo)[:, dims]
    natural = result.natural.mean[:, dims]
    assert result.natural.mean.shape[0] == max(int(round(model.settings.s_bar / result.alpha)), 2)
    assert result.errors.position == pytest.approx(
        metrics.remainder_error(truth, natural, obs.n_observed)
    )
    assert result.errors.goal == pytest.approx(metrics.goal_error(truth, natural))
    assert result.errors.duration == pytest.approx(abs(result.duration - demo.duration))
    # the same inference without the truth measures nothing
    assert infer(model, obs).errors is None


def test_a_long_observation_is_not_predicted_to_end_now(model, dataset) -> None:
    """The mode of a long observation can sit on the shortest speed that still contains it;
    the posterior keeps the longer ones: time is left, and the interval says how much."""
    demo = dataset["left"][2]
    obs = Observation.from_demo(model, demo, demo.n_samples - 2, ("hand",))
    result = infer(model, obs)
    assert result.duration >= result.observed_until
    assert result.timing.duration.high > result.observed_until


def test_the_temperature_is_chosen_by_the_fit_kept_or_given_and_saved(dataset) -> None:
    chosen = fit(dataset, LAYOUT, dataclasses.replace(SMALL, duration_temperature=None))
    tau = chosen.settings.duration_temperature
    report = chosen.report["settings"]["duration_temperature"]
    assert report["value"] == tau and 0.0 < tau <= 1.0
    assert report["coverage"][str(tau)] >= 0.9 or tau == min(map(float, report["coverage"]))
    given = fit(dataset, LAYOUT, dataclasses.replace(SMALL, duration_temperature=0.25))
    assert given.settings.duration_temperature == 0.25
    assert "duration_temperature" not in given.report["settings"]
    loaded = model_from_dict(model_to_dict(chosen))
    assert loaded.settings.duration_temperature == tau
    old = model_to_dict(chosen)
    del old["settings"]["duration_temperature"]  # a file written before the calibration
    assert model_from_dict(old).settings.duration_temperature == 1.0
    with pytest.raises(ValueError, match="duration_temperature"):
        Settings(duration_temperature=0.0)
    with pytest.raises(ValueError, match="duration_temperature"):
        Settings(duration_temperature=math.nan)


def test_timing_of_a_single_node_is_that_node(model, dataset) -> None:
    demo = dataset["left"][0]
    obs = Observation.from_demo(model, demo, 10, ("hand",))
    reco = recognise(model, obs, duration=demo.duration)
    t = timing(reco, float(obs.elapsed[-1]), model.sample_period, model.settings.s_bar, 0.1)
    assert t.duration.low == t.duration.value == t.duration.high == pytest.approx(demo.duration)


def test_a_speed_posterior_no_node_explains_is_refused_naming_its_primitive():
    from promp.recognition import speed_masses

    alphas = np.array([0.8, 1.0, 1.25])
    masses = speed_masses(2, alphas, np.array([-1.0, 0.0, -np.inf]), np.zeros(3), 0.5)
    assert masses.sum() == pytest.approx(1.0) and masses[2] == 0.0 and masses[1] > masses[0]
    with pytest.raises(ValueError, match="primitive 2 does not explain the observation"):
        speed_masses(2, alphas, np.full(3, -np.inf), np.zeros(3), 1.0)
