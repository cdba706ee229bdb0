"""The Data tab in a real browser: export and re-import a model and a workspace, refused files
leave the workspace byte for byte unchanged, the early size cap, the leave-one-out evaluation
with its progress bar and curves, the export of its results and its failed trials opened in
Infer. Plus the tab's pure helpers."""

from __future__ import annotations

import csv
import hashlib
import io
import json
import re
import threading
import zipfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from app.io import exchange
from app.io.demo_sources import DemoSources
from app.io.workspace_index import FORMAT
from app.panels.data.evaluation import EvaluationJob, EvaluationOutcome, EvaluationProgress
from app.panels.data.evaluation_plan import EvaluationPlan, evaluation_dataset, parse_percents
from app.panels.data.failed_trials import failed_trials, trial_choices
from app.panels.data.results import curves, results_table
from app.panels.data.results_zip import results_filename, results_zip
from app.ui.text import display_name
from promp.evaluate.methods import TrialAnswer
from promp.evaluate.plots import write_figures
from promp.evaluate.report import CSV_COLUMNS, report_json, results_csv
from promp.evaluate.sweep import run_sweep
from promp.io import model_from_json, model_to_dict
from promp.model import Settings
from tests.browser import (
    choose,
    notification,
    open_tab,
    press,
    server_caught_up,
    settled_screenshot,
)
from tests.conftest import (
    GIVEN_SETTINGS,
    PageSpec,
    StudioSpec,
    open_page,
    wait_frames,
    wait_until,
)
from tests.synthetic import LAYOUT, make_dataset

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

# ---------------------------------------------------------------------------- pure helpers


def test_parse_percents() -> None:
    assert parse_percents("10 20 30") == [10.0, 20.0, 30.0]
    assert parse_percents(" 50, 10;10 ") == [10.0, 50.0]
    for text, message in [
        ("", "at least one"),
        ("ten", "must be numbers"),
        ("0 50", r"in \(0, 100\]"),
        ("120", r"in \(0, 100\]"),
        ("nan", r"in \(0, 100\]"),
        (" ".join(str(i) for i in range(1, 30)), "at most 20"),
    ]:
        with pytest.raises(ValueError, match=message):
            parse_percents(text)


def test_evaluation_dataset_keeps_primitives_with_three_demos() -> None:
    demos = {"a": [1, 2, 3], "b": [1, 2], "c": [1, 2, 3, 4]}
    dataset, skipped = evaluation_dataset(["c", "b", "a", "d"], demos)
    assert list(dataset) == ["c", "a"] and skipped == {"b": 2, "d": 0}


def test_curves_and_table_from_sweep_rows() -> None:
    rows = [
        {"percent": p, "alpha_method": a, "observed": o, "recognition_errors": e,
         "trials": 12, "position_error_m": 0.01 * e, "duration_error_s": 0.1}
        for o, a, e0 in ((["hand", "head"], "ml", 2), (["hand"], "ml", 5), (["hand"], "model", 6))
        for p, e in ((50.0, e0 - 1), (10.0, e0))
    ]  # fmt: skip
    series = curves(rows)
    assert list(series) == ["hand, ML", "hand, model", "hand + head, ML"]
    np.testing.assert_array_equal(series["hand, ML"]["percent"], [10, 50])
    np.testing.assert_array_equal(series["hand, ML"]["recognition_errors"], [5, 4])
    np.testing.assert_allclose(series["hand, model"]["position_cm"], [6, 5])
    table = results_table(rows).splitlines()
    assert table[0] == "| errors (of 12) | hand, ML | hand, model | hand + head, ML |"
    assert table[2:4] == ["| 10 % | 5 | 6 | 2 |", "| 50 % | 4 | 5 | 1 |"]
    assert table[5] == "| position (cm) | hand, ML | hand, model | hand + head, ML |"
    assert table[7:] == ["| 10 % | 5.0 | 6.0 | 2.0 |", "| 50 % | 4.0 | 5.0 | 1.0 |"]


def test_several_methods_side_by_side_in_the_curves_and_the_table() -> None:
    """ours beside DTW: a series per method, named after it, and the table's columns side by
    side; DTW's position error (it predicts none) is n/a."""
    rows = [
        {"method": m, "percent": p, "alpha_method": "ml", "observed": ["hand"],
         "recognition_errors": e, "trials": 12,
         "position_error_m": 0.01 * e if m == "ours" else float("nan"), "duration_error_s": 0.1}
        for m, e0 in (("ours", 2), ("dtw", 4)) for p, e in ((10.0, e0), (50.0, e0 - 1))
    ]  # fmt: skip
    series = curves(rows)
    assert list(series) == ["ours: hand, ML", "DTW 1-NN: hand, ML"]
    assert series["DTW 1-NN: hand, ML"]["method"] == "dtw"
    table = results_table(rows).splitlines()
    assert table[0] == "| errors (of 12) | ours: hand, ML | DTW 1-NN: hand, ML |"
    assert table[2:4] == ["| 10 % | 2 | 4 |", "| 50 % | 1 | 3 |"]
    assert table[7:] == ["| 10 % | 2.0 | n/a |", "| 50 % | 1.0 | n/a |"]


def test_display_name_is_markdown_safe() -> None:
    assert display_name("model-2024.json") == "model-2024.json"
    assert display_name("<img src=x>`**.json") == "_img src_x____.json"
    assert display_name("../../a.zip") == "a.zip"
    assert len(display_name("x" * 200 + ".zip")) == 60


