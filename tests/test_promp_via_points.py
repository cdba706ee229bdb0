"""Via-points (promp.via_points): against the textbook conditioning, what a tight and a loose
point do, none, with an observation, nothing modified, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from promp.evidence.pipeline import condition
from promp.inference import Gaussian, Observation, predict
from promp.io import model_to_json
from promp.learn import fit
from promp.model import Settings
from promp.timing import duration_from_alpha
from promp.via_points import ViaPoint, condition_on_via_points
from tests import dense_reference as dense
from tests.synthetic import LAYOUT, make_dataset, make_demo

SMALL = Settings(n_basis=6, width=1.0, noise_scale=1.5)
HAND = ("x", "y", "z")


@pytest.fixture(scope="module")
def model():
    return fit(make_dataset(seed=3, n_demos=6), LAYOUT, SMALL)


def typical(prim) -> float:
    return float(np.exp(prim.log_alpha_mean))


def mean_at(model, dist, phase: float) -> np.ndarray:
    """The mean of every dimension at ``phase``, shape (n_dims,)."""
    phi = model.basis(np.array([phase]))[0]
    return dist.mean.reshape(model.n_dims, -1) @ phi


def points(rng, k: int = 3) -> list[ViaPoint]:
    """``k`` random points: the hand at one phase, a height alone at a time, the head's yaw."""
    a = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    return [
        ViaPoint(HAND, rng.normal(0.1, 0.05, 3), a @ np.diag([1e-4, 4e-4, 9e-4]) @ a.T,
                 phase=0.6),
        ViaPoint.isotropic(("z",), [0.02], 0.005, time=0.3),
        ViaPoint.isotropic(("yaw",), [-0.4], 0.05, phase=0.9),
    ][:k]  # fmt: skip


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_conditioning_matches_the_textbook_formula(model, seed) -> None:
    prim = model.primitives[seed % 2]
    alpha = typical(prim)
    vias = points(np.random.default_rng(seed))
    post = condition_on_via_points(model, prim, vias, alpha)
    mean, cov = dense.condition_on_everything(model, prim, alpha, None, vias)
    assert_allclose(post.mean, mean, rtol=1e-8, atol=1e-10)
    assert_allclose(post.cov, cov, rtol=1e-7, atol=1e-12)


def test_a_tight_via_point_is_passed_through(model) -> None:
    prim = model.primitives[0]
    alpha = typical(prim)
    target = mean_at(model, Gaussian(prim.mean_at(alpha), prim.cov), 0.5)[:3] + [0.05, -0.04, 0.03]
    post = condition_on_via_points(
        model, prim, [ViaPoint.isotropic(HAND, target, 1e-5, phase=0.5)], alpha
    )
    # within the point's own standard deviation (0.01 mm), from 3 to 5 cm away
    assert_allclose(mean_at(model, post, 0.5)[:3], target, atol=1e-5)
    # and the trajectory's spread there is as small as the point's
    spread = predict(model, post, alpha, n_points=3).std[1, :3]  # phase 0.5
    assert np.all(spread < 2e-5)


def test_a_loose_via_point_barely_moves_the_mean(model) -> None:
    prim = model.primitives[0]
    alpha = typical(prim)
    far = np.array([1.0, 1.0, 1.0])  # a metre away
    post = condition_on_via_points(model, prim, [ViaPoint.isotropic(HAND, far, 100.0, phase=0.5)],
                                   alpha)  # fmt: skip
    before = mean_at(model, Gaussian(prim.mean_at(alpha), prim.cov), 0.5)
    moved = np.abs(mean_at(model, post, 0.5) - before).max()
    assert 0.0 < moved < 1e-4  # it pulls, by less than 0.1 mm


def test_without_via_points_the_prior_comes_back_exactly(model) -> None:
    prim = model.primitives[1]
    alpha = typical(prim)
    post = condition_on_via_points(model, prim, [], alpha)
    assert_array_equal(post.mean, prim.mean_at(alpha))
    assert_array_equal(post.cov, prim.cov)
    gaussian = Gaussian(np.arange(model.n_dims * 6.0), np.eye(model.n_dims * 6))
    again = condition_on_via_points(model, gaussian, [])
    assert again is not gaussian
    assert_array_equal(again.mean, gaussian.mean)
    assert_array_equal(again.cov, gaussian.cov)
    for dtype in (int, np.float32):  # a prior of integers or single precision: float64 back
        n = model.n_dims * 6
        given = Gaussian(np.arange(n).astype(dtype), np.eye(n, dtype=dtype))
        back = condition_on_via_points(model, given, [])
        assert back.mean.dtype == back.cov.dtype == np.float64
        assert_array_equal(back.mean, given.mean)


