"""Progress a person can plan around, in the Data tab (issue 28): a running leave-one-out
evaluation says done / total, elapsed and the time left; cancelled, its partial results are
kept and said partial; the results say which workspace they are of, and go when the workspace
switches (a stale "Failed trials (15)" of another workspace never stays)."""

from __future__ import annotations

import io
import json
import zipfile

import pytest

from app.io.workspace import Workspace, WorkspaceData
from app.io.workspace_index import PALETTE, PrimitiveEntry
from promp.model import Settings
from promp.progress import clock
from tests.browser import click, open_tab, press
from tests.conftest import StudioSpec, open_page, wait_until
from tests.test_data_tab import gate_sweep  # the next sweep waits after its first fold

SETTINGS = {"n_basis": 7, "width": 1.0, "noise_scale": 1.5}  # no choice in every fold: quick


def scenario(seed: int, n_demos: int) -> WorkspaceData:
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=seed, n_demos=n_demos, third=True)
    return WorkspaceData(
        primitives=[PrimitiveEntry(name, PALETTE[i]) for i, name in enumerate(dataset)],
        demos=dataset,
        settings=SETTINGS,
    )


STUDIO = StudioSpec(folder="lab-a", make=lambda root, _: Workspace.create(root, scenario(1, 4)))


def until(predicate, what: str):
    return wait_until(predicate, timeout=120.0, what=what)


@pytest.mark.browser
def test_progress_cancel_and_a_workspace_switch(browser, studio, monkeypatch, tmp_path) -> None:
    from app.panels.data import DataPanel

    section = next(p for p in studio.panels if isinstance(p, DataPanel)).evaluation
    controls = section.controls
    page, _client = open_page(browser, studio, width=1200, height=1000)
    try:
        page.set_default_timeout(120_000)
        open_tab(page, "Data")
        controls.percents_text.value = "10 50"
        controls.observe_dropdown.value = "hand + head"
        controls.alpha_dropdown.value = "ML"
        gate = gate_sweep(monkeypatch)
        chosen = gate_sweep(monkeypatch, "choosing")  # the duration's temperature is automatic
        click(page, "Run leave-one-out evaluation")
        job = until(lambda: section.job, what="the evaluation to start")

        # The settings chosen once per block first: said, with the bar moving.
        page.get_by_text("Running on lab-a: choosing the settings: 1 / 10 blocks").wait_for()
        until(lambda: controls.progress_bar.value == 10.0, what="the bar at the first block")
        page.get_by_text("Leave-one-out evaluation", exact=True).first.evaluate(
            "e => e.scrollIntoView({block: 'start'})"
        )
        page.screenshot(path="/tmp/progress_choosing.png")
        chosen.set()
        until(lambda: not job.progress.choosing and job.progress.done == 1,
              what="the first held-out demonstration")  # fmt: skip

        # Counts, the time elapsed and the time left, in words a person plans with.
        status = page.get_by_text("Running on lab-a: 1 / 12 held-out demonstrations")
        status.wait_for()
        text = status.inner_text()
        assert " elapsed · about " in text and text.endswith(" left.")
        seconds = text.split(" · ")[1]  # "0:07 elapsed": the clock moves while it runs
        until(lambda: status.inner_text().split(" · ")[1] != seconds, what="the clock to move")
        page.get_by_text("Leave-one-out evaluation", exact=True).first.evaluate(
            "e => e.scrollIntoView({block: 'start'})"
        )
        page.screenshot(path="/tmp/progress_running.png")

        # Cancelled: what was done is kept and shown, said partial.
        press(page, page.get_by_role("button", name="Cancel evaluation"))
        until(job.cancel.is_set, what="the cancel click")
        gate.set()
        until(lambda: job.finished, what="the cancelled evaluation to end")
        done, outcome = job.progress.done, job.outcome
        assert outcome.cancelled and outcome.result.partial and 0 < done < 12
        page.get_by_text(f"Cancelled after {done} of 12 held-out").first.wait_for()
        title = page.locator("p", has_text="Results of lab-a").first
        title.wait_for()
        assert f"partial: cancelled after {done} of 12" in title.inner_text()
        assert {r["trials"] for r in outcome.result.rows} == {done}
        failed = page.get_by_text("Failed trials (", exact=False).first
        until(lambda: controls.failed_dropdown.visible, what="the failed trials listed")
        page.screenshot(path="/tmp/progress_partial.png")
        with zipfile.ZipFile(io.BytesIO(section.results.export(None))) as archive:  # partial
            report = json.loads(archive.read("results.json"))
        assert report["partial"] == {"held_out": done, "of": 12}

        # Another workspace: nothing of lab-a's evaluation stays.
        studio.session.store.switch(tmp_path / "lab-b", scenario(2, 3))
        until(lambda: not controls.failed_dropdown.visible, what="the failed trials gone")
        title.wait_for(state="detached")
        failed.wait_for(state="hidden")
        assert controls.export_button.disabled and not controls.results_folder.visible
        page.get_by_text("Held out one demonstration at a time").wait_for()
        page.screenshot(path="/tmp/progress_switched.png")
    finally:
        page.close()


