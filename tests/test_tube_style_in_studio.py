"""Readable on real data (issue 28, item 5) and the phase estimate seen in Infer (issue 25,
item 4), in a real browser: the tube style chosen in Teach changes what 3D draws (and Infer's
Display folder follows), Frame paths frames the demonstrations in Infer (not one inference
beside the dragged hand's gizmo), and the Infer tab shows the believed share of the movement
with its interval beside the true one, and the predicted end's interval on its charts."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pytest

from app.core.view_state import NO_TUBES, OUTLINE, REGION_50, REGION_90
from app.panels.infer import InferPanel
from app.panels.teach import TeachPanel
from app.scene.camera import FRAME, PANEL_PX
from app.scene.inference_layer import darker
from app.scene.tubes import TUBE_SIDE, region_vertices
from robots.icub.layout import hand_dims
from tests.browser import camera_pixels, camera_reports, press, settled_screenshot
from tests.conftest import PageSpec, open_page, wait_until

WIDTH, HEIGHT = 1400, 900


def inference_shown(page, studio) -> None:
    infer = panel(studio, InferPanel)
    wait_until(lambda: infer.view is not None and infer.view.result is not None
               and studio.scene.look.inference, timeout=180,
               what="an inference shown in 3D")  # fmt: skip


PAGE = PageSpec(tab="Infer", ready=inference_shown)  # on the default workspace


def panel(studio, kind):
    return next(p for p in studio.panels if isinstance(p, kind))


def pick(page, handle, option: str) -> None:
    """Choose ``option`` in dropdown ``handle`` by mouse, scrolled into the panel's view."""
    field = page.locator(f"[id='{handle._impl.uuid}']")
    field.scroll_into_view_if_needed(timeout=120_000)
    press(page, field)
    press(page, page.get_by_role("option", name=option, exact=True))
    wait_until(lambda: handle.value == option, timeout=120, what=f"{option!r} chosen")


def drawn(studio) -> tuple[list[bool], list[bool]]:
    """Whether each prior tube's surface and each outline is shown."""
    layer = studio.scene.workspace
    return ([t.visible for t in layer.tubes.values()],
            [o.visible for o in layer.outlines.values()])  # fmt: skip


@pytest.mark.browser
def test_the_tube_style_control_changes_what_is_drawn(browser, studio) -> None:
    teach, infer = panel(studio, TeachPanel), panel(studio, InferPanel)
    layer = studio.scene.workspace
    wait_until(lambda: len(layer.tubes) == 2 and all(drawn(studio)[0]), timeout=120,
               what="the two prior tubes, as 90 % regions")  # fmt: skip
    assert not any(drawn(studio)[1])
    # Drawn from inside: the demonstration lines within stay above the translucent tubes.
    assert all(tube.side == TUBE_SIDE == "back" for tube in layer.tubes.values())
    page, _client = open_page(browser, studio, dpr=1.0)
    try:
        dropdown = teach.prior.tubes.dropdown
        assert dropdown.value == REGION_90
        # Beside it, what the tubes are and the share of samples measured inside them.
        note = teach.prior.tube_note.content
        assert note.startswith("Tubes: at each moment, 90 % of a primitive's movements")
        assert re.search(r"measured: curved \d+ %, direct \d+ % of their demonstrations", note)
        pick(page, dropdown, NO_TUBES)
        wait_until(lambda: not any(drawn(studio)[0] + drawn(studio)[1]), timeout=120,
                   what="no tube node shown")  # fmt: skip
        assert all(line.visible for line in layer.lines.values())  # the lines stay
        # One choice for both tabs: Infer's Display folder shows it.
        wait_until(lambda: infer.controls.tubes.dropdown.value == NO_TUBES, timeout=60,
                   what="Infer's Tubes dropdown following")  # fmt: skip
        pick(page, dropdown, OUTLINE)
        wait_until(lambda: drawn(studio) == ([False, False], [True, True]), timeout=120,
                   what="the outlines alone")  # fmt: skip
        pick(page, dropdown, REGION_50)
        wait_until(lambda: drawn(studio) == ([True, True], [False, False]), timeout=120,
                   what="the bands again")  # fmt: skip
        # The 50 % region: the same regions at the radius that holds half of them.
        model = studio.session.snapshot().model
        for name, tube in layer.tubes.items():
            region = layer.prior_tube(model, name)
            wait_until(lambda t=tube, r=region: np.allclose(t.vertices, region_vertices(r, 0.5),
                                                            atol=1e-6),
                       timeout=60, what=f"{name}'s 50 % tube")  # fmt: skip
        wait_until(lambda: "50 %" in teach.prior.tube_note.content, timeout=60,
                   what="the line saying 50 %")  # fmt: skip
        page.mouse.move(10, 10)  # no tooltip over the picture
        settled_screenshot(page, Path("/tmp/tubes_50.png"))
    finally:
        page.close()
        studio.session.view.set_tube_style(REGION_90)


