"""Recognition over the whole movement (the Infer tab's "Recognition probability vs observed %"
chart): the earliest point from which it stays right, the curve against the scrub step, and in
a real browser the chart following the slider, a click on it moving the slider, and the
slider's arrow keys that no longer turn the 3D camera."""

from __future__ import annotations

import time

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.core.fits import held_out_training
from app.live.inference import inferred
from app.live.recognition_curve import (
    CurveCache,
    RecognitionCurve,
    earliest_right,
    recognition_curve,
)
from app.panels.infer.recognition import TITLE, chart_data
from app.ui.display import observed_choices
from promp.inference import Observation
from promp.learn import fit
from promp.model import Settings
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT
from tests.browser import camera_reports, choose, server_caught_up, wait_camera_still
from tests.conftest import PageSpec, wait_until

# ---------------------------------------------------------------------- pure logic


def test_earliest_right_is_where_the_last_wrong_run_ends() -> None:
    percents = [10, 20, 30, 40, 50]
    assert earliest_right(percents, [1, 0, 0, 0, 0], truth=0) == 20
    assert earliest_right(percents, [0, 1, 0, 1, 0], truth=0) == 50  # right again only at 50
    assert earliest_right(percents, [0, 0, 0, 0, 0], truth=0) == 10
    assert earliest_right(percents, [0, 0, 0, 0, 1], truth=0) is None  # wrong at the end
    assert earliest_right(percents, [0, -1, 0, 0, 0], truth=0) == 30  # no recognition: wrong
    assert earliest_right([], [], truth=0) is None
    with pytest.raises(ValueError, match="one recognition per percentage"):
        earliest_right([10, 20], [0], truth=0)
    with pytest.raises(ValueError, match="increase"):
        earliest_right([20, 10], [0, 0], truth=0)


def a_curve(truth: str | None = "a") -> RecognitionCurve:
    percents = np.arange(1.0, 101.0)
    p_a = np.clip((percents - 20.5) / 20.0, 0.0, 1.0)  # wrong until 30 %, then right
    probabilities = np.column_stack([p_a, 1.0 - p_a])
    probabilities[4] = np.nan  # a percentage the engine could not explain
    return RecognitionCurve(("a", "b"), percents, probabilities, truth)


def test_a_curve_knows_what_it_recognised_and_from_when_it_is_right() -> None:
    curve = a_curve()
    assert curve.recognised[4] == -1 and curve.recognised[0] == 1 and curve.recognised[-1] == 0
    assert curve.right_from == 31.0  # p(a) = 0.525 > 0.5 from 31 % on
    assert a_curve(truth=None).right_from is None
    assert a_curve(truth="b").right_from is None


def test_chart_data_draws_the_cursor_and_the_marker_as_vertical_segments() -> None:
    curve = a_curve()
    x, p_a, p_b, cursor, marker = chart_data(curve, 45.0)
    assert np.all(np.diff(x) >= 0) and x.shape == (104,)  # 100 + 2 for each mark
    for column, where in ((cursor, 45.0), (marker, 31.0)):
        drawn = np.flatnonzero(np.isfinite(column))
        assert drawn.size == 2 and drawn[1] == drawn[0] + 1
        assert_allclose(x[drawn], where)
        assert_allclose(column[drawn], [0.0, 100.0])
    assert_allclose(p_a[x == 45.0], 100.0)  # p(a) = 1 from 40 %
    assert_allclose(p_a + p_b, 100.0)  # interpolated everywhere, the NaN row bridged
    cache = CurveCache(max_entries=2)
    for key in "xyz":
        cache.put(key, curve)
    assert cache.get("x") is None and cache.get("z") is curve and len(cache) == 2


@pytest.fixture(scope="module")
def scenario():
    from app.studio import default_workspace

    return default_workspace().demos


def test_the_curve_is_the_scrub_steps_probabilities_over_the_movement(scenario) -> None:
    """Each point of the curve is what the bars show at that slider position; the held-out
    curved demonstration is recognised early and stays recognised."""
    demo = scenario["curved"][2]
    model = fit(held_out_training(scenario, "curved", demo.name), LAYOUT, Settings(n_basis=12))
    observed = observed_choices(LAYOUT)["hand + head"]
    curve = recognition_curve(model, demo, observed, "ml", truth="curved")
    assert curve.probabilities.shape == (100, 2)
    for percent in (10, 45, 90):
        step = inferred(model, Observation.first(model, demo, percent, observed), "ml", demo)
        probabilities = step.inference.probabilities
        assert_allclose(curve.probabilities[percent - 1], probabilities, atol=1e-12)
    assert curve.right_from is not None and curve.right_from <= 60
    assert curve.recognised[-1] == 0


# ---------------------------------------------------------------------- in a real browser


def infer_panel(studio):
    from app.panels.infer import InferPanel

    return next(p for p in studio.panels if isinstance(p, InferPanel))


PAGE = PageSpec(width=1280, height=800, tab="Infer")


CHART_JS = """(title) => {
    const entry = Object.values(window.__viserTestpoints?.uplots ?? {}).find(
        (t) => t.chart.root.querySelector('.u-title')?.textContent === title);
    if (!entry) return null;
    const data = entry.chart.data.map((column) => Array.from(column));
    return {x: data[0], series: data.slice(1), labels: entry.chart.series.map((s) => s.label)};
}"""


def chart_in_page(page) -> dict | None:
    return page.evaluate(CHART_JS, TITLE)


