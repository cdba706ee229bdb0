"""A hand recorded elsewhere: how much of it the iCub reaches, and a placement that fixes it; a
partner's position recorded in the partner's frame, placed beside the scene's partner."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robots.icub.placement import (
    IN_REACH,
    PARTNER_ORIGIN,
    Placement,
    guess_placement,
    partner_placement,
    reach_share,
)
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


@pytest.mark.parametrize("facing_deg", [0.0, 90.0, 180.0, -120.0])
def test_a_partners_position_goes_in_front_of_the_partner_whichever_way_its_axes_point(
    facing_deg,
) -> None:
    """A hand recorded in the partner's frame, whose x axis points ``facing_deg`` away from
    where the partner faces: placed at the partner's shoulders, turned so that the hand's
    median is in front of the partner, towards the robot (+x from the partner at x = -1)."""
    rng = np.random.default_rng(1)
    ahead = np.array([0.35, 0.05, -0.15]) + rng.normal(scale=0.05, size=(200, 3))  # reaching
    turn = Placement(yaw=math.radians(-facing_deg))
    placement = partner_placement(turn.apply(ahead))
    assert placement.translation == pytest.approx(PARTNER_ORIGIN)
    placed = placement.apply(turn.apply(ahead))
    # the same as for the partner's axes as the studio's (x forward): the lab's turn undone
    assert_allclose(placed, partner_placement(ahead).apply(ahead), atol=1e-9)
    assert np.median(placed[:, 0]) > PARTNER_ORIGIN[0] + 0.25  # in front, towards the robot
    assert np.all(placed[:, 0] < -0.3)  # and far from the robot's body


def test_a_partners_position_at_its_origin_or_absent_is_not_turned() -> None:
    assert partner_placement(np.zeros((0, 3))) == Placement(PARTNER_ORIGIN)
    assert partner_placement(np.array([[0.01, -0.02, 0.3]])) == Placement(PARTNER_ORIGIN)
    assert partner_placement(np.array([[np.nan, 0.0, 0.0]])) == Placement(PARTNER_ORIGIN)
