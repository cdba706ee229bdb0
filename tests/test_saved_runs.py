"""The Data tab's "Saved runs" in a real browser: two small evaluations are kept in the
workspace's runs/, listed with a run the command line wrote there, opened in the results area,
exported, compared, and one deleted to the trash and restored from "Recently deleted"; an
evaluation of ours beside the toolbox and both baselines, shown, kept and compared by method."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import pytest

from app.io.runs_folder import RUN_KIND, RUNS_DIR
from promp.evaluate.runs import RUN_FILE, write_run
from tests.browser import (
    choose,
    click,
    close_notifications,
    notification,
    open_tab,
    press,
    settled_screenshot,
)
from tests.conftest import (
    GIVEN_SETTINGS,
    StudioSpec,
    open_page,
    wait_until,
)

RUN_SHOT = Path("/tmp/runs_section.png")


def until(predicate, what: str):
    return wait_until(predicate, timeout=120.0, what=what)


# 2 primitives x 3 demonstrations of the simulated scenario, settings given (each fold fits
# once).
STUDIO = StudioSpec(seed=1, n_demos=3, settings=GIVEN_SETTINGS)


def data_panel(studio):
    from app.panels.data import DataPanel

    return next(p for p in studio.panels if isinstance(p, DataPanel))


def text_input(page, handle):
    """The <input> of a viser text handle (labelled by <label for=uuid>, the input has no id)."""
    return page.locator(
        f"label[for='{handle._impl.uuid}'] >> xpath=ancestor::*[.//input][1]//input"
    )


def pick(page, handle, option: str) -> None:
    """:func:`tests.browser.choose`, the dropdown first scrolled into the panel's view."""
    page.locator(f"[id='{handle._impl.uuid}']").scroll_into_view_if_needed()
    choose(page, handle, option)


def evaluate(page, panel, name: str, observed: str, methods: str = "ours"):
    """Run a leave-one-out evaluation of ``methods`` (the Methods dropdown's choice) from the
    GUI at 40 % observed, named ``name``, and wait until it has been kept in runs/; its job."""
    evaluation, runs = panel.evaluation, panel.runs
    controls = evaluation.controls
    for handle, value in ((controls.percents_text, "40"), (controls.run_name_text, name)):
        text_input(page, handle).fill(value)
        until(lambda h=handle, v=value: h.value == v, what=f"{value!r} typed")
    pick(page, controls.observe_dropdown, observed)
    pick(page, controls.alpha_dropdown, "ML")
    pick(page, controls.methods_dropdown, methods)
    kept = len(runs._listed or {})
    previous = evaluation.job
    click(page, "Run leave-one-out evaluation")
    job = until(lambda: evaluation.job is not previous and evaluation.job, what="the evaluation")
    until(lambda: job.finished, what="the evaluation to end")
    assert job.outcome.error is None and not job.outcome.cancelled
    notification(page, "Run kept", name.replace(" ", "_"))
    until(lambda: len(runs._listed or {}) == kept + 1, what=f"run {name!r} listed")
    return job


@pytest.mark.browser
def test_runs_are_kept_listed_opened_compared_deleted_and_restored(browser, studio) -> None:
    panel = data_panel(studio)
    runs, root = panel.runs, studio.session.store.state.workspace.root
    page, _client = open_page(browser, studio, width=1200, height=1400)
    try:
        page.set_default_timeout(120_000)
        open_tab(page, "Data")
        page.get_by_text("Saved runs", exact=True).first.wait_for()
        evaluate(page, panel, "both seen", "hand + head")
        evaluate(page, panel, "hand only", "hand")
        # A run the command line wrote into the workspace (--run WORKSPACE/runs/NAME).
        cli = json.loads(next((root / RUNS_DIR).glob(f"*both_seen/{RUN_FILE}")).read_text())
        write_run(root / RUNS_DIR / "20200101-000000-cli", cli["report"], "from the CLI")
        until(lambda: len(runs._listed or {}) == 3, what="the command line's run listed")
        table = page.get_by_text("from the CLI").first
        table.wait_for()
        page.get_by_text("hand + head").first.wait_for()
        # Newest first, by the time each run was made.
        labels = list(runs._choices)
        assert [label.split(" · ")[1] for label in labels] == [
            "from the CLI", "hand only", "both seen"
        ]  # fmt: skip
        labels = labels[1:]  # the studio's own: hand only, both seen

        # Open the first run: the results area shows it, under its name.
        close_notifications(page)
        pick(page, runs.controls.choice, labels[1])
        click(page, "Open run")
        page.get_by_text("Saved run:").first.wait_for()
        assert "both seen" in panel.evaluation.results.handles[0].content
        page.get_by_text("Recognition errors (of 6)").first.wait_for()

        # Export it: its folder as a zip.
        with page.expect_download() as info:
            click(page, "Export run")
        download = info.value
        folder = runs._choices[labels[1]]
        assert download.suggested_filename == f"run-{folder}.zip"
        with zipfile.ZipFile(io.BytesIO(Path(download.path()).read_bytes())) as archive:
            names = archive.namelist()
        assert {f"{folder}/{RUN_FILE}", f"{folder}/results.csv", f"{folder}/trials.csv"} <= set(
            names
        )
        assert any(n.startswith(f"{folder}/figures/confusion_") for n in names)

        # Compare it (A) with the other evaluation (B).
        close_notifications(page)  # they cover the panel's lower part
        pick(page, runs.controls.other, labels[0])
        click(page, "Compare runs")
        page.get_by_text("Made differently").first.wait_for()
        text = runs.controls.comparison.content
        assert "**A:** both seen" in text and "**B:** hand only" in text
        assert "**hand + head, ML → hand, ML**" in text  # each percentage side by side
        page.get_by_text("position (cm)").last.wait_for()
        section = page.get_by_text("Saved runs", exact=True).first
        section.evaluate("e => e.scrollIntoView({block: 'start'})")
        page.mouse.move(5, 700)
        page.screenshot(path=str(RUN_SHOT))

        # Delete it: to the trash, and back from "Recently deleted".
        click(page, "Delete run")
        notification(page, "Run deleted")
        until(lambda: len(runs._listed or {}) == 2, what="the run gone from the list")
        assert not (root / RUNS_DIR / folder).exists()
        entry = studio.session.store.state.trash[0]
        assert entry.kind == RUN_KIND and (root / "trash" / entry.name / "files").is_dir()
        close_notifications(page)
        folder_title = page.get_by_text("Recently deleted", exact=True).first
        folder_title.scroll_into_view_if_needed()
        press(page, folder_title)
        pick(page, panel.trash.choice, next(iter(panel.trash._entries)))
        click(page, "Restore")
        notification(page, "Restored")
        until(lambda: len(runs._listed or {}) == 3, what="the run listed again")
        assert (root / RUNS_DIR / folder / RUN_FILE).is_file()
    except Exception:
        page.screenshot(path="/tmp/runs_failed.png")
        raise
    finally:
        page.close()


