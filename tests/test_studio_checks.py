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


@pytest.mark.browser
def test_round_trips_and_a_far_start_are_said_in_units_and_left_out_undoably(
    browser, studio, artifacts, tmp_path
) -> None:
    """The bad takes of a real iCub set (tests/bad_takes.py), imported from the Data tab: its
    preview lists the three with their sizes in centimetres; in Teach they are marked "left
    out", what was found beside them, every take with its typicality (imported ones are
    scored too); Keep learns from a round trip, Leave out undoes that."""
    from app.panels.data import DataPanel
    from app.panels.teach import TeachPanel
    from promp.datasets import read_dataset
    from tests.bad_takes import BAD, write_bad_takes
    from tests.test_dataset_import import zip_folder

    source = write_bad_takes(tmp_path / "bad-takes")
    expected = read_dataset(source, "csv").findings
    assert {f.key for f in expected} == BAD
    page, _ = open_page(browser, studio)
    try:
        open_tab(page, "Data")
        section = next(p for p in studio.panels if isinstance(p, DataPanel)).importer
        upload_file(page, section.upload_button, "bad-takes.zip", zip_folder(source))
        page.get_by_text("Checks: 5 finding(s) in 3 demonstration(s)").wait_for()
        for finding in expected:  # e.g. "...record0.csv: hand starts 7.13 cm from where ..."
            page.get_by_text(finding.describe()).wait_for()
        click(page, "Create workspace")
        notification(page, "Workspace created")
        session, key = studio.session, ("base_to_left_goal", "record1")
        store = session.store
        wait_until(lambda: store.state.workspace.root.name == "bad-takes",
                   what="the new workspace")  # fmt: skip
        assert set(store.state.left_out) == BAD
        wait_until(lambda: not store.state.checks.scores.pending, timeout=180,
                   what="the imported demonstrations scored")  # fmt: skip

        open_tab(page, "Teach")
        teach = next(p for p in studio.panels if isinstance(p, TeachPanel))
        choose(page, teach.primitives.dropdown, "base_to_left_goal")
        page.get_by_text("⚠ 2 flagged (Keep learns from one anyway):").wait_for()
        trip = next(f for f in expected if f.key == key and f.kind == "round_trip")
        page.get_by_text(f"record1 (left out of learning): {trip.message}").wait_for()
        score = session.snapshot().typicality[key]
        assert score.label == "outlier"
        row = page.locator("label", has_text="record1").first.locator(
            "xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]")  # fmt: skip
        wait_until(lambda: "record1 · ⚠ left out · ⚠ outlier (0th pct)" in row.inner_text(),
                   what=lambda: f"the flag and the score in {row.inner_text()!r}")
        typical = session.snapshot().typicality[("base_to_left_goal", "record5")]
        page.get_by_text(f"record5 · {typical.label}").wait_for()  # imported, scored too
        page.get_by_text("10 demonstration(s) of base_to_left_goal").evaluate(
            "e => e.scrollIntoView({block: 'start'})")  # the list and its flags in view
        page.mouse.move(5, 450)
        settled_screenshot(page, artifacts / "teach_round_trip.png")

        def learned() -> int | None:
            snapshot = session.snapshot()
            model = None if snapshot.refitting else snapshot.model
            return None if model is None else model.primitive("base_to_left_goal").n_demos

        assert wait_until(learned, timeout=120, what="the model") == 8
        press(page, row.get_by_role("button", name="Keep", exact=True))
        notification(page, "Kept", "record1 is learned from despite its findings")
        wait_until(lambda: learned() == 9, timeout=120, what="a refit with the round trip")
        page.get_by_text("record1 · ⚠ kept despite findings").wait_for()
        press(page, row.get_by_role("button", name="Leave out", exact=True))
        notification(page, "Left out", "record1 is left out of learning")
        wait_until(lambda: learned() == 8, timeout=120, what="a refit without it")
        assert set(store.state.left_out) == BAD and not store.state.checks.kept
        page.get_by_text("record1 · ⚠ left out").wait_for()
    finally:
        page.close()


def test_a_rows_label_says_left_out_or_kept_its_score_or_scoring() -> None:
    """Teach's demonstration rows (GUI logic): a flagged take left out, then kept; an imported
    one scored, or still being scored."""
    from app.panels.teach.demos import row_label
    from promp.typicality import Typicality

    trip = (("round_trip", "hand goes 28.8 cm out and comes 59% of the way back: ..."),)
    outlier, typical = Typicality(-3.1, 0.0), Typicality(-0.2, 0.64)
    assert row_label(("record1", "2.1 s", False, outlier, trip, False, False)) == (
        "record1 · ⚠ left out · ⚠ outlier (0th pct)")  # fmt: skip
    assert row_label(("record1", "2.1 s", True, outlier, trip, True, False)) == (
        "record1 · ⚠ kept despite findings · ⚠ outlier (0th pct) · hidden")  # fmt: skip
    assert row_label(("record5", "2.0 s", False, typical, (), False, False)) == (
        "record5 · typical (64th pct)")  # fmt: skip
    assert row_label(("record5", "2.0 s", False, None, (), False, True)) == (
        "record5 · typicality: scoring...")  # fmt: skip
    assert row_label(("record5", "2.0 s", False, None, (), False, False)) == "record5"
