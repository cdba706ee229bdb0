"""The tube styles (issue 28, item 5): what each draws, the outline's geometry, the view state
that holds the one choice. No browser: tests/test_app_tube_style.py drives the studio."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.core.view_state import BANDS_1SD, BANDS_2SD, NO_TUBES, OUTLINE, TUBE_STYLES, View
from app.scene.tubes import (
    OUTLINE_RAILS,
    OUTLINE_RINGS,
    RING,
    TUBE_SIDE,
    outline_segments,
    tube_look,
    tube_vertices,
)

N = 50


def straight_tube(n_sigma: float) -> np.ndarray:
    mean = np.linspace([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], N)
    return tube_vertices(mean, np.full((N, 3), 0.01), n_sigma=n_sigma)


def radius(vertices: np.ndarray) -> float:
    """The mean distance of a straight tube's vertices from its axis (the x axis)."""
    return float(np.linalg.norm(vertices[:, 1:], axis=1).mean())


def test_each_style_draws_a_band_an_outline_or_nothing() -> None:
    two, one = tube_look(BANDS_2SD), tube_look(BANDS_1SD)
    assert two.surface and one.surface and not two.outline and not one.outline
    assert_allclose(radius(straight_tube(two.n_sigma)), 0.02, rtol=1e-5)
    assert_allclose(radius(straight_tube(one.n_sigma)), 0.01, rtol=1e-5)  # half as wide
    outline = tube_look(OUTLINE)
    assert outline.outline and not outline.surface and outline.n_sigma == 2.0
    assert not tube_look(NO_TUBES).shown
    assert all(tube_look(style).shown for style in TUBE_STYLES if style != NO_TUBES)
    with pytest.raises(ValueError, match="unknown tube style"):
        tube_look("blobs")


def test_the_surface_is_drawn_from_inside_so_lines_within_stay_above_it() -> None:
    """The faces drawn are the far wall's: a demonstration's line inside the tube is nearer
    the camera than any of them, and the depth test keeps it whole."""
    assert TUBE_SIDE == "back"


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
    assert view.state.tube_style == BANDS_2SD  # as before: ±2σ bands
    view.set_tube_style("".join(OUTLINE))  # an equal string from a browser
    assert view.state.tube_style is OUTLINE  # the constant (compared cheaply each frame)
    with pytest.raises(ValueError, match="unknown tube style"):
        view.set_tube_style("wireframe")
    assert view.state.tube_style is OUTLINE