@pytest.mark.browser
def test_frame_paths_frames_the_demonstrations_not_the_gizmo(studio, page) -> None:
    client = page.client
    # A direct movement: its inference alone (framed by the old Frame paths) leaves the curved
    # demonstrations' arcs out of the picture.
    infer = panel(studio, InferPanel)
    pick(page, infer.controls.primitive, "direct")
    wait_until(lambda: infer.view.state.primitive == "direct" and infer.view.result is not None
               and studio.scene.look.inference, timeout=180,
               what="a direct movement inferred")  # fmt: skip
    # The dropdown's tooltip names the choice whole (a narrow field cuts a long name).
    assert infer.controls.primitive.hint.endswith("Chosen: direct")
    assert infer.controls.demo.hint.endswith(f"Chosen: {infer.controls.demo.value}")
    store = studio.session.snapshot().store
    cols = hand_dims(store.layout)
    points = np.concatenate(
        [store.layout.extract(d)[:, cols] for items in store.demos.values() for d in items]
    )
    reports = camera_reports(client)
    start = len(reports.poses)
    before = np.array(client.camera.position)
    press(page, page.get_by_role("button", name=FRAME, exact=True))
    wait_until(lambda: any(np.linalg.norm(p[1] - before) > 1e-3 for p in reports.poses[start:]),
               timeout=120, what="the camera moved by Frame paths")  # fmt: skip
    width = WIDTH - PANEL_PX

    def framed() -> bool:
        pixels = camera_pixels(page, client, points)
        inside = bool(
            np.all(pixels[:, 0] > 0)
            and np.all(pixels[:, 0] < width)
            and np.all(pixels[:, 1] > 0)
            and np.all(pixels[:, 1] < HEIGHT)
        )
        span = np.ptp(pixels, axis=0)
        return inside and (span[0] > 0.4 * width or span[1] > 0.4 * HEIGHT)  # fmt: skip

    wait_until(framed, timeout=120, what=lambda: (
        "every demonstration in the picture, filling it: pixels from "
        f"{np.nanmin(camera_pixels(page, client, points), axis=0)} to "
        f"{np.nanmax(camera_pixels(page, client, points), axis=0)}"))  # fmt: skip
    # The dragged hand's gizmo does not decide the framing: the look-at point is the paths'.
    lo, hi = points.min(axis=0), points.max(axis=0)
    look_at = np.array(client.camera.look_at)
    centre_gap = np.linalg.norm(look_at - 0.5 * (lo + hi))
    assert centre_gap < np.linalg.norm(hi - lo), (look_at, lo, hi)


PHASE = re.compile(
    r"Phase: observed ≈ (\d+) % \(90 %: (\d+)–(\d+) %\) · true (\d+) %, (inside|outside)"
)


@pytest.mark.browser
def test_the_readout_shows_the_phase_and_the_charts_the_end_interval(studio, page) -> None:
    from PIL import Image

    infer = panel(studio, InferPanel)
    status = page.locator("div", has_text=re.compile(r"^Recognised:")).last
    match = wait_until(lambda: PHASE.search(page.inner_text("body")), timeout=120,
                       what="the phase line in the Infer tab")  # fmt: skip
    result = infer.view.result
    timing = result.inference.timing
    believed, low, high, true = (int(match.group(k)) for k in (1, 2, 3, 4))
    assert (believed, low, high) == tuple(
        round(100 * v) for v in (timing.observed_fraction.value, timing.observed_fraction.low,
                                 timing.observed_fraction.high)
    )  # fmt: skip
    assert true == round(100 * result.inference.observed_until / result.truth.duration)
    assert match.group(5) == ("inside" if low <= true <= high else "outside")
    assert status is not None
    duration = timing.duration
    assert f"Duration: predicted {duration.value:.2f} s (90 %: {duration.low:.2f}–" in (
        page.inner_text("body")
    )
    # The charts: a vertical line at the predicted end, in the darker posterior colour, which
    # nothing else on a chart is drawn in.
    color = np.array(darker(studio.session.snapshot().store.color(result.inference.primitive)))
    canvas = page.locator(".uplot:visible", has_text="hand x (cm)").first.locator("canvas")
    canvas.scroll_into_view_if_needed(timeout=120_000)

    def end_pixels() -> int:
        image = np.asarray(Image.open(io.BytesIO(canvas.screenshot())).convert("RGB"), float)
        near = np.linalg.norm(image - color, axis=2) < 30
        return int(near.any(axis=0).sum() and near.sum(axis=0).max())

    wait_until(
        lambda: end_pixels() > 40,
        timeout=120,
        what=lambda: f"a vertical end line on the chart ({end_pixels()} px tall)",
    )
    page.mouse.move(10, 10)
    settled_screenshot(page, Path("/tmp/infer_end.png"))
