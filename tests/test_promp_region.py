"""The predictive region of a primitive (promp.region): its Gaussian against the textbook
formula, its probability on movements drawn from the model itself, the speeds and the noise it
accounts for, its share of real demonstrations' samples, bad input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.data import Demonstration
from promp.datasets import read_dataset
from promp.learn import fit
from promp.model import Settings
from promp.region import (
    coverage,
    new_movement,
    region_radius,
    sample_distribution,
    sample_noise_var,
    speed_variance,
)
from tests.conftest import shared_set
from tests.synthetic import COLUMNS, LAYOUT, make_dataset

SMALL = Settings(n_basis=6, width=1.0, noise_scale=1.5)


@pytest.fixture(scope="module")
def model():
    return fit(make_dataset(seed=2, n_demos=8), LAYOUT, SMALL)


def test_the_radius_is_the_chi_square_quantile() -> None:
    assert region_radius(0.9, 3) == pytest.approx(2.5003, abs=1e-4)  # chi2_3(0.9) = 6.2514
    assert region_radius(0.5, 3) == pytest.approx(1.5382, abs=1e-4)
    assert region_radius(0.6827, 1) == pytest.approx(1.0, abs=1e-3)  # one sigma in 1-D


def test_the_sample_distribution_is_the_textbook_one(model) -> None:
    prim = model.primitives[0]
    dist = new_movement(prim)
    dims = np.array([0, 2, 4])
    phases = np.array([0.0, 0.37, 1.0])
    noise = sample_noise_var(model, prim)
    got = sample_distribution(model, dist, dims, phases, noise)
    m = model.basis.n_basis
    for i, z in enumerate(phases):
        a = np.zeros((3, model.n_dims * m))  # the basis of the three columns, explicitly
        for j, d in enumerate(dims):
            a[j, d * m : (d + 1) * m] = model.basis(np.array([z]))[0]
        assert_allclose(got.mean[i], a @ dist.mean, rtol=1e-12)
        assert_allclose(got.cov[i], a @ dist.cov @ a.T + np.diag(noise[dims]), rtol=1e-10)
    bare = sample_distribution(model, dist, dims, phases)
    assert_allclose(got.cov - bare.cov, np.broadcast_to(np.diag(noise[dims]), got.cov.shape),
                    atol=1e-15)  # fmt: skip


def test_a_new_movement_adds_the_spread_of_the_speeds(model) -> None:
    prim = model.primitives[1]
    dist = new_movement(prim)
    v = speed_variance(prim)
    assert v > 0 and np.abs(prim.alpha_slope).max() > 0
    assert_allclose(dist.mean, prim.mean)
    assert_allclose(dist.cov, prim.cov + v * np.outer(prim.alpha_slope, prim.alpha_slope))
    uncoupled = fit(make_dataset(seed=2, n_demos=8), LAYOUT,
                    dataclasses.replace(SMALL, alpha_coupling=False))  # fmt: skip
    assert_allclose(new_movement(uncoupled.primitives[1]).cov, uncoupled.primitives[1].cov)


def test_the_samples_noise_is_without_the_recognitions_scale(model) -> None:
    prim = model.primitives[0]
    assert_allclose(sample_noise_var(model, prim), prim.noise_var / 1.5**2)
    given = fit(make_dataset(seed=2, n_demos=8), LAYOUT,
                dataclasses.replace(SMALL, noise_std={"head": 0.02}))  # fmt: skip
    var = sample_noise_var(given, given.primitives[0])
    assert_allclose(var[3:], 0.02**2)  # given: kept
    assert_allclose(var[:3], given.primitives[0].noise_var[:3] / 1.5**2)


@pytest.mark.parametrize("probability", [0.5, 0.9])
def test_movements_drawn_from_the_model_fill_the_region_as_stated(model, probability) -> None:
    """Weights drawn from the new movement's Gaussian, samples with the noise: the share inside
    its region (the Gaussian's, without the calibrated factor) is the probability, within the
    Monte Carlo error (400 movements)."""
    prim = model.primitives[0]
    dist = new_movement(prim)
    noise = np.sqrt(sample_noise_var(model, prim))
    rng = np.random.default_rng(0)
    chol = np.linalg.cholesky(dist.cov + 1e-15 * np.eye(dist.cov.shape[0]))
    times = np.linspace(0.0, 2.0, 41)
    phi = model.basis(times / times[-1])
    demos = []
    for i in range(400):
        w = dist.mean + chol @ rng.standard_normal(dist.mean.shape[0])
        values = phi @ w.reshape(model.n_dims, -1).T + noise * rng.standard_normal((41, 6))
        demos.append(Demonstration(times, values, COLUMNS, name=f"drawn{i}"))
    share = coverage(model, prim.name, demos, "hand", probability, calibrated=False).share
    assert share == pytest.approx(probability, abs=0.03)


def test_bad_input_is_a_clear_error(model) -> None:
    prim = model.primitives[0]
    for p in (0.0, 1.0, float("nan"), 1.5):
        with pytest.raises(ValueError, match=r"probability must be in \(0, 1\)"):
            region_radius(p, 3)
    with pytest.raises(ValueError, match="unknown modality"):
        coverage(model, prim.name, [], "gaze")
    with pytest.raises(ValueError, match="unknown primitive"):
        coverage(model, "nope", [], "hand")
    with pytest.raises(ValueError, match="dimensions of the model"):
        sample_distribution(model, new_movement(prim), [6], np.array([0.5]))
    region = sample_distribution(model, new_movement(prim), [0, 1, 2], np.array([0.5]))
    with pytest.raises(ValueError, match="points must have shape"):
        region.squared_distances(np.zeros((2, 3)))


# ---------------------------------------------------------------------- the shared real sets


@pytest.mark.parametrize(
    "name", ["lab-records-heights", "lab-records-flt", "lab-records-flt-shapes"]
)
def test_the_region_holds_near_its_probability_of_real_demonstrations(name) -> None:
    """Each primitive's 90 % region holds between 85 and 100 % of its demonstrations' samples
    (bench/tube_coverage.py prints every figure, held out too)."""
    folder = shared_set(name)
    read = read_dataset(folder, "records")
    model = fit(read.dataset, read.layout)
    shares = {k: coverage(model, k, demos, "hand", 0.9).share for k, demos in read.dataset.items()}
    assert all(0.85 <= s <= 1.0 for s in shares.values()), shares
    pooled = np.mean(list(shares.values()))
    assert 0.88 <= pooled <= 0.98, shares


def test_a_modalitys_region_mean_and_shaped_prior_are_the_textbook_ones(model) -> None:
    """modality_region: sample_distribution on evenly spaced phases with the samples' noise;
    mean_position: the weights' mean through the basis at one phase (the region's mean there);
    shaped_prior: a new movement at the primitive's typical speed, conditioned on via-points at
    that speed (none: the new movement itself)."""
    import math

    from promp.region import mean_position, modality_region, shaped_prior
    from promp.via_points import ViaPoint, condition_on_via_points

    name = model.names[0]
    primitive = model.primitive(name)
    alpha, weights = shaped_prior(model, name)
    assert alpha == math.exp(primitive.log_alpha_mean)
    assert_allclose(weights.cov, new_movement(primitive).cov, rtol=0, atol=0)
    region = modality_region(model, weights, "hand", 11)
    dims = model.layout.dims(["hand"])
    noise = sample_noise_var(model, model.primitives[0])
    expected = sample_distribution(model, weights, dims, np.linspace(0, 1, 11), noise)
    assert_allclose(region.cov, expected.cov, rtol=0, atol=0)
    assert_allclose(mean_position(model, weights, "hand", 0.3), region.mean[3], atol=1e-12)
    point = ViaPoint.isotropic(model.layout.modality("hand").columns, region.mean[5] + 0.01,
                               0.001, phase=0.5)  # fmt: skip
    _, through = shaped_prior(model, name, [point])
    conditioned = condition_on_via_points(model, weights, [point], alpha)
    assert_allclose(through.mean, conditioned.mean, rtol=0, atol=0)
    before = np.linalg.norm(mean_position(model, weights, "hand", 0.5) - point.values)
    after = np.linalg.norm(mean_position(model, through, "hand", 0.5) - point.values)
    assert after < 0.2 * before  # a tight point 1.7 cm off: most of the way to it
