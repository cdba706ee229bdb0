"""The tube styles: what each draws (a region of stated probability), the tube's cross-section
(the shadow of each 3-D ellipsoid on the plane normal to the path), the outline's geometry, the
view state that holds the one choice, the line that says what a tube is; a tube wider than its
workspace drawn as an outline, its width said. No browser: tests/test_tube_style_in_studio.py
drives the studio."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.core.view_state import NO_TUBES, OUTLINE, REGION_50, REGION_90, TUBE_STYLES, View
from app.live.regions import TUBE_POINTS, prior_shape
from app.scene.tube_scale import TubeWidth, drawn_look, tube_width, workspace_extent
from app.scene.tubes import (
    MIN_RADIUS,
    OUTLINE_RAILS,
    OUTLINE_RINGS,
    RING,
    TUBE_SIDE,
    TubeLook,
    outline_segments,
    region_vertices,
    ring_widths,
    tube_look,
    tube_vertices,
)
from app.ui.tube_style import measured_sentence, tube_sentence, wide_sentence
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
    calibrated = {"a": Coverage(45, 50, 0.9, 1.31), "b": Coverage(90, 100, 0.9, 0.85)}
    assert measured_sentence(calibrated) == (
        "Inside the 90 % tubes, measured: a 90 %, b 90 % of their demonstrations' samples. "
        "Each tube's width is calibrated to hold 90 % of its primitive's takes, each left out "
        "in turn (one Gaussian does not hold how takes vary in their timing within the "
        "movement): a widened ×1.31, b narrowed ×0.85."
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


# ---------------------------------------------------------------------- tubes too wide for a band


def test_a_rings_width_is_its_longest_diameter() -> None:
    """An elongated spread across a straight path: the ring's width is the ellipse's long
    axis, measured on the vertices drawn (opposite vertices of a ring of many)."""
    mean = np.linspace([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], N)
    a = np.diag([1e-4, 9e-2, 1e-4])  # 30 cm of spread sideways (y)
    region = SampleDistribution(np.linspace(0, 1, N), mean, np.broadcast_to(a, (N, 3, 3)))
    widths = ring_widths(region, 0.9)
    assert_allclose(widths, 2 * region_radius(0.9, 3) * 0.3)
    rings = tube_vertices(mean, region.cov, region_radius(0.9, 3), ring=64).reshape(N, 64, 3)
    across = np.linalg.norm(rings[:, :32] - rings[:, 32:], axis=2).max(axis=1)
    assert_allclose(across, widths, rtol=1e-3)
    assert_allclose(ring_widths(straight_region(0.0), 0.9), 2 * MIN_RADIUS)  # never thinner


def straight_region(sd: float, length: float = 1.0) -> SampleDistribution:
    mean = np.linspace([0.0, 0.0, 0.0], [length, 0.0, 0.0], N)
    return SampleDistribution(np.linspace(0, 1, N), mean,
                              np.broadcast_to(sd**2 * np.eye(3), (N, 3, 3)))  # fmt: skip


def test_a_tube_wider_than_its_workspace_is_drawn_as_an_outline_its_width_said() -> None:
    """A 90 % region 1.25 m wide (sd 25 cm) over paths that span 40 cm: an outline whatever
    the band style, and the line beside it says how wide it is and why; a 5 cm tube over the
    same paths stays a band, and says nothing more."""
    wide = tube_width("human", straight_region(0.25, 0.4), 0.9, extent=0.4)
    thin = tube_width("hand", straight_region(0.01, 0.4), 0.9, extent=0.4)
    assert wide.width == pytest.approx(2 * region_radius(0.9, 3) * 0.25) and wide.too_wide
    assert not thin.too_wide
    for style in (REGION_90, REGION_50):
        assert drawn_look(tube_look(style), wide) == TubeLook(
            tube_look(style).probability, surface=False, outline=True)  # fmt: skip
        assert drawn_look(tube_look(style), thin) == tube_look(style)
    assert drawn_look(tube_look(NO_TUBES), wide) == tube_look(NO_TUBES)
    said = tube_sentence(REGION_90, "give", widths=(thin, wide))
    assert said.endswith(" Drawn as an outline, wider than where the paths go: human's tube "
                         "125 cm wide (its paths span 40 cm).")  # fmt: skip
    two = wide_sentence((wide, TubeWidth("hand", 0.9, 0.3)))
    assert "Drawn as outlines" in two and "human's tube 125 cm wide" in two
    assert "hand's 90 cm wide (its paths span 30 cm)" in two
    assert tube_sentence(REGION_90, widths=(thin,)) == tube_sentence(REGION_90)
    assert tube_sentence(OUTLINE, widths=(wide,)) == tube_sentence(OUTLINE)  # outlines anyway


def test_a_workspace_is_the_span_of_every_primitives_mean_path() -> None:
    from app.studio import default_workspace
    from promp.learn import fit

    data = default_workspace()
    model = fit(data.demos, data.layout)
    points = np.concatenate([d.select(("x", "y", "z")) for v in data.demos.values() for d in v])
    extent = workspace_extent(model, "hand")
    assert 0.8 * np.ptp(points, axis=0).max() < extent <= np.ptp(points, axis=0).max()
    regions = [prior_shape(model, n).region(model, "hand", TUBE_POINTS) for n in model.names]
    assert not any(tube_width(n, r, 0.9, extent).too_wide
                   for n, r in zip(model.names, regions, strict=True))  # fmt: skip


@pytest.mark.parametrize("name", ["lab-records-heights", "lab-records-flt",
                                  "lab-records-flt-shapes"])  # fmt: skip
def test_no_prior_tube_of_the_shared_lab_sets_is_too_wide(name) -> None:
    """The rule draws no real set's prior tube as an outline: the widest is 0.47 of its
    workspace (flt-shapes' trajH1 tube, widened x1.33 by its calibration), under the 1 of
    WIDER_THAN."""
    from app.io.dataset_import import read_folder
    from app.ui.tube_style import prior_widths
    from promp.learn import fit
    from tests.conftest import SHARED_DATA

    if not (SHARED_DATA / name).is_dir():
        pytest.skip(f"shared lab recordings not found at {SHARED_DATA / name}")
    data, _ = read_folder(SHARED_DATA / name, "records")
    model = fit(data.demos, data.layout)
    widths = prior_widths(model, model.names, REGION_90, ())
    ratios = [w.width / w.extent for w in widths]
    assert len(widths) == len(model.names) and max(ratios) < 0.5, widths