@pytest.mark.browser
def test_an_uploaded_dataset_says_how_long_reading_and_checking_took(browser, studio) -> None:
    from app.panels.data import DataPanel
    from tests.browser import upload_file
    from tests.test_dataset_import import csv_demo, zip_of

    importer = next(p for p in studio.panels if isinstance(p, DataPanel)).importer
    page, _client = open_page(browser, studio, width=1200, height=1000)
    try:
        page.set_default_timeout(120_000)
        open_tab(page, "Data")
        members = {f"{p}/take{i}.csv": csv_demo(10 * k + i) for k, p in enumerate(("up", "down"))
                   for i in range(3)}  # fmt: skip
        upload_file(page, importer.upload_button, "takes.zip", zip_of(members))
        page.get_by_text("Read and checked in 0:0").wait_for()
        page.get_by_text("Read and checked in").evaluate("e => e.scrollIntoView({block: 'center'})")
        page.screenshot(path="/tmp/progress_import.png")
    finally:
        page.close()


@pytest.mark.parametrize("settings", [Settings(), Settings(**SETTINGS, duration_temperature=1.0)],
                         ids=["automatic", "given"])  # fmt: skip
def test_the_progress_says_the_settings_are_being_chosen_then_counts_the_folds(
    monkeypatch, settings
) -> None:
    """Automatic settings are chosen once per block before any demonstration is held out
    (about a third of a run): the bar and the words follow the blocks, then the folds from
    zero, with the time left from the folds' own pace. Nothing to choose: no such stage."""
    import app.panels.data.evaluation as data_panel
    from app.panels.data.evaluation import EvaluationJob
    from app.panels.data.evaluation_plan import EvaluationPlan
    from tests.synthetic import LAYOUT, make_dataset

    job = EvaluationJob(EvaluationPlan(
        dataset=make_dataset(seed=0, n_demos=3), skipped={}, percents=[50.0],
        observe_sets=[["hand"]], alpha_methods=["ml"], settings=settings, layout=LAYOUT,
        source="/somewhere/lab",
    ))  # fmt: skip
    seen, real = [], data_panel.run_sweep

    def spying(*args, progress, choosing, **kwargs):
        def spy(report):
            def call(done: int, total: int) -> None:
                report(done, total)
                seen.append(job.progress)

            return call

        return real(*args, progress=spy(progress), choosing=spy(choosing), **kwargs)

    monkeypatch.setattr(data_panel, "run_sweep", spying)
    job.run()
    assert job.outcome.error is None and not job.outcome.cancelled
    stages = [p for p in seen if p.choosing]
    folds = [p for p in seen if not p.choosing]
    assert [(p.done, p.total) for p in folds] == [(0, 6)] * bool(stages) + [(k, 6) for k in
                                                                             range(1, 7)]
    assert seen[:len(stages)] == stages  # every block before any fold
    if settings.to_choose:
        assert [(p.done, p.total) for p in stages] == [(k, 6) for k in range(6)]
        now = stages[1].started + 30.0
        assert stages[1].text(now).startswith("choosing the settings: 1 / 6 blocks · 0:30 "
                                              "elapsed · about 2:30 left")  # fmt: skip
        since = folds[0].since  # the folds' clock: from the last block's choice
        assert stages[-1].started < since <= folds[-1].since
        text = folds[1].text(since + 10.0)  # 1 of 6 in 10 s: 50 s left, however long before
        assert text.startswith("1 / 6 held-out demonstrations · ") and "about 0:50 left" in text
        assert f"· {clock(since + 10.0 - folds[1].started)} elapsed ·" in text  # the run's
    else:
        assert not stages and all(p.since == 0.0 for p in folds)
