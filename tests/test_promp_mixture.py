"""The mixture recognition (``Settings.recognition = "mixture:H"``, promp/evidence/mixture.py):
each component's likelihood against the dense formula, its integral over the speed against a
fine grid, the ProMP at bandwidth 1, and the same numbers fresh or extended sample by sample."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.evidence import Evidence, mixture
from promp.evidence.pipeline import infer
from promp.evidence.speed import alpha_prior, logsumexp, longest_alpha, t_logpdf
from promp.inference import Observation
from promp.learn import fit
from promp.model import Settings, recognition_bandwidth
from promp.quality import winsorized
from promp.timing import duration_from_alpha
from tests import dense_reference as dense
from tests.synthetic import LAYOUT, make_dataset, make_demo

SMALL = Settings(n_basis=6, width=1.0, noise_scale=1.5, recognition="promp")


@pytest.fixture(scope="module")
def model():
    return fit(make_dataset(seed=1, n_demos=6), LAYOUT, SMALL)


@pytest.fixture(scope="module")
def test_demo():
    return make_demo(np.random.default_rng(7), np.array([0.2, -0.2, 0.1, 0.0, 0.3, -0.6]))


def _as(model, name: str):
    return dataclasses.replace(model, settings=dataclasses.replace(model.settings,
                                                                   recognition=name))


def _component(prim, j: int, h: float):
    """Component ``j`` at bandwidth ``h`` as a primitive of its own."""
    share = math.sqrt(1.0 - h * h)
    return dataclasses.replace(prim, mean=prim.mean + share * prim.residuals[j],
                               cov_diag=h * h * prim.cov_diag, cov_factor=h * prim.cov_factor,
                               residuals=None)  # fmt: skip


def test_the_fit_keeps_each_demonstrations_residual_from_the_regression(model) -> None:
    for prim in model.primitives:
        assert prim.residuals.shape == (prim.alphas.shape[0], prim.mean.shape[0])
        # residuals of a regression with an intercept: they sum to zero
        assert_allclose(prim.residuals.sum(axis=0), 0.0, atol=1e-9 * np.abs(prim.mean).max())
        assert np.abs(prim.residuals).max() > 0


@pytest.mark.parametrize("modalities", [["hand"], ["head"], ["hand", "head"]])
@pytest.mark.parametrize("n_observed", [1, 9, 40])
@pytest.mark.parametrize("h", [0.3, 0.7, 1.0])
def test_each_components_likelihood_is_the_dense_formulas(model, test_demo, modalities,
                                                          n_observed, h) -> None:  # fmt: skip
    obs = Observation.from_demo(model, test_demo, n_observed, modalities)
    evidence = Evidence(model, obs)
    prim = model.primitives[1]
    alphas = prim.alphas[:3]
    durations = duration_from_alpha(alphas, model.sample_period, model.settings.s_bar)
    sums = evidence._sums(prim, alphas, durations)
    fast = mixture.log_likelihoods(sums, prim, evidence.dims, prim.noise_var[evidence.dims], h)
    assert fast.shape == (alphas.shape[0], prim.residuals.shape[0])
    for j in range(prim.residuals.shape[0]):
        slow = [dense.log_likelihood(model, _component(prim, j, h), obs, a) for a in alphas]
        assert_allclose(fast[:, j], slow, rtol=1e-9, atol=1e-6)


def test_at_bandwidth_one_the_mixture_is_the_promp(model, test_demo) -> None:
    """Every component is the primitive itself and every kernel its speed prior: the same
    nodes, likelihoods, prior and evidence as the ProMP's quadrature."""
    obs = Observation.from_demo(model, test_demo, 25, ["hand"])
    evidence = Evidence(model, obs)
    for k, prim in enumerate(model.primitives):
        prior = alpha_prior(model, prim, obs, "ml")
        table = lambda x, p=prim: evidence._components(p, 1.0, x)  # noqa: E731
        nodes, ll, lp, log_ev = mixture.integrate(table, prim, prior, evidence._bound, 1.0)
        promp = evidence.integral(k)
        assert_allclose(nodes, promp.nodes, rtol=1e-12)
        assert_allclose(log_ev, promp.log_evidence, rtol=1e-9)
        # the speed's posterior: the same up to its normalisation (the mixture's prior is
        # its quadrature weights per unit of log alpha, the ProMP's its density)
        finite = np.isfinite(promp.log_likelihoods)
        assert np.array_equal(finite, np.isfinite(ll))
        gap = (ll + lp)[finite] - (promp.log_likelihoods + promp.log_prior)[finite]
        assert np.ptp(gap) < 1e-7 and abs(gap[0]) < 0.05


