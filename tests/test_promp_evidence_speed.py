"""promp.evidence.speed: the Eq. 7 speed from the early displacement (each observed modality's
regression combined by inverse variance, clipped to the plausible speeds), the columns of a
modality in an observation, a mixture of speed priors and its density, the speed prior of the
training speeds, the quadrature's range, nodes, refined nodes and weights, and logsumexp."""

from __future__ import annotations

import dataclasses
import math
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from promp.data import Layout, Modality
from promp.evidence.speed import (
    N_NODES,
    TAIL,
    AlphaPrior,
    alpha_prior,
    anchored_nodes,
    logsumexp,
    logsumexp_rows,
    longest_alpha,
    modality_columns,
    model_alpha,
    quadrature,
    quadrature_weights,
    refined_nodes,
    speed_prior,
)
from promp.inference import Observation
from promp.learn import fit
from promp.model import Settings
from promp.timing import duration_from_alpha
from tests.synthetic import LAYOUT, make_dataset


class Regression:
    """A modality's Eq. 7 regression that answers ``(alpha, variance)`` and keeps what it was
    asked (the displacement and the samples observed)."""

    def __init__(self, alpha: float, var: float) -> None:
        self.answer, self.asked = (alpha, var), []

    def predict(self, delta: np.ndarray, n_observed: int) -> tuple[float, float]:
        self.asked.append((np.array(delta), n_observed))
        return self.answer


@pytest.fixture(scope="module")
def learned():
    model = fit(make_dataset(seed=3, n_demos=5), LAYOUT, Settings(n_basis=6, width=1.0,
                                                                  noise_scale=1.5))  # fmt: skip
    demo = make_dataset(seed=4, n_demos=3)[model.names[0]][0]
    return model, Observation.from_demo(model, demo, 30, ["hand", "head"])


def with_regressions(primitive, alphas, hand, head):
    """``primitive`` with the training speeds ``alphas`` and the regressions' answers."""
    models = {"hand": Regression(*hand), "head": Regression(*head)}
    return dataclasses.replace(primitive, alphas=np.array(alphas), alpha_models=models,
                               residuals=None)  # (its demonstrations are not these)


def test_the_model_speed_is_each_regressions_estimate_weighted_by_its_precision(learned) -> None:
    model, obs = learned
    primitive = with_regressions(model.primitives[0], [0.8, 1.5], (1.0, 0.01), (2.0, 0.04))
    assert longest_alpha(model, obs) > 3.0  # the clip's top is the training speeds' (2 x 1.5)
    alpha, log_sd = model_alpha(model, primitive, obs)
    assert alpha == pytest.approx((100.0 * 1.0 + 25.0 * 2.0) / 125.0, rel=1e-12)
    assert log_sd == pytest.approx(math.sqrt(1.0 / 125.0) / alpha, rel=1e-12)  # delta method
    n_obs = round(float(obs.elapsed[-1]) / model.sample_period) + 1
    assert n_obs == 30
    for name, cols in (("hand", [0, 1, 2]), ("head", [3, 4, 5])):
        (delta, n), = primitive.alpha_models[name].asked
        assert n == n_obs
        assert_allclose(delta, obs.values[-1, cols] - obs.values[0, cols], rtol=0, atol=0)
    # a regression of no error variance: its estimate alone (the variance floored at 1e-12)
    exact = with_regressions(model.primitives[0], [0.8, 1.5], (1.0, 0.0), (2.0, 0.04))
    alpha, log_sd = model_alpha(model, exact, obs)
    assert alpha == pytest.approx(1.0, rel=1e-9)
    assert log_sd == pytest.approx(1e-6, rel=1e-9)


def test_the_model_speed_is_clipped_to_the_plausible_speeds(learned) -> None:
    """Within half the slowest and twice the fastest training speed, and never faster than
    the longest speed that still contains the observation."""
    model, obs = learned
    longest = longest_alpha(model, obs)
    slow = with_regressions(model.primitives[0], [0.8, 1.5], (0.1, 0.01), (0.1, 0.01))
    assert model_alpha(model, slow, obs)[0] == pytest.approx(0.4, rel=1e-12)
    fast = with_regressions(model.primitives[0], [0.8, 1.5], (9.0, 0.01), (9.0, 0.01))
    assert model_alpha(model, fast, obs)[0] == pytest.approx(3.0, rel=1e-12)
    bound = with_regressions(model.primitives[0], [0.8, 0.6 * longest], (9.0, 0.01), (9.0, 0.01))
    assert model_alpha(model, bound, obs)[0] == pytest.approx(longest, rel=1e-12)


