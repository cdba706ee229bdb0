"""promp.rows: every row equal, bit for bit, to the one-row call it replaces, so that the duration
temperature's choice, done for all held-out trials at once, keeps every choice and report."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal
from scipy.interpolate import PchipInterpolator

from promp.duration import REFINE, _refined, choose_temperature, weighted_quantiles
from promp.rows import interp_rows, pchip_rows, quantiles_rows


@pytest.mark.filterwarnings("error")  # silent, as the one-row calls are
def test_interp_rows_is_numpy_s_interp_row_by_row():
    rng = np.random.default_rng(0)
    for case in range(120):
        k, q = int(rng.integers(2, 12)), int(rng.integers(1, 30))
        xp = np.sort(rng.normal(size=(5, k)), axis=1)
        if case % 3 == 0:
            xp[:, 1] = xp[:, 0]  # a repeated knot, as a flat cdf has
        fp = rng.normal(size=(5, k))
        if case % 4 == 1:  # impossible values (a log-density's -inf), some side by side
            fp[rng.uniform(size=fp.shape) < 0.4] = -np.inf
            fp[rng.uniform(size=fp.shape) < 0.1] = np.inf
        x = rng.uniform(xp.min() - 0.5, xp.max() + 0.5, size=(5, q))
        x[:, 0] = xp[:, -1]
        want = np.array([np.interp(x[r], xp[r], fp[r]) for r in range(5)])
        assert_array_equal(interp_rows(x, xp, fp), want)  # (NaN where numpy gives NaN)
    # a slope that overflows: numpy reads a point on a knot as the knot's value, not inf * 0
    xp, fp = np.array([[0.0, 1e-310, 1.0]]), np.array([[0.0, 1e300, 0.0]])
    x = np.array([[0.0, 1e-310, 0.5, 1.0]])
    assert np.array_equal(interp_rows(x, xp, fp), np.interp(x[0], xp[0], fp[0])[None])


@pytest.mark.filterwarnings("error")  # silent, as the one-row calls are
def test_pchip_rows_is_scipy_s_pchip_row_by_row():
    rng = np.random.default_rng(1)
    for case in range(120):
        k, q = int(rng.integers(2, 12)), int(rng.integers(1, 30))
        x = np.cumsum(rng.uniform(0.01, 1.0, size=(5, k)), axis=1)
        if case % 2:
            y = rng.normal(size=(5, k))
        else:  # a log-likelihood's shape: concave, with a flat step now and then
            y = -((np.cumsum(rng.uniform(0.0, 1.0, size=(5, k)), axis=1) - 2.0) ** 2)
            y[:, min(2, k - 1)] = y[:, 1]
        at = np.sort(rng.uniform(x[:, :1], x[:, -1:], size=(5, q)), axis=1)
        at[:, 0], at[:, -1] = x[:, 0], x[:, -1]
        if case % 5 == 0:  # outside the knots: extrapolated from the end pieces
            at = np.concatenate([x[:, :1] - 0.3, at, x[:, -1:] + 0.3], axis=1)
        want = np.array([PchipInterpolator(x[r], y[r])(at[r]) for r in range(5)])
        assert np.array_equal(pchip_rows(x, y, at), want)
    # slopes of exactly 0 and 1 (whole numbers): the zero-slope rule at its edges
    x = np.array([[0.0, 1.0, 2.0, 3.0, 4.0], [0.0, 1.0, 2.0, 3.0, 4.0]])
    y = np.array([[0.0, 1.0, 2.0, 5.0, 5.0], [3.0, 3.0, 4.0, 5.0, 9.0]])
    at = np.linspace(-0.5, 4.5, 41)[None].repeat(2, axis=0)
    want = np.array([PchipInterpolator(x[r], y[r])(at[r]) for r in range(2)])
    assert np.array_equal(pchip_rows(x, y, at), want)


@pytest.mark.filterwarnings("error")  # silent, as the one-row calls are
def test_quantiles_rows_is_weighted_quantiles_row_by_row():
    rng = np.random.default_rng(2)
    qs = np.array([0.05, 0.5, 0.95])
    for _ in range(60):
        k = int(rng.integers(2, 300))
        values = np.cumsum(rng.uniform(0.01, 1.0, size=(7, k)), axis=1)
        masses = np.exp(5.0 * rng.normal(size=(7, k)))
        masses[masses < 0.05] = 0.0  # nodes of no mass: flat steps of the cdf
        masses[:, 0] += 1e-300
        want = np.array([weighted_quantiles(values[r], masses[r], qs) for r in range(7)])
        assert np.array_equal(quantiles_rows(values, masses, qs), want)


def _refined_one_by_one(nodes, log_lik, log_w):
    """The trial-by-trial refinement that promp.duration._refined replaced."""
    n_t, n_a = nodes.shape
    fine_n = (n_a - 1) * REFINE + 1
    fine = nodes[:, :1] + (nodes[:, -1:] - nodes[:, :1]) * np.linspace(0.0, 1.0, fine_n)
    out_ll, out_w = np.full((n_t, fine_n), -np.inf), np.empty((n_t, fine_n))
    widths = np.gradient(nodes, axis=1)
    for t in range(n_t):
        density = log_w[t] - np.log(widths[t])
        out_w[t] = np.interp(fine[t], nodes[t], density) + np.log(np.gradient(fine[t]))
        ok = np.isfinite(log_lik[t])
        if ok.sum() >= 2:
            inside = (fine[t] >= nodes[t][ok][0]) & (fine[t] <= nodes[t][ok][-1])
            out_ll[t, inside] = PchipInterpolator(nodes[t][ok], log_lik[t][ok])(fine[t][inside])
        elif ok.any():
            out_ll[t, np.argmin(np.abs(fine[t] - nodes[t][ok][0]))] = log_lik[t][ok][0]
    return fine, out_ll, out_w


def _speed_trials(seed: int, n: int = 90, n_a: int = 12):
    """Held-out speed tables like the scorer's: nodes in log alpha, a peaked log-likelihood with
    the nodes past each trial's bound impossible, log quadrature weights, the truth."""
    rng = np.random.default_rng(seed)
    centre = rng.normal(0.0, 0.2, size=(n, 1))
    nodes = centre + np.linspace(-0.6, 0.6, n_a) * rng.uniform(0.5, 1.5, size=(n, 1))
    truth = centre[:, 0] + rng.normal(0.0, 0.1, size=n)
    log_lik = -0.5 * ((nodes - truth[:, None]) / rng.uniform(0.03, 0.3, size=(n, 1))) ** 2
    log_lik[::3, -4:] = -np.inf  # a bound cuts the fastest speeds
    log_lik[1::7, 1:] = -np.inf  # a single possible node
    log_lik[2::11, :5] = -np.inf  # the slowest cut
    log_w = np.log(np.full((n, n_a), 1.0 / n_a))
    return nodes, log_lik, log_w, truth