@pytest.mark.browser
def test_ours_beside_the_toolbox_and_both_baselines(browser, studio, artifacts) -> None:
    """Methods "ours + toolbox + baselines": the four run on the same trials; the results name
    each (the baselines' position errors n/a), the kept run lists each method's errors, and
    the comparison with a run of ours alone pairs ours with ours and names the others; ours
    against each other method on the same trials is shown, and again when the run is opened."""
    panel = data_panel(studio)
    runs = panel.runs
    page, _client = open_page(browser, studio, width=1200, height=1400)
    try:
        page.set_default_timeout(120_000)
        open_tab(page, "Data")
        page.get_by_text("Saved runs", exact=True).first.wait_for()
        evaluate(page, panel, "ours alone", "hand")
        job = evaluate(page, panel, "with baselines", "hand", "ours + toolbox + baselines")
        assert job.plan.methods == ["ours", "seed", "dtw", "prefix-nn"]
        rows, trials = job.outcome.result.rows, job.outcome.result.trials
        assert [r["method"] for r in rows] == job.plan.methods
        assert {r["trials"] for r in rows} == {6}
        tested = {m: sorted((t.primitive, t.demo) for t in trials if t.method == m)
                  for m in job.plan.methods}  # fmt: skip
        assert all(trials == tested["ours"] for trials in tested.values())
        page.get_by_text("Recognition errors (of 6)").first.wait_for()
        table = panel.evaluation.results.handles[3].content
        assert table.splitlines()[0] == ("| errors (of 6) | ours: hand, ML | toolbox (2017): "
                                         "hand, ML | DTW 1-NN: hand, ML | prefix 1-NN: hand, ML |")
        position = table.splitlines()[-1]
        assert position.startswith("| 40 % |") and position.endswith("| n/a | n/a |")
        page.get_by_text("prefix 1-NN: hand, ML").first.wait_for()  # the table in the page
        assert "methods ours, seed, dtw, prefix-nn" in panel.evaluation.results.handles[0].content
        # ours against each other method on the same trials, with McNemar's band
        paired = panel.evaluation.results.handles[4].content
        assert paired.startswith("**ours against each other method, on the same trials**")
        against = [line.split(" | ")[0] for line in paired.splitlines() if line.startswith(
            ("| toolbox", "| DTW", "| prefix"))]  # fmt: skip
        assert against == ["| toolbox (2017)", "| DTW 1-NN", "| prefix 1-NN"]
        heading = page.get_by_text("ours against each other method, on the same trials").first
        heading.wait_for()
        page.get_by_role("columnheader", name="band").first.wait_for()
        heading.scroll_into_view_if_needed()  # the panel scrolled to the paired table
        settled_screenshot(page, artifacts / "data_methods_paired.png")

        errors = ", ".join(f"{label} {r['recognition_errors']}" for label, r in zip(
            ("ours", "toolbox (2017)", "DTW 1-NN", "prefix 1-NN"), rows, strict=True))
        until(lambda: f"{errors} (of 6 each)" in runs.controls.table.content,
              what="the kept run's errors per method")  # fmt: skip
        labels = list(runs._choices)
        newest, alone = labels[0], next(label for label in labels if "ours alone" in label)
        assert "with baselines" in newest
        close_notifications(page)
        pick(page, runs.controls.choice, alone)
        pick(page, runs.controls.other, newest)
        # the kept run opened: its paired comparison shown again, the same
        pick(page, runs.controls.choice, newest)
        click(page, "Open run")
        until(lambda: "with baselines" in panel.evaluation.results.handles[0].content,
              what="the kept run opened")  # fmt: skip
        assert panel.evaluation.results.handles[4].content == paired
        pick(page, runs.controls.choice, alone)
        click(page, "Compare runs")
        page.get_by_text("Made differently").first.wait_for()
        text = runs.controls.comparison.content
        assert "methods ours → ours + seed + dtw + prefix-nn" in text
        assert "**ours: hand, ML**" in text and "**DTW 1-NN: hand, ML**" in text
        assert "**toolbox (2017): hand, ML**" in text and "**prefix 1-NN: hand, ML**" in text
        page.get_by_text("DTW 1-NN: hand, ML").last.wait_for()
    except Exception:
        page.screenshot(path="/tmp/runs_baselines_failed.png")
        raise
    finally:
        page.close()
