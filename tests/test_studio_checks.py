"""Faulty recordings in the studio, in a real browser: the import preview lists what the checks
found (file, time, size), the flagged demonstration is marked "left out" in Teach with the
finding beside it, drawn grey and not learned from; one click keeps it (stored in the
workspace, its file untouched), and its gap is repaired on request into new demonstrations."""

from __future__ import annotations

import numpy as np
import pytest

from app.scene.workspace_layer import NO_COLOR
from promp.data import Demonstration
from promp.datasets import demo_to_csv
from tests.browser import (
    choose,
    click,
    notification,
    open_tab,
    press,
    settled_screenshot,
    upload_file,
)
from tests.conftest import StudioSpec, open_page, wait_until
from tests.test_dataset_import import zip_of

STUDIO = StudioSpec(seed=2, n_demos=3)


def paused(demo: Demonstration) -> Demonstration:
    """``demo`` with a 20 s pause of its timestamps after the middle sample."""
    times = demo.times.copy()
    times[demo.n_samples // 2 :] += 20.0
    return Demonstration(times, demo.values, demo.columns, "paused")


@pytest.mark.browser
def test_a_flagged_demonstration_is_shown_left_out_and_kept_with_one_click(
    browser, studio, artifacts
) -> None:
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=3, n_demos=5)
    members = {f"{p}/{d.name}.csv": demo_to_csv(d).encode() for p, v in dataset.items() for d in v}
    gap = paused(dataset["curved"][2])
    members["curved/paused.csv"] = demo_to_csv(gap).encode()
    page, _ = open_page(browser, studio)
    try:
        open_tab(page, "Data")
        from app.panels.data import DataPanel

        section = next(p for p in studio.panels if isinstance(p, DataPanel)).importer
        upload_file(page, section.upload_button, "takes.zip", zip_of(members))
        page.get_by_text("Checks: 1 finding(s) in 1 demonstration(s)").wait_for()
        at = gap.times[gap.n_samples // 2 - 1]
        text = f"curved/paused.csv: a 20 s gap in the timestamps at {at:.3g} s"
        page.get_by_text(text).wait_for()
        click(page, "Create workspace")
        notification(page, "Workspace created")
        session = studio.session
        store = session.store
        wait_until(lambda: store.state.workspace.root.name == "takes", what="the new workspace")
        key = ("curved", "paused")
        assert list(store.state.left_out) == [key]

        def model():
            snapshot = session.snapshot()
            return None if snapshot.refitting else snapshot.model

        model = wait_until(model, timeout=120, what="the model")
        assert model.primitive("curved").n_demos == 5  # learned without it

        open_tab(page, "Teach")
        from app.panels.teach import TeachPanel

        teach = next(p for p in studio.panels if isinstance(p, TeachPanel))
        choose(page, teach.primitives.dropdown, "curved")
        page.get_by_text("paused · ⚠ left out").wait_for()
        page.get_by_text("⚠ 1 flagged (Keep learns from one anyway):").wait_for()
        page.get_by_text("paused (left out of learning): a 20 s gap").wait_for()
        page.mouse.move(5, 450)
        settled_screenshot(page, artifacts / "teach_flagged.png")
        lines = studio.scene.workspace.lines
        wait_until(lambda: key in lines, what="the line of the flagged demonstration")
        assert tuple(lines[key].color) == NO_COLOR  # drawn grey: not learned from

        before = store.state.workspace.demo_path(*key).read_bytes()
        press(page, page.get_by_role("button", name="Keep", exact=True))
        notification(page, "Kept", "paused is learned from despite its findings")
        wait_until(lambda: store.state.checks.kept == {key}, what="the choice stored")
        page.get_by_text("paused · ⚠ kept despite findings").wait_for()
        colour = store.state.color("curved")
        wait_until(lambda: tuple(lines[key].color) == colour, what="its line in its colour")
        model = wait_until(
            lambda: None if session.snapshot().refitting else session.snapshot().model,
            timeout=120, what="a refit",
        )  # fmt: skip
        assert model.primitive("curved").n_demos == 6
        assert '"kept": [\n   [\n    "curved",\n    "paused"' in (
            store.state.workspace.index_path.read_text()
        )
        assert store.state.workspace.demo_path(*key).read_bytes() == before
        assert np.isfinite(model.primitive("curved").mean).all()

        # Repair on request: split at the gap, two new demonstrations beside the original.
        press(page, page.get_by_role("button", name="Repair gap", exact=True))
        page.get_by_text("Repair the gap of").wait_for()
        click(page, "Split at the gap")  # below the fold: a click event, as a scrolled page
        notification(page, "Gap repaired", "paused-part1, paused-part2 made from paused")
        names = [d.name for d in store.state.demos["curved"]]
        assert names[-2:] == ["paused-part1", "paused-part2"] and "paused" in names
        assert store.state.workspace.demo_path(*key).read_bytes() == before
        assert not any(f.kind == "gap" for f in store.state.findings_of("curved", "paused-part1"))
    finally:
        page.close()