class FirstOrFails:
    """A fake method: recognises the first primitive whatever it sees (p = 0.9) and predicts
    the truth; it cannot run on ``right1`` beyond 50 % observed."""

    def fit(self, train, sample_period) -> None:
        pass

    def infer(self, demo, n_observed, observe, alpha_method) -> TrialAnswer:
        if demo.name == "right1" and n_observed > demo.n_samples // 2:
            raise ValueError("no candidate duration explains it")
        values = LAYOUT.extract(demo)
        spread = np.full_like(values, 0.01)
        return TrialAnswer(
            0, np.array([0.9, 0.1]), 1.0, demo.duration, values + 0.1, spread, values, spread
        )


def fake_job() -> EvaluationJob:
    """A finished job of the fake method on two synthetic primitives x 3 demonstrations,
    hand and hand + head at 30 and 60 % (ML): every "right" trial is recognised as "left"."""
    dataset = make_dataset(seed=0, n_demos=3)
    job = EvaluationJob(EvaluationPlan(
        dataset=dataset, skipped={}, percents=[30.0, 60.0],
        observe_sets=[["hand"], ["hand", "head"]], alpha_methods=["ml"], settings=Settings(),
        layout=LAYOUT, source="/somewhere/my lab",
    ))  # fmt: skip
    plan = job.plan
    result = run_sweep(
        FirstOrFails, dataset, LAYOUT, plan.percents, plan.alpha_methods, plan.observe_sets,
        "ours", keep_trials=True,
    )  # fmt: skip
    job.progress, job.outcome = EvaluationProgress(done=6, total=6), EvaluationOutcome(result)
    return job


def test_results_zip_holds_what_the_command_line_writes(tmp_path) -> None:
    job = fake_job()
    report = job.report()
    assert report["primitives"] == ["left", "right"]
    assert report["settings"]["format"] == "workspace"
    assert report["settings"]["basis"]["n_basis"] == "auto"
    result, dataset = job.outcome.result, job.plan.dataset
    with zipfile.ZipFile(io.BytesIO(results_zip(report, result, dataset, LAYOUT))) as z:
        names = z.namelist()
        assert z.read("results.json").decode() == report_json(report)
        assert z.read("results.csv").decode() == results_csv(result.rows)
        pngs = {n: z.read(n) for n in names if n.startswith("figures/")}
    written = write_figures(tmp_path, result, dataset, LAYOUT, "ours")  # as --plots
    assert names[:2] == ["results.json", "results.csv"]
    assert sorted(pngs) == sorted(f"figures/{p.name}" for p in written)
    assert len(pngs) >= 4 and all(data.startswith(PNG_MAGIC) for data in pngs.values())
    table = list(csv.DictReader(io.StringIO(results_csv(result.rows))))
    assert list(table[0]) == list(CSV_COLUMNS) and len(table) == len(result.rows) == 4
    late = next(r for r in table if r["observed"] == "hand+head" and r["percent"] == "60.0")
    assert late["failed"] == "right/right1" and late["recognition_errors"] == "3"
    assert float(late["log_loss"]) == pytest.approx(result.rows[3]["log_loss"])
    assert re.fullmatch(r"evaluation-my_lab-\d{8}-\d{6}\.zip", results_filename("my lab"))
    assert results_filename("../").startswith("evaluation-workspace-")


def test_an_export_draws_its_figures_while_a_kept_run_draws_its_own(tmp_path, monkeypatch):
    """Export results is not held up by another evaluation's run being kept (drawn by the runs
    section's saver): neither drawing waits for the other. (Behind one lock, a busy machine's
    export waited for the figures of every evaluation kept before it.)"""
    from app.panels.data.results_zip import draw_figures
    from promp.evaluate import plots

    job = fake_job()
    report, result, dataset = job.report(), job.outcome.result, job.plan.dataset
    drawing, release = threading.Event(), threading.Event()
    real = plots.reliability_diagram

    def held(*args, **kwargs):  # the saver stops after its first figure until released
        if threading.current_thread().name == "data-run-save":
            drawing.set()
            release.wait()
        return real(*args, **kwargs)

    monkeypatch.setattr(plots, "reliability_diagram", held)
    saver = threading.Thread(target=draw_figures, name="data-run-save", daemon=True,
                             args=(tmp_path / "run", report, result, dataset, LAYOUT))  # fmt: skip
    saver.start()
    exported: list[bytes] = []
    try:
        wait_until(drawing.is_set, what="the kept run's figures being drawn")
        threading.Thread(target=lambda: exported.append(results_zip(report, result, dataset,
                                                                    LAYOUT)),
                         daemon=True).start()  # fmt: skip
        wait_until(lambda: exported, what="the export, while the kept run's are drawn")
    finally:
        release.set()
        saver.join()
    written = write_figures(tmp_path / "cli", result, dataset, LAYOUT, "ours")
    with zipfile.ZipFile(io.BytesIO(exported[0])) as z:
        figures = sorted(n for n in z.namelist() if n.startswith("figures/"))
    assert figures == sorted(f"figures/{p.name}" for p in written)
    assert sorted(p.name for p in (tmp_path / "run").iterdir()) == sorted(p.name for p in written)


