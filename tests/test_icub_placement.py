"""A hand recorded elsewhere: how much of it the iCub reaches, and a placement that fixes it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robots.icub.placement import IN_REACH, Placement, guess_placement, reach_share
from robots.icub.scenario import generate_scenario


@pytest.fixture(scope="module")
def hand() -> np.ndarray:
    demos = [d for v in generate_scenario(seed=0, n_demos=4).values() for d in v]
    return np.concatenate([d.select(["x", "y", "z"]) for d in demos])


def test_the_simulated_experiment_is_in_reach_and_a_baxter_frame_is_not(hand) -> None:
    assert reach_share(hand) >= 0.95
    elsewhere = hand + np.array([0.9, 0.3, -0.7])  # a base a metre away
    assert reach_share(elsewhere) < IN_REACH
    placed = guess_placement(elsewhere)
    assert reach_share(placed.apply(elsewhere)) >= IN_REACH


def test_a_placement_is_undone_exactly_and_travels_as_json() -> None:
    rng = np.random.default_rng(0)
    points = rng.normal(size=(20, 3))
    placement = Placement((0.1, -0.2, 0.3), math.radians(30))
    assert_allclose(placement.undo(placement.apply(points)), points, atol=1e-12)
    # a turn about the vertical: heights and distances unchanged
    moved = placement.apply(points)
    assert_allclose(moved[:, 2], points[:, 2] + 0.3)
    assert_allclose(np.linalg.norm(moved[1] - moved[0]), np.linalg.norm(points[1] - points[0]))
    assert Placement.from_json(placement.to_json()) == placement
    assert Placement().is_identity and not placement.is_identity
    for bad in ({"translation_m": [0, 0]}, {"translation_m": [0, 0, float("nan")], "yaw_rad": 0},
                {"yaw_rad": 1.0}, {"translation_m": "abc", "yaw_rad": 0}):  # fmt: skip
        with pytest.raises(ValueError, match="placement"):
            Placement.from_json(bad)