@pytest.mark.parametrize("n_observed", [1, 25])
def test_with_an_observation_it_equals_conditioning_on_both(model, n_observed) -> None:
    prim = model.primitives[0]
    alpha = typical(prim)
    demo = make_demo(np.random.default_rng(5), np.array([0.2, -0.2, 0.1, 0.0, 0.3, -0.6]))
    obs = Observation.from_demo(model, demo, n_observed, ["hand"])
    vias = points(np.random.default_rng(9))
    mean, cov = dense.condition_on_everything(model, prim, alpha, obs, vias)
    # the observation first (the posterior of Eq. 8), then the points
    after = condition_on_via_points(model, condition(model, prim, obs, alpha), vias, alpha)
    assert_allclose(after.mean, mean, rtol=1e-7, atol=1e-9)
    assert_allclose(after.cov, cov, rtol=1e-6, atol=1e-12)
    # the points first, then the observation on that prior
    before = condition(model, prim, obs, alpha,
                       prior=condition_on_via_points(model, prim, vias, alpha))  # fmt: skip
    assert_allclose(before.mean, mean, rtol=1e-7, atol=1e-9)
    assert_allclose(before.cov, cov, rtol=1e-6, atol=1e-12)


def test_points_at_once_equal_points_one_by_one(model) -> None:
    prim = model.primitives[1]
    alpha = typical(prim)
    vias = points(np.random.default_rng(4))
    together = condition_on_via_points(model, prim, vias, alpha)
    one_by_one = condition_on_via_points(model, prim, vias[:1], alpha)
    for point in reversed(vias[1:]):
        one_by_one = condition_on_via_points(model, one_by_one, [point], alpha)
    assert_allclose(one_by_one.mean, together.mean, rtol=1e-8, atol=1e-10)
    assert_allclose(one_by_one.cov, together.cov, rtol=1e-6, atol=1e-12)


def test_a_time_is_a_phase_at_the_speed_given(model) -> None:
    prim = model.primitives[0]
    alpha = typical(prim)
    duration = float(duration_from_alpha(alpha, model.sample_period, model.settings.s_bar))
    by_time = ViaPoint.isotropic(HAND, [0.1, 0.0, 0.05], 0.01, time=0.25 * duration)
    by_phase = ViaPoint.isotropic(HAND, [0.1, 0.0, 0.05], 0.01, phase=0.25)
    a = condition_on_via_points(model, prim, [by_time], alpha)
    b = condition_on_via_points(model, prim, [by_phase], alpha)
    assert_allclose(a.mean, b.mean, rtol=1e-10)


def test_nothing_is_modified_and_the_model_file_is_unchanged(model) -> None:
    prim = model.primitives[0]
    alpha = typical(prim)
    exported = model_to_json(model)
    prior = Gaussian(prim.mean_at(alpha), prim.cov.copy())
    kept = prior.mean.copy(), prior.cov.copy()
    vias = points(np.random.default_rng(1))
    post = condition_on_via_points(model, prior, vias, alpha)
    assert post is not prior and post.mean is not prior.mean and post.cov is not prior.cov
    assert_array_equal(prior.mean, kept[0])
    assert_array_equal(prior.cov, kept[1])
    assert model_to_json(model) == exported