def test_an_evaluation_s_figures_are_drawn_once_for_its_run_and_its_export(tmp_path, monkeypatch):
    """The run kept and Export results of one evaluation take one drawing of its figures (the
    second to ask waits for it): what ``--plots`` writes, byte for byte."""
    import app.panels.data.results_zip as module

    drawings = []
    real = module.draw_figures
    monkeypatch.setattr(module, "draw_figures", lambda *args: drawings.append(1) or real(*args))
    job = fake_job()
    taken: list[dict] = []
    askers = [threading.Thread(target=lambda: taken.append(job.figures())) for _ in range(2)]
    for asker in askers:
        asker.start()
    for asker in askers:
        asker.join()
    content = results_zip(job.report(), job.outcome.result, job.plan.dataset, LAYOUT,
                          job.figures)  # fmt: skip
    assert len(drawings) == 1 and taken[0] is taken[1]
    written = write_figures(tmp_path, job.outcome.result, job.plan.dataset, LAYOUT, "ours")
    with zipfile.ZipFile(io.BytesIO(content)) as z:
        figures = {n: z.read(n) for n in z.namelist() if n.startswith("figures/")}
    assert figures == {f"figures/{p.name}": p.read_bytes() for p in written}


def test_failed_trials_list_every_misrecognised_trial() -> None:
    job = fake_job()
    trials = failed_trials(job.outcome.result, job.plan.dataset)
    # Every "right" trial (3 demonstrations x 2 percents x 2 modality sets), in order.
    assert len(trials) == 12
    assert [(t.request.demo, t.request.percent) for t in trials[:4]] == [
        ("right0", 30.0), ("right0", 30.0), ("right0", 60.0), ("right0", 60.0)
    ]  # fmt: skip
    first = trials[0]
    assert first.request.primitive == "right" and first.request.observed == ("hand",)
    assert first.request.alpha_method == "ml"
    assert first.recognised == "left" and first.probability == pytest.approx(0.9)
    failed = [t for t in trials if t.recognised is None]
    assert [(t.request.demo, t.request.percent) for t in failed] == [("right1", 60.0)] * 2
    assert "no candidate duration" in failed[0].error
    labels = list(trial_choices(trials))
    assert len(set(labels)) == 12
    assert labels[0] == "right0 · right · 30 % of hand, ML → left"
    assert "right1 · right · 60 % of hand + head, ML → failed" in labels
    one_setting = [t for t in trials if t.request.observed == ("hand",)]
    assert list(trial_choices(one_setting))[0] == "right0 · right · 30 % → left"


def test_failed_trials_of_several_methods_say_whose_they_are() -> None:
    dataset = make_dataset(seed=0, n_demos=3)
    result = run_sweep({"ours": FirstOrFails, "dtw": FirstOrFails}, dataset, LAYOUT, [30.0],
                       ["ml"], [["hand"]], keep_trials=True)  # fmt: skip
    trials = failed_trials(result, dataset)
    assert [t.method for t in trials] == ["ours"] * 3 + ["dtw"] * 3  # the sweep's order
    labels = list(trial_choices(trials))
    assert labels[0] == "ours: right0 · right · 30 % → left"
    assert labels[3] == "DTW 1-NN: right0 · right · 30 % → left"


def test_evaluation_section_without_a_browser() -> None:
    """Before an evaluation, Export and Open refuse with a yellow notification; after one,
    Export sends the zip and Open asks the studio for the chosen trial."""
    import viser

    from app.io.net import free_port
    from app.panels.data.evaluation_section import EvaluationSection

    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    told, opened = [], []
    workspace = SimpleNamespace(root=Path("/somewhere/my lab"))  # where fake_job comes from
    store = SimpleNamespace(layout=LAYOUT, workspace=workspace, sources=DemoSources())
    ctx = SimpleNamespace(
        gui=server.gui,
        store=SimpleNamespace(state=store),
        open_in_infer=lambda request, client: opened.append((request, client)),
    )
    try:
        section = EvaluationSection(ctx, lambda client, *message: told.append(message))
        controls = section.controls
        assert controls.export_button.disabled and not controls.failed_dropdown.visible
        assert section.results.export(None) is None
        assert section.failed_trials.open_in_infer(None) is None
        assert [(title, color) for title, _, color in told] == [
            ("No results to export", "yellow"), ("No failed trial", "yellow")
        ]  # fmt: skip
        assert opened == []

        section._job = job = fake_job()
        section.step(SimpleNamespace(store=store))  # the loop shows the finished job
        assert not section.controls.export_button.disabled
        assert section.controls.failed_dropdown.label == "Failed trials (12)"
        assert len(section.controls.failed_dropdown.options) == 12
        assert section.controls.open_button.visible and not section.controls.open_button.disabled
        section.controls.failed_dropdown.value = section.controls.failed_dropdown.options[5]
        trial = section.failed_trials.open_in_infer(None)
        assert opened == [(trial.request, None)] and trial.request.demo == "right1"
        content = section.results.export(None)
        with zipfile.ZipFile(io.BytesIO(content)) as archive:
            assert json.loads(archive.read("results.json")) == json.loads(
                report_json(job.report())
            )
        assert told[-1][0] == "Results exported" and "evaluation-my_lab-" in told[-1][1]
    finally:
        server.stop()


