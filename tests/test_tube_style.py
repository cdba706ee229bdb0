"""The tube styles: what each draws (a region of stated probability), the tube's cross-section
(the shadow of each 3-D ellipsoid on the plane normal to the path), the outline's geometry, the
view state that holds the one choice, the line that says what a tube is. No browser:
tests/test_tube_style_in_studio.py drives the studio."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.core.view_state import NO_TUBES, OUTLINE, REGION_50, REGION_90, TUBE_STYLES, View
from app.scene.tubes import (
    MIN_RADIUS,
    OUTLINE_RAILS,
    OUTLINE_RINGS,
    RING,
    TUBE_SIDE,
    outline_segments,
    region_vertices,
    tube_look,
    tube_vertices,
)
from app.ui.tube_style import measured_sentence, tube_sentence
from promp.region import Coverage, SampleDistribution, region_radius

N = 50


def straight_tube(radius: float, sd: float = 0.01) -> np.ndarray:
    mean = np.linspace([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], N)
    return tube_vertices(mean, np.broadcast_to(sd**2 * np.eye(3), (N, 3, 3)), radius)


def radius(vertices: np.ndarray) -> float:
    """The mean distance of a straight tube's vertices from its axis (the x axis)."""
    return float(np.linalg.norm(vertices[:, 1:], axis=1).mean())


def test_each_style_draws_a_band_an_outline_or_nothing() -> None:
    ninety, half = tube_look(REGION_90), tube_look(REGION_50)
    assert ninety.surface and half.surface and not ninety.outline and not half.outline
    assert (ninety.probability, half.probability) == (0.9, 0.5)
    outline = tube_look(OUTLINE)
    assert outline.outline and not outline.surface and outline.probability == 0.9
    assert not tube_look(NO_TUBES).shown
    assert all(tube_look(style).shown for style in TUBE_STYLES if style != NO_TUBES)
    with pytest.raises(ValueError, match="unknown tube style"):
        tube_look("blobs")


def test_the_surface_is_drawn_from_inside_so_lines_within_stay_above_it() -> None:
    """The faces drawn are the far wall's: a demonstration's line inside the tube is nearer
    the camera than any of them, and the depth test keeps it whole."""
    assert TUBE_SIDE == "back"


def test_a_ring_is_the_shadow_of_the_ellipsoid_on_the_normal_plane() -> None:
    """A straight path along x: the ring is the ellipse of the (y, z) block of the covariance
    at the radius that holds the probability; the spread along the path and its correlation
    with the others do not widen it beyond the shadow; a vanishing spread keeps MIN_RADIUS."""
    mean = np.linspace([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], N)
    a = np.array([[4.0, 1.0, 0.5], [1.0, 2.0, 0.6], [0.5, 0.6, 1.0]]) * 1e-4  # m^2
    region = SampleDistribution(np.linspace(0, 1, N), mean, np.broadcast_to(a, (N, 3, 3)))
    vertices = region_vertices(region, 0.9).reshape(N, RING, 3)
    r = region_radius(0.9, 3)
    shadow = np.linalg.inv(a[1:, 1:])  # the marginal of (y, z): the shadow's ellipse
    offsets = vertices[:, :, 1:].astype(float)  # (N, RING, 2), the axis at y = z = 0
    d2 = np.einsum("nri,ij,nrj->nr", offsets, shadow, offsets)
    assert_allclose(d2, r**2, rtol=2e-3)  # every vertex on the ellipse (MIN_RADIUS aside)
    assert_allclose(vertices[:, :, 0], mean[:, None, 0] * np.ones((1, RING)), atol=1e-6)
    thin = straight_tube(2.0, sd=0.0)
    assert_allclose(radius(thin), MIN_RADIUS, rtol=1e-3)
    # at 2.5 sd (90 % in 3-D) a round spread of 1 cm gives a 2.5 cm tube
    assert_allclose(radius(straight_tube(r)), 0.025, rtol=1e-3)


def test_the_line_beside_the_tubes_says_what_they_are() -> None:
    assert tube_sentence(REGION_90) == (
        "Tubes: at each moment, 90 % of a primitive's movements pass inside its tube "
        "(a 3-D region of the model)."
    )
    assert "50 % of top's movements that began like this one" in tube_sentence(REGION_50, "top")
    assert "shaped by 2 via-points" in tube_sentence(REGION_90, "top", vias=2)
    assert tube_sentence(NO_TUBES) == "Tubes off."
    shares = {"a": Coverage(45, 50, 0.9), "b": Coverage(99, 100, 0.9)}
    assert measured_sentence(shares) == (
        "Inside the 90 % tubes, measured: a 90 %, b 99 % of their demonstrations' samples."
    )


def test_the_outline_is_rings_and_lines_along_on_the_tube() -> None:
    vertices = straight_tube(2.0)
    segments = outline_segments(vertices)
    assert segments.shape == (OUTLINE_RINGS * RING + OUTLINE_RAILS * (N - 1), 2, 3)
    assert segments.dtype == np.float32
    # Every end is one of the tube's vertices, at the tube's radius.
    ends = segments.reshape(-1, 3)
    nearest = np.min(np.linalg.norm(ends[:, None, :] - vertices[None, :, :], axis=2), axis=1)
    assert nearest.max() < 1e-6
    assert_allclose(np.linalg.norm(ends[:, 1:], axis=1), 0.02, rtol=1e-5)
    # The rings close; the first and the last ring are at the tube's ends.
    rings = segments[: OUTLINE_RINGS * RING].reshape(OUTLINE_RINGS, RING, 2, 3)
    assert_allclose(rings[:, -1, 1], rings[:, 0, 0])
    assert_allclose(rings[[0, -1], :, 0, 0], [[0.0] * RING, [1.0] * RING], atol=1e-6)
    # Each line along runs from one end to the other.
    rails = segments[OUTLINE_RINGS * RING :].reshape(N - 1, OUTLINE_RAILS, 2, 3)
    assert_allclose(rails[0, :, 0, 0], 0.0, atol=1e-6)
    assert_allclose(rails[-1, :, 1, 0], 1.0, atol=1e-6)


def test_the_view_state_holds_one_style_for_both_tabs() -> None:
    view = View()
    assert view.state.tube_style == REGION_90
    view.set_tube_style("".join(OUTLINE))  # an equal string from a browser
    assert view.state.tube_style is OUTLINE  # the constant (compared cheaply each frame)
    with pytest.raises(ValueError, match="unknown tube style"):
        view.set_tube_style("wireframe")
    assert view.state.tube_style is OUTLINE