def test_a_modalitys_columns_follow_the_observed_ones_before_it() -> None:
    partner = Modality("partner", ("px", "py"), unit="m")
    model = SimpleNamespace(layout=Layout((*LAYOUT.modalities, partner)))
    every = SimpleNamespace(modalities=("hand", "head", "partner"))
    assert modality_columns(model, every, "partner").tolist() == [6, 7]
    assert modality_columns(model, every, "head").tolist() == [3, 4, 5]
    skipped = SimpleNamespace(modalities=("head", "partner"))  # the hand not observed
    assert modality_columns(model, skipped, "partner").tolist() == [3, 4]
    assert modality_columns(model, skipped, "head").tolist() == [0, 1, 2]
    with pytest.raises(ValueError):
        modality_columns(model, skipped, "hand")


def test_a_mixed_prior_shares_its_mass_and_its_density_is_the_mixture() -> None:
    prior = AlphaPrior((0.1,), (0.3,), (5.0,), (1.0,))
    mixed = prior.mixed_with(0.4, 0.2, 3.0, 0.25)
    assert mixed.locs == (0.1, 0.4) and mixed.scales == (0.3, 0.2) and mixed.dofs == (5.0, 3.0)
    assert mixed.weights == pytest.approx((0.75, 0.25), rel=1e-15)
    again = mixed.mixed_with(-0.2, 0.1, 2.0, 0.4)
    assert again.weights == pytest.approx((0.45, 0.15, 0.4), rel=1e-15)
    x = np.linspace(-1.0, 1.0, 9)
    want = 0.75 * stats.t.pdf(x, 5.0, 0.1, 0.3) + 0.25 * stats.t.pdf(x, 3.0, 0.4, 0.2)
    assert_allclose(np.exp(mixed.logpdf(x)), want, rtol=1e-12)
    single = mixed.logpdf(x.astype(np.float32))  # single precision in, float64 out
    assert single.dtype == np.float64
    assert_allclose(single, mixed.logpdf(x.astype(np.float32).astype(float)), rtol=1e-15)