def test_a_quick_evaluation_holds_out_a_few_demonstrations_per_primitive() -> None:
    """The Held out choice: a few per primitive, evenly spread (as --subset N), each tested
    by a model fitted on every other demonstration; said in the status, kept in the report."""
    import viser

    from app.io.net import free_port
    from app.panels.data.evaluation_plan import SUBSET_CHOICES, plan_evaluation
    from app.panels.data.evaluation_section import EvaluationSection, summary
    from promp.evaluate.sweep import spread_subset

    dataset = make_dataset(seed=0, n_demos=7)
    store = SimpleNamespace(
        layout=LAYOUT, workspace=SimpleNamespace(root=Path("/somewhere/lab")), names=tuple(dataset),
        learned=dataset, findings=(), left_out={}, sources=DemoSources(),
        learning_settings=lambda: Settings(**GIVEN_SETTINGS),
    )  # fmt: skip
    with pytest.raises(ValueError, match="held out: expected one of"):
        plan_evaluation(store, [["hand"]], "ML", "50", "ours", "half of them")
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    ctx = SimpleNamespace(gui=server.gui, store=SimpleNamespace(state=store),
                          open_in_infer=lambda *_: None)  # fmt: skip
    try:
        section = EvaluationSection(ctx, lambda *_: None)
        controls = section.controls
        assert tuple(controls.subset_dropdown.options) == tuple(SUBSET_CHOICES)
        assert controls.subset_dropdown.value == "every demonstration"
        controls.subset_dropdown.value = "3 per primitive"
        controls.percents_text.value = "50"
        job = section.start(None)
        job.join(timeout=600)
        assert job.outcome.error is None and job.progress.total == 3 * len(dataset)
        names = [[d.name for d in demos] for demos in dataset.values()]
        held = {(t.primitive, t.demo) for t in job.outcome.result.trials}
        assert held == {(k, names[k][j]) for k, j in spread_subset(dataset, 3)}
        assert job.report()["settings"]["subset"] == 3
        assert "Held out 3 per primitive, evenly spread: 6 demonstrations" in summary(job)
    finally:
        server.stop()


def test_when_it_acts_in_the_results_the_comparison_and_the_export(tmp_path) -> None:
    """"When it acts" checked: the evaluation observes every held-out demonstration every 2 %,
    its results show the decisions (the headline per method, the in-sample chart), its report,
    export and kept run hold them, a saved run opens with them, and two runs compared say
    them A → B."""
    import viser

    from app.io.net import free_port
    from app.panels.data.decisions import decisions_table
    from app.panels.data.evaluation_section import EvaluationSection
    from app.panels.data.runs_text import comparison_markdown
    from promp.evaluate.decisions import decisions_of
    from promp.evaluate.runs import compare_runs, read_run, write_run

    dataset = make_dataset(seed=0, n_demos=3)
    store = SimpleNamespace(
        layout=LAYOUT, workspace=SimpleNamespace(root=Path("/somewhere/lab")), names=tuple(dataset),
        learned=dataset, findings=(), left_out={}, sources=DemoSources(),
        learning_settings=lambda: Settings(**GIVEN_SETTINGS),
    )  # fmt: skip
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    ctx = SimpleNamespace(gui=server.gui, store=SimpleNamespace(state=store),
                          open_in_infer=lambda *_: None)  # fmt: skip
    try:
        section = EvaluationSection(ctx, lambda *_: None)
        controls = section.controls
        assert controls.decide_checkbox.value is False
        controls.percents_text.value = "50"
        controls.observe_dropdown.value = "hand"
        controls.methods_dropdown.value = "ours + toolbox + baselines"
        controls.decide_checkbox.value = True
        job = section.start(None)
        job.join(timeout=600)
        assert job.outcome.error is None and job.plan.decide
        decisions = job.outcome.decisions
        assert [r["method"] for r in decisions.rows] == ["ours", "seed", "dtw", "prefix-nn"]
        assert {r["trials"] for r in decisions.rows} == {6}
        section.step(SimpleNamespace(store=store))  # the loop shows the finished job
        shown = section.results.handles
        assert "when it acts: every 2 %" in shown[0].content
        # The position chart leaves out the baselines, which give no position (all NaN: uPlot
        # drew nothing at all with them); the errors chart has all four.
        assert [s["label"] for s in shown[2].series[1:]] == ["ours: hand, ML",
                                                             "toolbox (2017): hand, ML"]
        assert len(shown[2].data) == 3 and len(shown[1].data) == 5
        chart, table = shown[-2], shown[-1]
        assert chart.title.startswith("When it acts: harmonic mean")
        assert len(chart.data) == 1 + 4 and len(chart.data[0]) == len(decisions.curve) // 4
        assert table.content == decisions_table(decisions)
        lines = table.content.splitlines()
        assert lines[2] == ("| | ours: hand, ML | toolbox (2017): hand, ML | DTW 1-NN: hand, ML "
                            "| prefix 1-NN: hand, ML |")  # fmt: skip
        assert [line.split(" | ")[0] for line in lines[4:]] == [
            "| harmonic mean", "| accuracy", "| earliness", "| never committed", "| threshold"]
        accuracy = " | ".join(f"{100 * r['accuracy']:.0f} %" for r in decisions.rows)
        assert lines[5] == f"| accuracy | {accuracy} |"
        best = max(r["harmonic_mean"] for r in decisions.rows)
        assert f"**{best:.3f}**" in table.content  # the best harmonic mean in bold
        report = job.report()
        assert report["decisions"] == decisions.rows
        with zipfile.ZipFile(io.BytesIO(results_zip(report, job.outcome.result, dataset,
                                                    LAYOUT))) as archive:  # fmt: skip
            assert "decisions.csv" in archive.namelist()
            assert "figures/decisions_ours+seed+dtw+prefix-nn.png" in archive.namelist()
        # Kept, opened again: the same decisions; beside another run: A → B.
        a = write_run(tmp_path / "a", report, "a")
        other = dict(report, decisions=[dict(r, harmonic_mean=0.5) for r in report["decisions"]])
        b = write_run(tmp_path / "b", other, "b")
        assert decisions_of(read_run(tmp_path / "a").report).rows == decisions.rows
        section.results.show("saved", a.report["results"], decisions_of(a.report))
        assert section.results.handles[-1].content == table.content
        text = comparison_markdown(a, b, compare_runs(a, b))
        assert "**When it acts**" in text
        ours = next(line for line in text.splitlines() if line.startswith("| ours: hand, ML |")
                    and "→ 0.500" in line)  # fmt: skip
        assert f"{decisions.rows[0]['harmonic_mean']:.3f} → 0.500" in ours
    finally:
        server.stop()