@pytest.mark.parametrize("seed", [3, 4])
def test_the_refinement_of_every_trial_at_once_is_the_trial_by_trial_one(seed):
    nodes, log_lik, log_w, _ = _speed_trials(seed)
    for got, want in zip(
        _refined(nodes, log_lik, log_w), _refined_one_by_one(nodes, log_lik, log_w), strict=True
    ):
        assert np.array_equal(got, want)


def test_the_temperature_chosen_and_its_coverages_are_the_trial_by_trial_ones():
    trials = [_speed_trials(5), _speed_trials(6, n=40)]
    tau, coverage = choose_temperature(trials)
    nodes, log_lik, log_w, truth = (np.concatenate(parts) for parts in zip(*trials, strict=True))
    possible = np.isfinite(log_lik).any(axis=1)  # row 57: every node cut, not a trial
    nodes, log_lik, log_w, truth = (a[possible] for a in (nodes, log_lik, log_w, truth))
    nodes, log_lik, log_w = _refined_one_by_one(nodes, log_lik, log_w)
    for t, covered in coverage.items():
        log_mass = np.where(np.isfinite(log_lik), t * log_lik, -np.inf) + log_w
        masses = np.exp(log_mass - log_mass.max(axis=1, keepdims=True))
        bounds = np.array([weighted_quantiles(x, w, np.array([0.05, 0.95]))
                           for x, w in zip(nodes, masses, strict=True)])  # fmt: skip
        assert covered == float(np.mean((bounds[:, 0] <= truth) & (truth <= bounds[:, 1])))
    assert 0.0 < tau <= 1.0 and len(set(coverage.values())) > 1