def cursor_in_page(page) -> float | None:
    """Where the chart in the page draws its slider cursor (the series labelled 'slider')."""
    chart = chart_in_page(page)
    if chart is None or "slider" not in chart["labels"]:
        return None
    column = chart["series"][chart["labels"].index("slider") - 1]
    drawn = [x for x, v in zip(chart["x"], column, strict=True) if v is not None and v == v]
    return drawn[0] if drawn else None


@pytest.mark.browser
def test_the_chart_follows_the_slider_and_a_click_on_it_moves_the_slider(studio, page) -> None:
    panel = infer_panel(studio)
    choose(page, panel.controls.primitive, "curved")
    choose(page, panel.controls.demo, "curved_002")
    panel.controls.percent.value = 40
    curve = wait_until(
        lambda: panel.recognition.curve() if "curved_002" in (panel.recognition.key or ())
        else None,
        timeout=120, what="the recognition curve computed",
    )  # fmt: skip
    assert curve.names == ("curved", "direct") and curve.truth == "curved"
    wait_until(lambda: cursor_in_page(page) == 40, timeout=60, what="the cursor at 40 %")
    chart = chart_in_page(page)
    assert chart["labels"][1:3] == ["curved", "direct"]
    i = chart["x"].index(90.0)
    assert_allclose(chart["series"][0][i], 100 * curve.probabilities[89, 0], atol=1e-9)
    verdict = page.locator("p", has_text="Right from")
    expected = f"Right from {curve.right_from:g} %"
    wait_until(
        lambda: verdict.count() and expected in verdict.first.inner_text(),
        timeout=60, what=lambda: f"{expected!r} (page: {verdict.all_inner_texts()})",
    )  # fmt: skip
    # The slider moves the cursor (the curve is not computed again).
    computed = panel.recognition.worker.computed
    root = page.locator(f"[id='{panel.controls.percent._impl.uuid}']")
    box = root.bounding_box()
    page.mouse.click(box["x"] + 0.8 * box["width"], box["y"] + box["height"] / 2)
    wait_until(lambda: 75 <= panel.controls.percent.value <= 85, timeout=60,
               what="the slider near 80 %")  # fmt: skip
    wait_until(lambda: cursor_in_page(page) == panel.controls.percent.value, timeout=60,
               what="the cursor following the slider")  # fmt: skip
    assert panel.recognition.worker.computed == computed
    # A click on the chart moves the slider to the percentage clicked.
    over = page.locator(".uplot", has_text=TITLE).locator(".u-over")
    box = over.bounding_box()
    page.mouse.click(box["x"] + 0.25 * box["width"], box["y"] + box["height"] / 2)
    wait_until(lambda: 23 <= panel.controls.percent.value <= 27, timeout=60,
               what="the slider near 25 %")  # fmt: skip
    wait_until(lambda: cursor_in_page(page) == panel.controls.percent.value, timeout=60,
               what="the cursor at the clicked percentage")  # fmt: skip
    # Another setting is another curve, cached: back to the first costs nothing.
    choose(page, panel.controls.observed, "head")
    wait_until(lambda: panel.recognition.worker.computed == computed + 1, timeout=120,
               what="the head-only curve")  # fmt: skip
    choose(page, panel.controls.observed, "hand + head")
    wait_until(lambda: panel.recognition.curve() is curve, timeout=60, what="the cached curve")
    assert panel.recognition.worker.computed == computed + 1


@pytest.mark.browser
def test_arrow_keys_move_the_slider_and_not_the_camera(studio, page) -> None:
    """viser turns the camera on the arrow keys anywhere but in a text field; the page's
    script keeps them for the slider that has the focus (and for the camera otherwise)."""
    panel, client = infer_panel(studio), page.client
    panel.controls.percent.value = 50
    thumb = page.locator(f"[id='{panel.controls.percent._impl.uuid}']").get_by_role("slider")
    # The keys step from the value the page shows: wait for the page (not the server, whose
    # value is set at once) to show 50, or the first presses step from the previous value.
    wait_until(lambda: thumb.get_attribute("aria-valuenow") == "50", timeout=60,
               what="the page's slider at 50 %")  # fmt: skip
    thumb.focus()
    wait_camera_still(client)
    wxyz, position = np.array(client.camera.wxyz), np.array(client.camera.position)
    reports = camera_reports(client)
    seen = len(reports.poses)
    for _ in range(5):
        page.keyboard.press("ArrowLeft")
    page.keyboard.down("ArrowLeft")  # held for a second: 50 degrees of orbit in viser
    time.sleep(1.0)
    page.keyboard.up("ArrowLeft")
    wait_until(lambda: panel.controls.percent.value <= 44, timeout=30,
               what="the slider moved by keys")  # fmt: skip
    # Had the keys turned the camera, the page's reports would come before the probe's.
    probe = server_caught_up(studio, client)
    for _, at, _looking in reports.poses[seen:probe]:
        assert_allclose(at, position, atol=1e-9)
    assert page.evaluate("window.__icubStudio.stoppedKeys") >= 6
    wxyz = np.array(client.camera.wxyz)  # the probe put the camera back
    # With the 3D view focused, the same key turns the camera (the test can see it).
    page.evaluate("document.activeElement.blur()")
    page.keyboard.down("ArrowLeft")
    time.sleep(0.5)
    page.keyboard.up("ArrowLeft")
    wait_until(lambda: np.abs(np.array(client.camera.wxyz) - wxyz).max() > 0.01, timeout=30,
               what="the camera turned by the key")  # fmt: skip
    assert panel.controls.percent.value <= 44