# ---------------------------------------------------------------------------- browser


def until(predicate, what: str):
    """:func:`wait_until` with room for a loaded machine (the browser renders in software)."""
    return wait_until(predicate, timeout=120.0, what=what)


def workspace_hash(root: Path, trash: bool = True) -> str:
    """SHA-256 over every file's relative path and bytes (``trash=False``: outside trash/)."""
    digest = hashlib.sha256()
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        relative = path.relative_to(root)
        if not trash and relative.parts[0] == "trash":
            continue
        digest.update(str(relative).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


# 3 primitives x 4 demonstrations of the simulated scenario, settings given; the Data tab.
STUDIO = StudioSpec(seed=1, n_demos=4, third=True, settings=GIVEN_SETTINGS)
PAGE = PageSpec(width=1200, height=800, tab="Data",
                ready=lambda page, _: page.get_by_role("button", name="Export model").wait_for())


def readme_picture(browser, studio, path: Path) -> None:
    """docs/data.png: the Data tab after the evaluation, in a page of its own at full
    resolution (the GUI is the server's: the new page shows the same results)."""
    page, _ = open_page(browser, studio, width=1600, height=1000, dpr=1.0)
    try:
        tab = page.get_by_role("tab", name="Data")
        press(page, tab)
        until(lambda: tab.get_attribute("aria-selected") == "true", what="the Data tab shown")
        folder = page.get_by_text("Leave-one-out evaluation", exact=True).first
        folder.evaluate("e => e.scrollIntoView({block: 'start'})")
        page.get_by_text("Recognition errors (of 12)").first.wait_for()
        page.mouse.move(5, 450)
        settled_screenshot(page, path)
    finally:
        page.close()


def panel_of(studio):
    from app.panels.data import DataPanel

    return next(p for p in studio.panels if isinstance(p, DataPanel))


def upload(page, studio, name: str, content: bytes) -> None:
    """Choose a file in the Data tab's upload button, as the browser's file dialog does."""
    uuid = panel_of(studio).upload_button._impl.uuid
    page.set_input_files(
        f"#file_upload_{uuid}",
        files=[{"name": name, "mimeType": "application/octet-stream", "buffer": content}],
    )


@pytest.mark.browser
def test_export_model_and_upload_it_back(page, studio, artifacts) -> None:
    before = workspace_hash(studio.workspace)
    with page.expect_download() as info:
        page.get_by_role("button", name="Export model").click()
    download = info.value
    assert re.fullmatch(r"model-\d{8}-\d{6}\.json", download.suggested_filename)
    content = Path(download.path()).read_bytes()
    assert model_to_dict(model_from_json(content)) == model_to_dict(studio.session.snapshot().model)

    upload(page, studio, "exported-model.json", content)
    text = notification(page, "Model imported")
    assert "exported-model.json: primitives curved, direct, second_bin" in text
    until(lambda: studio.session.snapshot().imported is not None, what="the imported model")
    snapshot = studio.session.snapshot()
    assert snapshot.imported.source == "exported-model.json"
    assert model_to_dict(snapshot.inference_model) == model_to_dict(snapshot.model)
    page.get_by_text("imported from").wait_for()
    page.screenshot(path=str(artifacts / "data_model_imported.png"))
    assert workspace_hash(studio.workspace) == before  # a model import writes nothing

    page.get_by_role("button", name="Use the learned model").click()
    until(lambda: studio.session.snapshot().imported is None, what="the learned model back")
    page.get_by_text("learned from the demonstrations (curved").wait_for()


def zip_with_parent_entry() -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("studio.json", json.dumps({"format": FORMAT, "version": 1}))
        archive.writestr("../evil", "owned")
    return buffer.getvalue()


@pytest.mark.browser
@pytest.mark.parametrize(
    "name, content, reason",
    [
        ("model.json", np.random.default_rng(0).bytes(4096), "not a model file: not UTF-8"),
        ("evil.zip", zip_with_parent_entry(), "../evil: '..', '.' and empty path components"),
    ],
)
def test_a_bad_file_is_refused_and_changes_nothing(page, studio, artifacts, name, content, reason):
    before = workspace_hash(studio.workspace)
    version, model = studio.session.store.state.version, studio.session.snapshot().model
    guard = panel_of(studio).guard
    dismissals = guard.dismissals
    upload(page, studio, name, content)
    text = notification(page, f"Cannot import {name}")
    assert reason in text and "Nothing was changed." in text, text
    # viser's "File uploaded successfully." (which would close itself after 4 s) is taken
    # away: the studio asked the browser to close it before it sent the refusal (the same
    # websocket, in order), and the page no longer shows it.
    assert guard.dismissals == dismissals + 1
    success = page.locator(".mantine-Notification-root", has_text="File uploaded successfully")
    wait_until(lambda: success.count() == 0, timeout=60, what="no success toast")
    if name == "evil.zip":
        page.screenshot(path=str(artifacts / "data_refused_zip.png"))
    server_caught_up(studio, page.client)  # anything the refusal set off has run
    assert workspace_hash(studio.workspace) == before
    snapshot = studio.session.snapshot()
    assert snapshot.store.version == version and snapshot.model is model
    assert snapshot.imported is None
    assert not (studio.workspace.parent / "evil").exists()


@pytest.mark.browser
def test_an_oversized_upload_is_refused_before_it_is_buffered(page, studio) -> None:
    panel = panel_of(studio)
    before = workspace_hash(studio.workspace)
    received, refusals = panel.uploads_received, panel.guard.refusals
    parts = panel.guard.parts_seen
    assert panel.guard.active
    panel.guard.max_bytes = 256 * 1024
    try:
        upload(page, studio, "huge.zip", b"\0" * (3 * 2**20))
        text = notification(page, "Cannot import huge.zip")
        assert "3.0 MB, over the 256.0 KB upload limit. Nothing was changed." in text
        until(lambda: panel.guard.refusals == refusals + 1, what="the guard's refusal")
        # The browser sends every part (3 MB in 512 KB parts) after the refusal too: once all
        # six have reached the server, none may be kept.
        until(lambda: panel.guard.parts_seen == parts + 6, what="the six parts at the server")
        wait_frames(studio)
        assert studio.server.gui._current_file_upload_states == {}
        assert panel.uploads_received == received  # the callback never saw the file
        button = page.get_by_role("button", name="Import model or workspace")
        until(button.is_enabled, what="the upload button to be usable again")
    finally:
        panel.guard.max_bytes = exchange.MAX_UPLOAD_BYTES
    assert workspace_hash(studio.workspace) == before
    # Under the cap, the same path accepts a file.
    upload(page, studio, "small.json", b"{}")
    assert "not a model file" in notification(page, "Cannot import small.json")
    assert panel.uploads_received == received + 1


@pytest.mark.browser
def test_export_the_workspace_and_import_it_back(page, studio, artifacts) -> None:
    before = workspace_hash(studio.workspace)
    demos_before = {n: [d.name for d in v] for n, v in studio.session.store.state.demos.items()}
    with page.expect_download() as info:
        page.get_by_role("button", name="Export workspace").click()
    download = info.value
    assert re.fullmatch(r"workspace-\d{8}-\d{6}\.zip", download.suggested_filename)
    content = Path(download.path()).read_bytes()
    with zipfile.ZipFile(io.BytesIO(content)) as archive:
        names = set(archive.namelist())
    assert {"studio.json", "model.json", "demos/curved/curved_000.csv"} <= names
    assert len([n for n in names if n.endswith(".csv")]) == 12

    # Cancelling the confirmation changes nothing.
    upload(page, studio, "exported.zip", content)
    page.get_by_text("Replace the workspace?").wait_for()
    page.get_by_role("button", name="Cancel", exact=True).click()
    notification(page, "Import cancelled")
    assert workspace_hash(studio.workspace) == before

    version = studio.session.store.state.version
    upload(page, studio, "exported.zip", content)
    page.get_by_text("holds 3 primitives (curved, direct, second_bin) and 12").wait_for()
    page.screenshot(path=str(artifacts / "data_confirm_replace.png"))
    page.get_by_role("button", name="Replace the workspace").click()
    text = notification(page, "Workspace imported")
    assert "exported.zip: 3 primitives, 12 demonstrations." in text
    assert studio.session.store.state.version > version
    # The same content, written again by the studio: identical files; the replaced ones wait
    # in the trash.
    assert workspace_hash(studio.workspace, trash=False) == before
    (entry,) = studio.session.store.state.trash
    assert entry.kind == "workspace" and "exported.zip" in entry.label
    demos = studio.session.store.state.demos
    assert {n: [d.name for d in v] for n, v in demos.items()} == demos_before


def gate_sweep(monkeypatch, stage: str = "progress") -> threading.Event:
    """Make the next sweep wait after its first held-out demonstration (``stage``
    ``"choosing"``: its first block's choice of the settings) until the returned event is set
    (the sweep itself is the real one; gates of both stages stack)."""
    import app.panels.data.evaluation as data_panel

    gate = threading.Event()
    real = data_panel.run_sweep

    def gated(*args, **kwargs):
        told = kwargs[stage]

        def report(done: int, total: int) -> None:
            told(done, total)
            if done == 1:
                gate.wait(120)

        return real(*args, **{**kwargs, stage: report})

    monkeypatch.setattr(data_panel, "run_sweep", gated)
    return gate


def percents_input(page, panel):
    """The evaluation's "Percents" text input (viser labels its inputs with <label for=uuid>
    but gives the input no id)."""
    return page.locator(
        f"label[for='{panel.controls.percents_text._impl.uuid}'] "
        ">> xpath=ancestor::*[.//input][1]//input"
    )


@pytest.mark.browser
def test_leave_one_out_evaluation_from_the_gui(page, studio, artifacts, monkeypatch) -> None:
    panel = panel_of(studio).evaluation
    percents = percents_input(page, panel)
    percents.fill("abc")
    until(lambda: panel.controls.percents_text.value == "abc", what="the typed percents")
    page.get_by_role("button", name="Run leave-one-out evaluation").click()
    assert "percentages must be numbers" in notification(page, "Cannot evaluate")

    percents.fill("10 30 50 70 90")
    until(lambda: panel.controls.percents_text.value == "10 30 50 70 90", what="the percents")
    panel.controls.observe_dropdown.value = "compare each"
    panel.controls.alpha_dropdown.value = "both"
    gate = gate_sweep(monkeypatch)
    run = page.get_by_role("button", name="Run leave-one-out evaluation")
    run.click()
    job = until(lambda: panel._job, what="the evaluation to start")
    # Held after the first of 12 held-out demonstrations: the page shows a running job.
    until(lambda: not job.progress.choosing and job.progress.done == 1,
          what="the first held-out demonstration")  # fmt: skip
    bar = page.locator("[role=progressbar]").first
    until(lambda: bar.get_attribute("aria-valuenow") == f"{100 / 12}", what="the bar at 1/12")
    cancel = page.get_by_role("button", name="Cancel evaluation")
    until(lambda: not run.is_enabled() and cancel.is_visible(), what="Run off, Cancel shown")
    page.screenshot(path=str(artifacts / "data_evaluation_running.png"))
    gate.set()
    until(lambda: bar.get_attribute("aria-valuenow") == "100", what="the bar at 100")
    until(run.is_enabled, what="the button to be enabled again")
    assert job.finished and job.outcome.error is None and not job.outcome.cancelled

    chart_title = page.get_by_text("Recognition errors (of 12)")
    chart_title.wait_for()
    page.get_by_text("Position error of the remainder").first.wait_for()
    charts = page.evaluate(
        "Object.values(window.__viserTestpoints.uplots).map(t => "
        "({series: t.chart.series.map(s => s.label), x: Array.from(t.chart.data[0])}))"
    )
    charts = [c for c in charts if c["series"][0] == "observed (%)"]  # other tabs have charts
    assert len(charts) == 2
    labels = {label for chart in charts for label in chart["series"]}
    assert {"hand, ML", "head, model", "hand + head, ML"} <= labels
    assert all(chart["x"] == [10, 30, 50, 70, 90] for chart in charts)
    header = "| errors (of 12) | hand, ML | hand, model | head, ML |"
    assert panel.results.handles[0].content.startswith("**Results of ws** (")  # what they are
    assert header in panel.results.handles[3].content
    status = panel.controls.eval_status.content
    assert "Held out each of 12 demonstrations of curved, direct, second_bin" in status
    page.set_viewport_size({"width": 1200, "height": 1700})  # the whole tab in the picture
    page.get_by_role("columnheader", name="position (cm)").first.wait_for()
    settled_screenshot(page, artifacts / "data_evaluation.png")
    page.set_viewport_size({"width": 1200, "height": 800})

    # The curves are the sweep's: recognition improves as more is observed (hand+head).
    rows = [r for r in job.outcome.result.rows if r["observed"] == ["hand", "head"]]
    errors = {r["percent"]: r["recognition_errors"] for r in rows if r["alpha_method"] == "ml"}
    assert errors[90.0] <= errors[10.0]

    # A second run, cancelled while it runs: its partial results are shown, said partial.
    gate = gate_sweep(monkeypatch)
    run.click()
    second = until(lambda: panel._job is not job and panel._job, what="a second run")
    until(lambda: not second.progress.choosing and second.progress.done == 1,
          what="the second run's first held-out demonstration")  # (after its blocks' choices)
    page.get_by_role("button", name="Cancel evaluation").click()
    until(second.cancel.is_set, what="the cancel click")
    gate.set()
    until(lambda: second.finished, what="the cancelled run to end")
    done = second.progress.done
    assert second.outcome.cancelled and second.outcome.result.partial and 0 < done < 12
    page.get_by_text(f"Cancelled after {done} of 12 held-out").first.wait_for()
    until(run.is_enabled, what="the button after the cancel")
    assert "**partial**" in panel.results.handles[0].content
    assert panel.controls.results_folder.visible


@pytest.fixture(scope="module")
def evaluated(page, studio):
    """A small evaluation run from the GUI (hand + head, ML, 10 and 40 % observed: at 10 %
    some held-out demonstrations are recognised as another primitive); its job."""
    # the evaluations of the test before are kept as runs in the background (their figures
    # drawn): done first, so that the export measured is this one's alone, whatever the load
    until(lambda: panel_of(studio).runs.idle, what="the runs of the evaluations before kept")
    panel = panel_of(studio).evaluation
    previous = panel._job
    percents = percents_input(page, panel)
    percents.fill("10 40")
    until(lambda: panel.controls.percents_text.value == "10 40", what="the percents")
    panel.controls.observe_dropdown.value = "hand + head"
    panel.controls.alpha_dropdown.value = "ML"
    page.get_by_role("button", name="Run leave-one-out evaluation").click()
    job = until(lambda: panel._job is not previous and panel._job, what="the evaluation")
    until(lambda: job.finished, what="the evaluation to finish")
    assert job.outcome.error is None and not job.outcome.cancelled
    until(page.get_by_role("button", name="Export results").is_enabled, what="Export enabled")
    return job


@pytest.mark.browser
def test_export_results_from_the_gui(page, studio, evaluated) -> None:
    with page.expect_download() as info:
        page.get_by_role("button", name="Export results").click()
    download = info.value
    assert re.fullmatch(r"evaluation-ws-\d{8}-\d{6}\.zip", download.suggested_filename)
    with zipfile.ZipFile(Path(download.path())) as archive:
        names = archive.namelist()
        report = json.loads(archive.read("results.json"))
        table = list(csv.reader(io.StringIO(archive.read("results.csv").decode())))
        pngs = {n: archive.read(n) for n in names if n.startswith("figures/")}
    assert report["primitives"] == ["curved", "direct", "second_bin"]
    assert report["settings"]["percents"] == [10.0, 40.0]
    rows = report["results"]
    assert len(rows) == 2 and all(r["trials"] == 12 for r in rows)
    assert report == json.loads(report_json(evaluated.report()))
    assert table[0] == list(CSV_COLUMNS) and len(table) == 1 + len(rows)
    assert [float(line[3]) for line in table[1:]] == [r["percent"] for r in rows]
    assert "figures/curves_ours.png" in pngs
    assert all(name.endswith(".png") and data.startswith(PNG_MAGIC) for name, data in pngs.items())
    assert download.suggested_filename in notification(page, "Results exported")


@pytest.mark.browser
def test_a_failed_trial_opens_in_infer(browser, page, studio, evaluated, artifacts) -> None:
    from app.panels.infer import InferPanel
    from app.scene.look import INFER

    panel = panel_of(studio).evaluation
    infer = next(p for p in studio.panels if isinstance(p, InferPanel))
    expected = failed_trials(evaluated.outcome.result, evaluated.plan.dataset)
    assert expected, "the 10 % trials of this workspace include misrecognised ones"
    labels = list(trial_choices(expected))
    until(lambda: list(panel.controls.failed_dropdown.options) == labels, what="the failed trials")
    # One that is not what the Infer tab shows already.
    label, trial = next(
        (label, t) for label, t in trial_choices(expected).items()
        if (t.request.primitive, t.request.demo)
        != (infer.controls.primitive.value, infer.controls.demo.value)
    )  # fmt: skip
    request = trial.request
    assert re.fullmatch(rf"{request.demo} · {request.primitive} · 10 % → \w+", label)

    # The picture of the tab (docs/data.png), and nothing past the panel's right edge: the
    # full-width Export button marks it.
    page.set_viewport_size({"width": 1600, "height": 1000})
    folder = page.get_by_text("Leave-one-out evaluation", exact=True).first
    folder.evaluate("e => e.scrollIntoView({block: 'start'})")
    page.get_by_text("Recognition errors (of 12)").first.wait_for()
    edge = page.get_by_role("button", name="Export results").bounding_box()
    shown = page.locator(f"[id='{panel.controls.failed_dropdown._impl.uuid}']")
    for element in (shown, page.get_by_role("button", name="Open in Infer")):
        box = element.bounding_box()
        assert box["x"] + box["width"] <= edge["x"] + edge["width"] + 1
    assert shown.evaluate("e => e.scrollWidth <= e.clientWidth"), "the trial's label is cut"
    readme_picture(browser, studio, artifacts / "data.png")

    choose(page, panel.controls.failed_dropdown, label)
    page.get_by_role("button", name="Open in Infer").click()
    controls = infer.controls
    until(
        lambda: (controls.primitive.value, controls.demo.value, controls.percent.value)
        == (request.primitive, request.demo, 10),
        what="the trial chosen in the Infer tab",
    )
    assert (controls.source.value, controls.observed.value, controls.alpha.value) == (
        "Test demonstration", "hand + head", "ML"
    )  # fmt: skip
    tab = page.get_by_role("tab", name="Infer")
    until(lambda: tab.get_attribute("aria-selected") == "true", what="the Infer tab shown")
    page.get_by_text(f"learned without {request.demo} (held out)").wait_for()
    assert studio.scene.panel == INFER
    assert infer.view.result is not None and infer.view.result.observation.n_observed > 0
    page.screenshot(path=str(artifacts / "data_open_in_infer.png"))
    open_tab(page, "Data")
    page.set_viewport_size({"width": 1200, "height": 800})


@pytest.mark.browser
def test_evaluation_needs_three_demonstrations(page, studio) -> None:
    store = studio.session.store
    for name in store.state.names:
        for demo in list(store.state.demos[name])[2:]:
            store.delete_demo(name, demo.name)
    page.get_by_role("button", name="Run leave-one-out evaluation").click()
    notification(
        page, "Cannot evaluate", "at least 3 demonstrations (curved: 2, direct: 2, second_bin: 2)"
    )