def test_bad_input_is_a_clear_error(model) -> None:
    prim = model.primitives[0]
    alpha = typical(prim)
    with pytest.raises(ValueError, match="columns are"):
        condition_on_via_points(model, prim, [ViaPoint.isotropic(("q",), [0.0], 0.01, phase=0.5)],
                                alpha)  # fmt: skip
    with pytest.raises(ValueError, match="after the end"):
        condition_on_via_points(model, prim, [ViaPoint.isotropic(("z",), [0.0], 0.01, time=1e3)],
                                alpha)  # fmt: skip
    with pytest.raises(ValueError, match="needs the speed alpha"):
        condition_on_via_points(model, prim, [])
    with pytest.raises(ValueError, match="needs the speed alpha"):
        condition_on_via_points(model, Gaussian(prim.mean, prim.cov),
                                [ViaPoint.isotropic(("z",), [0.0], 0.01, time=0.1)])  # fmt: skip
    with pytest.raises(ValueError, match="weights"):
        condition_on_via_points(model, Gaussian(np.zeros(3), np.eye(3)), [])
    with pytest.raises(ValueError, match=r"phase must be in \[0, 1\]"):
        ViaPoint.isotropic(HAND, [0, 0, 0], 0.01, phase=1.5)
    with pytest.raises(ValueError, match="either a phase"):
        ViaPoint.isotropic(HAND, [0, 0, 0], 0.01)
    with pytest.raises(ValueError, match="either a phase"):
        ViaPoint.isotropic(HAND, [0, 0, 0], 0.01, phase=0.5, time=0.2)
    with pytest.raises(ValueError, match="3 finite values"):
        ViaPoint.isotropic(HAND, [0, 0], 0.01, phase=0.5)
    with pytest.raises(ValueError, match="positive definite"):
        ViaPoint(HAND, [0, 0, 0], np.diag([1e-4, 0.0, 1e-4]), phase=0.5)
    with pytest.raises(ValueError, match="symmetric"):
        ViaPoint(("x", "y"), [0, 0], [[1.0, 0.5], [0.0, 1.0]], phase=0.5)
    with pytest.raises(ValueError, match="distinct columns"):
        ViaPoint.isotropic(("x", "x"), [0, 0], 0.01, phase=0.5)
    with pytest.raises(ValueError, match="standard deviation must be positive"):
        ViaPoint.isotropic(HAND, [0, 0, 0], 0.0, phase=0.5)
    with pytest.raises(ValueError, match="time must be >= 0"):
        ViaPoint.isotropic(HAND, [0, 0, 0], 0.01, time=-1.0)


def test_a_via_point_keeps_what_it_was_given_read_only(model) -> None:
    """The columns as a tuple of names, the values and covariance as float arrays that cannot
    be written, a phase or time as a float; the edges of what is accepted: the phases 0 and 1,
    the time 0."""
    point = ViaPoint(["x", "z"], [1, 2], [[1, 0], [0, 4]], phase=1)
    assert point.columns == ("x", "z") and isinstance(point.columns, tuple)
    assert point.values.dtype == float and point.cov.dtype == float
    assert_array_equal(point.values, [1.0, 2.0])
    assert_array_equal(point.cov, [[1.0, 0.0], [0.0, 4.0]])
    assert type(point.phase) is float and point.phase == 1.0 and point.time is None
    for array in (point.values, point.cov):
        with pytest.raises(ValueError):
            array[0] = 5.0
    assert ViaPoint.isotropic(("x",), [0.0], 0.1, phase=0).phase == 0.0
    at_start = ViaPoint.isotropic(("x",), [0.0], 0.1, time=0)
    assert type(at_start.time) is float and at_start.time == 0.0 and at_start.phase is None
    assert at_start.phase_at(model, 1.0) == 0.0
    assert_array_equal(ViaPoint.isotropic(HAND, [1, 2, 3], 0.5, phase=0.5).cov,
                       0.25 * np.eye(3))  # fmt: skip


def test_a_time_at_the_end_is_the_phase_1(model) -> None:
    """A time equal to the movement's duration at alpha (or past it by round-off) is the phase
    1 exactly; a little later is refused; a phase is the phase whatever alpha."""
    alpha = typical(model.primitives[0])
    duration = float(duration_from_alpha(alpha, model.sample_period, model.settings.s_bar))
    assert ViaPoint.isotropic(("z",), [0.0], 0.1, time=duration).phase_at(model, alpha) == 1.0
    for late in (duration * (1.0 + 5e-10), duration * (1.0 + 1e-9)):  # the bound itself too
        assert ViaPoint.isotropic(("z",), [0.0], 0.1, time=late).phase_at(model, alpha) == 1.0
    half = ViaPoint.isotropic(("z",), [0.0], 0.1, time=0.5 * duration)
    assert half.phase_at(model, alpha) == pytest.approx(0.5, rel=1e-12)
    with pytest.raises(ValueError):
        ViaPoint.isotropic(("z",), [0.0], 0.1, time=duration * 1.001).phase_at(model, alpha)
    assert ViaPoint.isotropic(("z",), [0.0], 0.1, phase=0.3).phase_at(model, None) == 0.3