def test_a_mixed_priors_mass_below_a_bound_is_the_mixtures() -> None:
    """``logcdf``: the log of the weighted Student-t masses below the bound; no mass below
    ``-inf``, said without a warning."""
    mixed = AlphaPrior((0.1,), (0.3,), (5.0,), (1.0,)).mixed_with(0.4, 0.2, 3.0, 0.25)
    for bound in (-0.5, 0.3, 1.2):
        want = 0.75 * stats.t.cdf(bound, 5.0, 0.1, 0.3) + 0.25 * stats.t.cdf(bound, 3.0, 0.4, 0.2)
        assert mixed.logcdf(bound) == pytest.approx(math.log(want), rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert mixed.logcdf(-math.inf) == -math.inf


def test_the_quadrature_range_is_the_central_mass_truncated_at_the_bound() -> None:
    """``span``: from the lowest to the highest end of its components' central masses
    (:data:`TAIL` left out at each end), cut at the bound; a bound at or below the lowest end
    (every plausible speed ends too early): the ``4 max(scale)`` just below the bound."""
    mixed = AlphaPrior((0.1,), (0.3,), (5.0,), (1.0,)).mixed_with(0.4, 0.2, 3.0, 0.25)
    lo = min(0.1 + 0.3 * stats.t.ppf(TAIL, 5.0), 0.4 + 0.2 * stats.t.ppf(TAIL, 3.0))
    hi = max(0.1 + 0.3 * stats.t.ppf(1 - TAIL, 5.0), 0.4 + 0.2 * stats.t.ppf(1 - TAIL, 3.0))
    assert mixed.span(math.inf) == pytest.approx((lo, hi), rel=1e-9)
    assert mixed.span(0.5) == pytest.approx((lo, 0.5), rel=1e-9)
    at_lo = mixed.span(math.inf)[0]  # exactly the lowest end
    for bound in (at_lo, lo - 1.0):
        assert mixed.span(bound) == pytest.approx((bound - 4.0 * 0.3, bound), rel=1e-12)


def test_the_speed_prior_is_kept_per_s_bar_and_the_model_half_is_never_narrow(learned) -> None:
    """``alpha_prior``: the training speeds' prior is computed once per primitive and ``s_bar``
    (a model of another ``s_bar`` sharing the primitive gets its own); with
    ``alpha_method="model"`` half of the mass is a Student-t at the Eq. 7 speed, of the
    regression's error in log alpha but never narrower than a quarter of the training prior's
    scale."""
    model, obs = learned
    s_bar = model.settings.s_bar
    exact = with_regressions(model.primitives[0], [1.0, 1.0], (1.2, 0.0), (1.2, 0.0))
    trained = alpha_prior(model, exact, obs, "ml")  # one speed: the scale is its floor
    assert trained.scales == pytest.approx((1.0 / s_bar,), rel=1e-12)
    other = dataclasses.replace(model, settings=dataclasses.replace(model.settings,
                                                                    s_bar=2.0 * s_bar))  # fmt: skip
    assert alpha_prior(other, exact, obs, "ml").scales == pytest.approx((0.5 / s_bar,), rel=1e-12)
    assert alpha_prior(model, exact, obs, "ml") is trained
    mixed = alpha_prior(model, exact, obs, "model")
    assert mixed.locs == pytest.approx((0.0, math.log(1.2)), abs=1e-12)
    assert mixed.weights == pytest.approx((0.5, 0.5), rel=1e-15)
    assert mixed.dofs == (trained.dofs[0],) * 2
    assert mixed.scales[1] == pytest.approx(trained.scales[0] / 4, rel=1e-12)  # the floor
    loose = with_regressions(model.primitives[0], [1.0, 1.0], (1.2, 1.0), (1.2, 1.0))
    assert alpha_prior(model, loose, obs, "model").scales[1] == pytest.approx(
        model_alpha(model, loose, obs)[1], rel=1e-12)  # fmt: skip
    assert model_alpha(model, loose, obs)[1] > trained.scales[0]


def test_a_bound_at_or_below_the_priors_range_gives_the_half_step_lattice_below_it() -> None:
    """``anchored_nodes`` when every plausible speed ends too early (the bound at or below the
    lowest end of the prior's range, a prior of positive or negative log alpha): the nodes of
    the lattice of the same origin and half the step that lie within ``4 max(scale)`` below
    the bound and more than half a (half) step below it, then the bound itself."""
    for loc in (3.0, -3.0):
        prior = AlphaPrior((loc,), (0.1,), (5.0,), (1.0,))
        lo, hi = prior.span(math.inf)
        half = (hi - lo) / (N_NODES - 1) / 2
        for bound in (lo, lo - 0.05):
            lattice = lo + half * np.arange(math.ceil((bound - 4 * 0.1 - lo) / half), 1)
            want = np.append(lattice[lattice < bound - 0.5 * half], bound)
            nodes = anchored_nodes(prior, bound)
            assert nodes.size == want.size > 20
            assert_allclose(nodes, want, rtol=0, atol=1e-12)


def test_the_quadrature_gives_the_priors_density_at_its_nodes_wherever_the_bound() -> None:
    """``quadrature``: its nodes are ``anchored_nodes``, its log prior the prior's density at
    each of them and its log mass the prior's mass below the bound, for a bound beyond the
    lattice, on it, between two of its nodes, just inside it and below it, asked in any order
    (the lattice's densities are computed once per prior and reused)."""
    prior = AlphaPrior((0.2, -0.1), (0.15, 0.3), (6.0, 3.0), (0.7, 0.3))
    lo, hi = prior.span(math.inf)
    step = (hi - lo) / (N_NODES - 1)
    bounds = (hi + 1.0, hi, lo + 10.5 * step, lo + 10 * step, lo + 0.7 * step, lo, lo - 0.3)
    for bound in (*bounds, *reversed(bounds)):
        nodes, log_prior, log_mass = quadrature(prior, bound)
        assert_allclose(nodes, anchored_nodes(prior, bound), rtol=0, atol=0)
        assert nodes[-1] == min(bound, hi) and nodes.size >= 2
        assert_allclose(log_prior, prior.logpdf(nodes), rtol=1e-13, atol=0)
        assert log_mass == prior.logcdf(bound)


def test_the_refined_nodes_split_the_coarse_steps_around_the_best_node() -> None:
    """``refined_nodes``: the quarter steps within one coarse step either side of the best
    node (seven points, the best one left out), only those strictly inside the coarse range
    (a last gap shorter than the step: the bound's); wherever the nodes lie."""
    nodes = np.array([0.0, 0.25, 0.5, 0.75, 0.9375])  # the last gap three quarters of a step
    quarter = np.array([-3, -2, -1, 1, 2, 3]) * 0.0625
    assert refined_nodes(nodes, 2).tolist() == (0.5 + quarter).tolist()
    assert refined_nodes(nodes, 1).tolist() == (0.25 + quarter).tolist()
    assert refined_nodes(nodes, 0).tolist() == quarter[3:].tolist()
    assert refined_nodes(nodes, 3).tolist() == (0.75 + quarter[:5]).tolist()  # not 0.9375
    assert refined_nodes(nodes, 4).tolist() == (0.9375 + quarter[:3]).tolist()
    far = refined_nodes(4096.0 + nodes / 16, 2)  # large log alphas, a fine step: the same
    assert far.tolist() == (4096.0 + (0.5 + quarter) / 16).tolist()


def test_the_speed_prior_of_one_two_or_many_training_speeds() -> None:
    """``speed_prior``: one speed, the scale of one sample's worth of duration and one degree
    of freedom; two, their standard deviation (n - 1 in the denominator) inflated by
    ``sqrt(1 + 1/n)``; rows of speeds, each row its own prior."""
    loc, scale, dof = speed_prior(np.log([2.0]), 100.0)
    assert (float(loc), float(scale), float(dof)) == pytest.approx((math.log(2.0), 0.02, 1.0))
    loc, scale, dof = speed_prior(np.log([1.0, 2.0]), 100.0)
    assert float(scale) == pytest.approx(math.log(2.0) / math.sqrt(2.0) * math.sqrt(1.5))
    assert float(dof) == 1.0
    rows = np.log([[1.0, 1.5, 2.0], [1.0, 1.01, 1.4]])
    for row, each in zip(rows, zip(*speed_prior(rows, 100.0), strict=True), strict=True):
        assert_allclose(each, speed_prior(row, 100.0), rtol=1e-15)
    assert speed_prior(rows, 100.0)[1][0] != speed_prior(rows, 100.0)[1][1]


def test_a_prior_whose_components_do_not_match_is_refused() -> None:
    """An ``AlphaPrior`` with more locations than scales has no density: an error, not a
    density of its first components."""
    broken = AlphaPrior((0.1, 0.4), (0.3,), (5.0,), (1.0,))
    with pytest.raises(ValueError):
        broken.logpdf(np.zeros(3))


def test_the_longest_speed_lasts_exactly_the_observation(learned) -> None:
    model, obs = learned
    longest = longest_alpha(model, obs)
    assert longest == pytest.approx(model.settings.s_bar / 30, rel=1e-12)  # 30 samples seen
    assert duration_from_alpha(longest, model.sample_period, model.settings.s_bar) == (
        pytest.approx(float(obs.elapsed[-1]), rel=1e-12))  # fmt: skip


def test_a_node_half_a_step_below_the_bound_is_dropped() -> None:
    """``anchored_nodes``: the lattice's nodes more than half a step below the bound are kept;
    one exactly half a step below is dropped (the last gap one and a half steps, not half)."""
    prior = AlphaPrior((0.1,), (0.3,), (5.0,), (1.0,))
    lo, hi = prior.span(math.inf)
    lattice, step = np.linspace(lo, hi, N_NODES), (hi - lo) / (N_NODES - 1)
    exact = [j for j in range(1, N_NODES - 2)
             if (lattice[j] + 0.5 * step) - 0.5 * step == lattice[j]]  # fmt: skip
    assert exact  # a node that is half a step below its bound to the last bit
    j = exact[0]
    nodes = anchored_nodes(prior, lattice[j] + 0.5 * step)
    assert nodes[:-1].tolist() == lattice[:j].tolist()


def test_the_quadrature_weights_are_trapezoids_normalised_to_the_prior_mass() -> None:
    """``quadrature_weights``: each node's log prior plus the log of its trapezoid width (half
    the distance between its neighbours; an end's, its one gap), shifted so that they sum to
    the mass below the bound; one node alone carries the whole mass."""
    nodes, log_prior = np.array([0.0, 0.5, 1.5]), np.array([-1.0, -0.5, -2.0])
    weights = quadrature_weights(nodes, log_prior, -0.3)
    assert logsumexp(weights) == pytest.approx(-0.3, rel=1e-12)
    assert_allclose(weights - weights[0], log_prior - log_prior[0]
                    + np.log(np.array([0.5, 0.75, 1.0]) / 0.5), rtol=1e-12)  # fmt: skip
    assert_allclose(quadrature_weights(np.array([0.2]), np.array([-1.0]), -0.3), [-0.3],
                    rtol=1e-12)  # fmt: skip


def test_single_precision_speeds_and_values_are_read_in_double() -> None:
    """``AlphaPrior.from_alphas`` and ``logsumexp_rows`` compute in float64 whatever they are
    given."""
    alphas = np.array([0.8, 1.3, 0.95], dtype=np.float32)
    assert AlphaPrior.from_alphas(alphas, 100.0) == AlphaPrior.from_alphas(alphas.astype(float),
                                                                           100.0)  # fmt: skip
    assert AlphaPrior.from_alphas(alphas, 100.0).dofs == (2.0,)
    values = np.array([[0.1, -3.0, 2.5]], dtype=np.float32)
    rows = logsumexp_rows(values)
    assert rows.dtype == np.float64
    assert rows.tolist() == logsumexp_rows(values.astype(float)).tolist()


def test_rows_of_nothing_sum_to_nothing_row_by_row() -> None:
    """``logsumexp_rows`` of an empty last axis: ``-inf`` for each row, in the rows' shape."""
    empty = logsumexp_rows(np.empty((2, 3, 0)))
    assert empty.shape == (2, 3) and np.all(empty == -np.inf)
