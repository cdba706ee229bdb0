"""Learning: weights, covariance, noise, time modulation and the alpha models."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.basis import RBFBasis, SeedBasis
from promp.content_key import content_order
from promp.covariance import block_target, pooled_covariances
from promp.data import Demonstration
from promp.learn import fit
from promp.model import Settings
from promp.timing import alpha_from_duration, duration_from_alpha
from promp.weights import fit_weights
from tests.synthetic import COLUMNS, LAYOUT, make_dataset

FLOOR = np.full(3, 1e-12)  # the smallest trajectory variance of the 3 dimensions below
# Settings given where a test is not about their automatic choice (promp.selection)
GIVEN = Settings(n_basis=6, width=1.0, noise_scale=1.5)


def test_basis_rows_are_normalised_and_widths_follow_the_spacing() -> None:
    for m in (2, 5, 20):
        phi = RBFBasis(m, 1.0)(np.linspace(-0.5, 1.5, 101))
        assert phi.shape == (101, m)
        assert_allclose(phi.sum(axis=1), 1.0)
        assert np.all(np.isfinite(phi))
    assert RBFBasis(11, 2.0).sigma == pytest.approx(0.2)
    assert_allclose(SeedBasis(5).centres, [0, 0.2, 0.4, 0.6, 0.8])
    with pytest.raises(ValueError, match="n_basis"):
        RBFBasis(1)
    with pytest.raises(ValueError, match="width"):
        RBFBasis(5, 0.0)


def test_ridge_fit_recovers_a_trajectory_in_the_span_of_the_basis() -> None:
    basis = RBFBasis(8, 1.0)
    times = np.linspace(0.0, 2.0, 101)
    w_true = np.random.default_rng(0).normal(size=(8, 2))
    values = basis(times / 2.0) @ w_true
    w, resid = fit_weights(basis, times, values, ridge=1e-12)
    assert_allclose(w.reshape(2, 8).T, w_true, atol=1e-6)
    assert np.all(np.abs(resid) < 1e-6)


def test_alpha_and_duration_convention_round_trip() -> None:
    dt, s_bar = 0.02, 100.0
    # A movement of 151 samples at 50 Hz lasts 3 s and has alpha = 100 / 151.
    assert alpha_from_duration(3.0, dt, s_bar) == pytest.approx(100 / 151)
    assert duration_from_alpha(100 / 151, dt, s_bar) == pytest.approx(3.0)


def test_fit_learns_spd_covariance_from_fewer_demos_than_weights() -> None:
    dataset = make_dataset(seed=0, n_demos=4)  # 4 demos, 6 x 20 = 120 weights
    model = fit(dataset, LAYOUT, Settings(n_basis=20, width=1.0, noise_scale=1.5))
    for prim in model.primitives:
        assert prim.mean.shape == (120,)
        eigenvalues = np.linalg.eigvalsh(prim.cov)
        assert eigenvalues.min() > 0
        assert prim.cov_factor.shape[0] == 120
        assert np.all((prim.shrinkage > 0.0) & (prim.shrinkage <= 1.0))
        assert prim.alphas.shape == (4,)


def test_noise_is_estimated_from_the_residuals_per_modality() -> None:
    hand_noise, head_noise = 2e-3, 2e-2
    rng = np.random.default_rng(3)
    dataset = {}
    for name in ("a", "b"):
        demos = []
        for i in range(6):
            n = int(rng.integers(150, 250))
            t = np.linspace(0, n / 50, n)
            clean = np.outer(np.sin(np.pi * t / t[-1]), np.arange(1, 7) * 0.05)
            noise = rng.normal(size=(n, 6)) * np.repeat([hand_noise, head_noise], 3)
            demos.append(Demonstration(t, clean + noise, COLUMNS, name=f"{name}{i}"))
        dataset[name] = demos
    model = fit(dataset, LAYOUT, Settings(n_basis=10, width=1.0, noise_scale=1.0))
    noise_std = np.sqrt(model.primitives[0].noise_var)
    assert_allclose(noise_std[:3], hand_noise, rtol=0.1)
    assert_allclose(noise_std[3:], head_noise, rtol=0.1)
    # One sensor, one noise: every primitive shares it.
    assert_allclose(model.primitives[1].noise_var, model.primitives[0].noise_var)
    scaled = fit(dataset, LAYOUT, Settings(n_basis=10, width=1.0, noise_scale=1.5))
    assert_allclose(scaled.primitives[0].noise_var, 1.5**2 * model.primitives[0].noise_var)
    override = fit(
        dataset, LAYOUT, Settings(n_basis=10, width=1.0, noise_scale=1.0, noise_std={"head": 0.5})
    )
    assert_allclose(override.primitives[0].noise_var[3:], 0.25)
    assert_allclose(override.primitives[0].noise_var[:3], model.primitives[0].noise_var[:3])


def test_training_alphas_follow_the_durations() -> None:
    dataset = make_dataset(seed=4, n_demos=5)
    model = fit(dataset, LAYOUT, GIVEN)
    for prim, demos in zip(model.primitives, dataset.values(), strict=True):
        demos = [demos[i] for i in content_order(demos)]  # a fit takes them in this order
        expected = [alpha_from_duration(d.duration, model.sample_period, 100.0) for d in demos]
        assert_allclose(prim.alphas, expected)


def test_alpha_coupling_is_the_conditional_of_the_joint_gaussian() -> None:
    model = fit(make_dataset(seed=5, n_demos=8), LAYOUT, GIVEN)
    prim = model.primitives[0]
    centre = np.exp(prim.log_alpha_mean)
    assert_allclose(prim.mean_at(centre), prim.mean, atol=1e-12)
    batch = prim.mean_at(np.array([0.5, 1.0]))
    assert batch.shape == (2, prim.mean.shape[0])
    off = fit(
        make_dataset(seed=5, n_demos=8), LAYOUT, dataclasses.replace(GIVEN, alpha_coupling=False)
    )
    assert_allclose(off.primitives[0].mean_at(0.5), off.primitives[0].mean)


def _classes(rng, n_classes: int, n_per_class: int, shared: bool, p: int = 12) -> list:
    """Residuals of classes whose covariances are one shared matrix, or each its own."""
    def random_cov():
        a = rng.normal(size=(p, 3))
        return a @ a.T + 0.05 * np.eye(p)

    common = random_cov()
    out = []
    for _ in range(n_classes):
        cov = common if shared else random_cov() * rng.uniform(0.2, 5.0)
        x = rng.multivariate_normal(np.zeros(p), cov, size=n_per_class)
        out.append(x - x.mean(axis=0))
    return out


def test_the_pooled_prior_is_strong_when_primitives_share_their_shape() -> None:
    """Empirical Bayes, with a known answer: classes drawn from one covariance make the prior
    strong (c far above each class's dof: they borrow it), classes with unrelated covariances
    make it weak (each keeps its own)."""
    rng = np.random.default_rng(0)
    basis = RBFBasis(4, 1.0)
    dims = [np.array([0, 1, 2])]
    shared = _classes(rng, 6, 8, shared=True)
    _, strong = pooled_covariances(shared, [7] * 6, dims, 3, basis, FLOOR)
    unrelated = _classes(rng, 6, 40, shared=False)
    _, weak = pooled_covariances(unrelated, [39] * 6, dims, 3, basis, FLOOR)
    assert strong.strength > 10 * 7
    assert weak.strength < 39
    described = strong.describe()
    assert described["strength"] == strong.strength and "marginal likelihood" in str(described)


def test_the_pooled_covariance_is_the_posterior_mean_of_its_niw_prior() -> None:
    """Sigma_k = (1 + 1/n)(c Sigma_0 + E^T E) / (c + dof), checked densely."""
    rng = np.random.default_rng(1)
    basis = RBFBasis(4, 1.0)
    residuals = _classes(rng, 3, 6, shared=True)
    out, prior = pooled_covariances(residuals, [5, 5, 5], [np.arange(3)], 3, basis, FLOOR)
    rows = np.concatenate(residuals)
    target = block_target(rows, 3, 15, basis, FLOOR)
    beta = np.repeat(prior.target_weight, 4)
    sigma0 = np.diag(beta * target) + np.sqrt(1 - beta)[:, None] * (rows.T @ rows / 15) * np.sqrt(
        1 - beta
    )[None, :]
    c = prior.strength
    for (diag, factor), e in zip(out, residuals, strict=True):
        expected = (1 + 1 / 6) * (c * sigma0 + e.T @ e) / (c + 5)
        assert_allclose(np.diag(diag) + factor @ factor.T, expected, rtol=1e-9, atol=1e-12)


def test_the_model_reports_what_it_chose() -> None:
    model = fit(make_dataset(seed=3, n_demos=6), LAYOUT, GIVEN)
    cov = model.report["covariance"]
    assert cov["strength"] > 0 and len(cov["target_weight"]) == LAYOUT.n_dims
    fixed = fit(make_dataset(seed=3, n_demos=6), LAYOUT, dataclasses.replace(GIVEN, shrinkage=0.2))
    assert fixed.report["covariance"]["shrinkage"] == 0.2


def test_shrinkage_target_is_one_scaled_identity_per_dimension() -> None:
    model = fit(make_dataset(seed=2, n_demos=5), LAYOUT, dataclasses.replace(GIVEN, shrinkage=0.3))
    prim = model.primitives[0]
    blocks = prim.cov_diag.reshape(6, 6)
    assert_allclose(blocks, blocks[:, :1] * np.ones((1, 6)))  # constant within a dimension
    assert_allclose(prim.shrinkage, 0.3)
    pooled = fit(make_dataset(seed=2, n_demos=5), LAYOUT, GIVEN)
    assert_allclose(pooled.primitives[0].cov_diag.reshape(6, 6)[:, 1:], pooled.primitives[
        0
    ].cov_diag.reshape(6, 6)[:, :-1])  # the pooled prior keeps the block form
    lam = pooled.primitives[0].shrinkage
    assert lam.shape == (6,) and np.all((lam > 0) & (lam <= 1))
    assert lam[0] == lam[1] == lam[2] and lam[3] == lam[4] == lam[5]  # one per modality


def test_fit_does_not_mutate_the_demonstrations() -> None:
    dataset = make_dataset(seed=6, n_demos=3)
    before = [d.values.copy() for d in dataset["left"]]
    fit(dataset, LAYOUT)
    for demo, values in zip(dataset["left"], before, strict=True):
        assert_allclose(demo.values, values, rtol=0, atol=0)


def test_bad_training_input_is_a_clear_error() -> None:
    dataset = make_dataset(seed=0, n_demos=3)
    with pytest.raises(ValueError, match="'left' has 1 demonstration"):
        fit({"left": dataset["left"][:1], "right": dataset["right"]}, LAYOUT)
    with pytest.raises(ValueError, match="empty"):
        fit({}, LAYOUT)
    hand_only = Demonstration(np.arange(5.0), np.zeros((5, 3)), ("x", "y", "z"), name="h")
    with pytest.raises(ValueError, match=r"no column\(s\) \['roll', 'pitch', 'yaw'\]"):
        fit({"a": [hand_only, hand_only]}, LAYOUT)
    for bad in (
        dict(n_basis=1),
        dict(width=-1.0),
        dict(ridge=-1.0),
        dict(s_bar=0.0),
        dict(shrinkage=1.5),
        dict(shrinkage=0.0),
        dict(noise_std={"hand": 0.0}),
        dict(noise_scale=0.0),
    ):
        with pytest.raises(ValueError):
            Settings(**bad)