def test_the_design_places_each_column_in_its_block(model) -> None:
    """``via_point_design``: a row per column of each point, the basis at the point's phase in
    the block of its column's weights; the targets in order; the points' covariances on the
    diagonal, blocks apart; none gives empty arrays."""
    from promp.via_points import via_point_design

    m, p = model.basis.n_basis, model.n_dims * model.basis.n_basis
    cov = np.array([[0.04, 0.01], [0.01, 0.09]])
    vias = [ViaPoint(("z", "x"), [1.0, 2.0], cov, phase=0.25),
            ViaPoint.isotropic(("yaw",), [3.0], 0.5, phase=0.75)]  # fmt: skip
    a, y, noise = via_point_design(model, vias)
    columns = list(model.layout.columns)
    want = np.zeros((3, p))
    for row, (column, phase) in enumerate((("z", 0.25), ("x", 0.25), ("yaw", 0.75))):
        d = columns.index(column)
        want[row, d * m : (d + 1) * m] = model.basis(np.array([phase]))[0]
    assert_array_equal(a, want)
    assert_array_equal(y, [1.0, 2.0, 3.0])
    assert_array_equal(noise, [[0.04, 0.01, 0.0], [0.01, 0.09, 0.0], [0.0, 0.0, 0.25]])
    empty = via_point_design(model, [])
    assert empty[0].shape == (0, p) and empty[1].shape == (0,) and empty[2].shape == (0, 0)


def test_more_bad_input_is_a_clear_error(model) -> None:
    """A bad speed even where no point needs it, a prior of another kind, a prior whose
    covariance alone has the wrong size, variances that leave S not positive definite, a
    non-finite standard deviation, values or covariance, a point given both ways or a
    negative phase: each a ValueError."""
    n = model.n_dims * model.basis.n_basis
    point = ViaPoint.isotropic(("z",), [0.0], 0.01, phase=0.5)
    for alpha in (0.0, -1.0, np.nan):
        with pytest.raises(ValueError):
            condition_on_via_points(model, Gaussian(np.zeros(n), np.eye(n)), [point], alpha)
    with pytest.raises(ValueError):
        condition_on_via_points(model, (np.zeros(n), np.eye(n)), [point], 1.0)
    with pytest.raises(ValueError):
        condition_on_via_points(model, Gaussian(np.zeros(n), np.eye(n - 1)), [], 1.0)
    with pytest.raises(ValueError):  # a prior of negative variances: S = A Sigma A^T + R < 0
        condition_on_via_points(model, Gaussian(np.zeros(n), -np.eye(n)), [point], 1.0)
    for std in (np.nan, np.inf, -0.1):
        with pytest.raises(ValueError):
            ViaPoint.isotropic(HAND, [0, 0, 0], std, phase=0.5)
    for bad in (dict(values=[0.0, np.nan]), dict(cov=[[1.0, 0.0], [0.0, np.inf]]),
                dict(cov=np.eye(3)), dict(values=[0.0, 0.0, 0.0])):  # fmt: skip
        given = {"values": [0.0, 0.0], "cov": np.eye(2), **bad}
        with pytest.raises(ValueError):
            ViaPoint(("x", "y"), given["values"], given["cov"], phase=0.5)
    for phase in (-0.01, np.nan, np.inf):
        with pytest.raises(ValueError):
            ViaPoint.isotropic(("x",), [0.0], 0.1, phase=phase)
    for time in (np.nan, np.inf):
        with pytest.raises(ValueError):
            ViaPoint.isotropic(("x",), [0.0], 0.1, time=time)
    with pytest.raises(ValueError):
        ViaPoint((), [], np.zeros((0, 0)), phase=0.5)


def test_values_of_any_shape_are_flattened_and_symmetry_is_checked_to_round_off() -> None:
    """A point's values given as a row are its k values; its covariance is symmetric to a
    relative 1e-9 (round-off passes, an asymmetry of 5e-9 of a 0.5 entry does not)."""
    point = ViaPoint(("x", "y"), [[1.0, 2.0]], np.eye(2), phase=0.5)
    assert point.values.shape == (2,)
    assert_array_equal(point.values, [1.0, 2.0])
    ViaPoint(("x", "y"), [0.0, 0.0], [[1.0, 0.5 * (1.0 + 1e-10)], [0.5, 1.0]], phase=0.5)
    with pytest.raises(ValueError):
        ViaPoint(("x", "y"), [0.0, 0.0], [[1.0, 0.5 + 5e-9], [0.5, 1.0]], phase=0.5)


@pytest.mark.parametrize("where", ["mean", "cov"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_prior_that_is_not_finite_is_refused_not_spread_to_every_weight(model, where, bad):
    prim = model.primitives[0]
    mean, cov = prim.mean_at(typical(prim)).copy(), prim.cov.copy()
    (mean if where == "mean" else cov)[3] = bad
    point = [ViaPoint.isotropic(HAND, [0.0, 0.0, 0.0], 0.01, phase=0.5)]
    given = (mean.copy(), cov.copy())
    with pytest.raises(ValueError, match="must be finite"):
        condition_on_via_points(model, Gaussian(mean, cov), point)
    np.testing.assert_array_equal(mean, given[0])  # nothing changed
    np.testing.assert_array_equal(cov, given[1])
