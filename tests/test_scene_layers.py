"""The scene owns its look: the Teach tab draws the workspace's demonstrations and priors, never
the Infer tab's inference, whatever the Infer tab's display options (it once drew no
demonstration and Infer's posterior after Infer's "faded" priors); Infer draws its inference with
the priors as it asks. Once from Python, once with a real browser's clicks."""

from __future__ import annotations

import pytest

from app.scene.look import FADED, INFER, SHOWN, TEACH
from app.scene.workspace_layer import DIMMED_OPACITY, PRIOR_OPACITY
from tests.browser import choose, open_tab, press
from tests.conftest import StudioSpec, open_page, wait_until


def first_inference(studio):
    infer = infer_panel(studio)
    return infer.view is not None and infer.view.result is not None


STUDIO = StudioSpec(ready=first_inference)


def infer_panel(studio):
    from app.panels.infer import InferPanel

    return next(p for p in studio.panels if isinstance(p, InferPanel))


def teach_panel(studio):
    from app.panels.teach import TeachPanel

    return next(p for p in studio.panels if isinstance(p, TeachPanel))


def drawn(studio) -> dict:
    """What the scene shows: visible demonstration lines, each tube's (visible, opacity), and
    whether the posterior tube shows."""
    workspace = studio.scene.workspace
    return {
        "lines": sum(bool(line.visible) for line in workspace.lines.values()),
        "tubes": sorted({(bool(t.visible), float(t.opacity)) for t in workspace.tubes.values()}),
        "posterior": bool(studio.scene.inference.tube.visible),
    }


TEACH_LOOK = {"lines": 40, "tubes": [(True, PRIOR_OPACITY)], "posterior": False}
INFER_FADED = {"lines": 0, "tubes": [(True, DIMMED_OPACITY)], "posterior": True}


def test_teach_draws_its_demos_and_priors_after_infer_faded_them(studio) -> None:
    infer = infer_panel(studio)
    try:
        infer.controls.session_mode.value = FADED
        studio.scene.use_panel(INFER)  # what using an Infer control from a browser does
        wait_until(lambda: drawn(studio) == INFER_FADED, timeout=30, what="Infer's look")
        studio.scene.use_panel(TEACH)
        wait_until(lambda: drawn(studio) == TEACH_LOOK, timeout=30, what="Teach's look")
        assert not any(node.visible for node in studio.scene.inference.nodes)
        studio.scene.use_panel(INFER)
        wait_until(lambda: drawn(studio) == INFER_FADED, timeout=30, what="Infer's look again")
    finally:
        infer.controls.session_mode.value = SHOWN
        studio.scene.use_panel(TEACH)
        wait_until(lambda: drawn(studio) == TEACH_LOOK, timeout=30, what="the workspace back")


@pytest.mark.browser
def test_switching_tabs_in_the_browser_never_leaves_the_other_tabs_objects(
    browser, studio, artifacts
) -> None:
    page, _client = open_page(browser, studio)
    try:
        infer, teach = infer_panel(studio), teach_panel(studio)
        # Faded is the default: start from shown, so that the browser's choice is a change
        # (viser tells the server of changes only) and the test stands alone.
        infer.controls.session_mode.value = SHOWN
        open_tab(page, "Infer")
        folder = page.get_by_text("Display", exact=True).last  # below the charts
        folder.scroll_into_view_if_needed(timeout=60_000)
        press(page, folder)  # it opens
        dropdown = page.locator(f"[id='{infer.controls.session_mode._impl.uuid}']")
        dropdown.wait_for(state="visible", timeout=60_000)
        dropdown.scroll_into_view_if_needed(timeout=60_000)
        choose(page, infer.controls.session_mode, FADED)
        wait_until(lambda: drawn(studio) == INFER_FADED, timeout=60, what=lambda: (
            f"Infer's look; drawn: {drawn(studio)}, panel in use: {studio.scene.panel}"))
        tab = page.get_by_role("tab", name="Teach")
        tab.scroll_into_view_if_needed(timeout=60_000)  # the panel was scrolled down
        press(page, tab)
        choose(page, teach.primitives.dropdown, "direct")
        wait_until(lambda: drawn(studio) == TEACH_LOOK, timeout=60, what="Teach's look")
        page.get_by_text("20 demonstration(s) of direct").wait_for(timeout=60_000)
        page.screenshot(path=str(artifacts / "teach_after_infer_faded.png"))
    finally:
        infer.controls.session_mode.value = SHOWN
        page.close()