@pytest.mark.parametrize("n_observed", [8, 30])
def test_the_mixtures_evidence_is_its_integral_over_the_speed(model, test_demo,
                                                             n_observed) -> None:  # fmt: skip
    """``log (1/J) sum_j int p(y | alpha, j) k_j(alpha) d log alpha`` on a grid of 3,001 nodes
    (each kernel the speed prior moved towards the demonstration's own speed and narrowed,
    zero likelihood past the fastest speed that contains the observation) against the
    engine's 38 nodes, within the ProMP's own quadrature error."""
    h = 0.5
    mixed = _as(model, f"mixture:{h}")
    obs = Observation.from_demo(mixed, test_demo, n_observed, ["hand", "head"])
    evidence = Evidence(mixed, obs)
    bound = math.log(longest_alpha(mixed, obs))
    for k, prim in enumerate(mixed.primitives):
        prior = alpha_prior(mixed, prim, obs, "ml")
        (loc,), (scale,), (dof,) = prior.locs, prior.scales, prior.dofs
        grid = np.linspace(loc - 14 * scale, min(bound, loc + 14 * scale), 3001)
        own = winsorized(np.log(prim.alphas))
        terms = []
        for j in range(prim.residuals.shape[0]):
            centre = loc + math.sqrt(1 - h * h) * (own[j] - loc)
            density = t_logpdf((grid - centre) / (h * scale), dof) - math.log(h * scale)
            ll = Evidence(mixed, obs).log_likelihoods(_component(prim, j, h), np.exp(grid))
            top = np.max(ll + density)  # (scaled: the likelihoods are large)
            terms.append(math.log(np.trapezoid(np.exp(ll + density - top), grid)) + top)
        brute = logsumexp(np.array(terms)) - math.log(len(terms))
        # (the ProMP's own 38 nodes are 0.004-0.037 from such a grid here)
        assert evidence.integral(k).log_evidence == pytest.approx(brute, abs=0.06)


def test_the_mixture_recognises_with_its_own_evidence_and_speed(model, test_demo) -> None:
    """Its evidence and its speed's posterior are the mixture's; the conditioning at a speed
    is the ProMP's."""
    obs = Observation.from_demo(model, test_demo, 12, ["hand"])
    promp = infer(model, obs)
    mixed = infer(_as(model, "mixture:0.5"), obs)
    assert_allclose(mixed.probabilities.sum(), 1.0, rtol=1e-12)
    assert mixed.primitive == promp.primitive
    assert np.abs(mixed.recognition.log_evidence - promp.recognition.log_evidence).min() > 1e-3
    assert mixed.timing.alpha != promp.timing.alpha
    again = Evidence(model, obs).condition(model.primitive(mixed.primitive), mixed.timing.alpha)
    assert_allclose(mixed.posterior.mean, again.mean, rtol=1e-12, atol=1e-15)


def test_the_mixture_extended_sample_by_sample_is_the_fresh_one(model, test_demo) -> None:
    """The live predictor's promise (promp.live): the evidence extended by new samples gives
    the numbers of one computed from every sample."""
    mixed = _as(model, "mixture:0.6")
    evidence = None
    for n in (3, 4, 9, 10, 22):
        obs = Observation.from_demo(mixed, test_demo, n, ["hand", "head"])
        evidence = Evidence(mixed, obs) if evidence is None else evidence.extended(obs)
        fresh = Evidence(mixed, obs)
        for k in range(len(mixed.primitives)):
            assert_allclose(evidence.integral(k).log_evidence, fresh.integral(k).log_evidence,
                            rtol=1e-9)  # fmt: skip
        assert_allclose(evidence.recognition.probabilities, fresh.recognition.probabilities,
                        rtol=1e-9, atol=1e-12)  # fmt: skip


@pytest.mark.parametrize("name, bandwidth", [("promp", 1.0), ("mixture:0.5", 0.5),
                                             ("mixture:1", 1.0)])  # fmt: skip
def test_recognition_names_give_their_bandwidth(name, bandwidth) -> None:
    assert recognition_bandwidth(name) == bandwidth
    assert Settings(recognition=name).recognition == name


@pytest.mark.parametrize("name", ["mixture", "mixture:0", "mixture:1.5", "mixture:nan",
                                  "mixture:x", "promp:1", "ebip:1", ""])  # fmt: skip
def test_other_recognition_names_are_refused(name) -> None:
    with pytest.raises(ValueError, match="recognition must be"):
        Settings(recognition=name)


def test_a_mixture_needs_the_residuals(model) -> None:
    bare = dataclasses.replace(model.primitives[0], residuals=None)
    with pytest.raises(ValueError, match="needs every primitive's training residuals"):
        dataclasses.replace(_as(model, "mixture:0.5"), primitives=(bare,) + model.primitives[1:])
    with pytest.raises(ValueError, match="residuals must be"):
        dataclasses.replace(model.primitives[0], residuals=model.primitives[0].residuals[1:])
