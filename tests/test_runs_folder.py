"""The workspace's evaluation runs (app.io.runs_folder): saved with the command line's writer,
listed, opened, exported, deleted to the trash and restored, compared as the Data tab shows
them; the workspace's loader never takes runs/ for demonstrations. No browser."""

from __future__ import annotations

import datetime as dt
import hashlib
import io
import json
import zipfile
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import pytest

from app.core.store import Store
from app.io.runs_folder import (
    PARTIAL,
    RUN_KIND,
    RUNS_DIR,
    RunsScanner,
    list_runs,
    open_run,
    run_path,
    run_zip,
    save_run,
    trash_run,
)
from app.io.trash import Trash
from app.io.workspace import FolderKind, Workspace, WorkspaceData, inspect_folder
from app.io.workspace_index import PALETTE, PrimitiveEntry
from app.panels.data.results_zip import results_zip
from app.panels.data.runs_section import default_name
from app.panels.data.runs_text import comparison_markdown, run_choices, runs_table
from promp.evaluate.runs import RUN_FILE, compare_runs, write_run
from tests.conftest import wait_until
from tests.synthetic import make_dataset
from tests.test_data_tab import fake_job

WHEN = dt.datetime(2026, 11, 26, 1, 23, 45, tzinfo=dt.UTC)


@pytest.fixture(scope="module")
def job():
    return fake_job()


def folder_hash(root: Path) -> str:
    digest = hashlib.sha256()
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def workspace(root: Path) -> Workspace:
    dataset = make_dataset(seed=0, n_demos=3)
    return Workspace.create(
        root,
        WorkspaceData(
            primitives=[PrimitiveEntry(n, PALETTE[i]) for i, n in enumerate(dataset)],
            demos=dataset,
        ),
    )


def test_runs_are_saved_listed_newest_first_and_opened(tmp_path: Path, job) -> None:
    ws = workspace(tmp_path / "ws")
    before = ws.load()
    report = job.report()
    first = save_run(ws.root, report, "hand + head ML", created=WHEN)
    again = save_run(ws.root, report, "hand + head ML", created=WHEN)  # the same second
    later = save_run(ws.root, report, "cut", partial=True, created=WHEN + dt.timedelta(1))
    assert first.folder == ws.root / RUNS_DIR / "20261126-012345-hand_head_ML"
    assert again.folder.name == "20261126-012345-hand_head_ML-2"
    assert later.report[PARTIAL] is True and PARTIAL not in first.report

    listed = list_runs(ws.root)
    assert list(listed) == [later.folder.name, again.folder.name, first.folder.name]
    item = listed[first.folder.name][1]
    assert (item.name, item.created) == ("hand + head ML", "2026-11-26T01:23:45+00:00")
    assert item.observed == (("hand",), ("hand", "head"))
    assert item.alpha == ("ml",) and item.percents == (30.0, 60.0)
    assert item.trials == sum(r["trials"] for r in report["results"])
    assert item.errors == sum(r["recognition_errors"] for r in report["results"]) > 0
    assert listed[later.folder.name][1].partial and not item.partial
    # Unchanged runs are not read again.
    assert list_runs(ws.root, listed)[first.folder.name][1] is item

    run = open_run(ws.root, first.folder.name)
    assert run.report["results"] == json.loads(json.dumps(report["results"]))
    assert run.report["used"] == {p: [d.name for d in ds] for p, ds in job.plan.dataset.items()}
    # The demonstrations are what they were: runs/ is not read as demonstrations.
    after = ws.load()
    assert after.primitives == before.primitives and after.problems == []
    assert {p: [d.name for d in ds] for p, ds in after.demos.items()} == {
        p: [d.name for d in ds] for p, ds in before.demos.items()
    }
    assert inspect_folder(ws.root)[0] is FolderKind.WORKSPACE


def test_an_unreadable_run_is_listed_with_the_reason_and_changes_nothing(
    tmp_path: Path, job
) -> None:
    ws = workspace(tmp_path / "ws")
    good = save_run(ws.root, job.report(), "good", created=WHEN)
    corrupt = ws.root / RUNS_DIR / "20261126-000000-corrupt"
    corrupt.mkdir()
    (corrupt / RUN_FILE).write_text("{not json", encoding="utf-8")
    newer = ws.root / RUNS_DIR / "20261126-000001-newer"
    newer.mkdir()
    meta = json.loads((good.folder / RUN_FILE).read_text(encoding="utf-8"))
    (newer / RUN_FILE).write_text(json.dumps({**meta, "version": 99}), encoding="utf-8")
    (ws.root / RUNS_DIR / ".20261126-000002-being_written.x").mkdir()  # a writer's staging
    digest = folder_hash(ws.root)

    listed = list_runs(ws.root)
    assert list(listed) == [good.folder.name, newer.name, corrupt.name]
    assert "cannot read as JSON" in listed[corrupt.name][1].problem
    assert "run version 99, expected 1" in listed[newer.name][1].problem
    for name, message in ((corrupt.name, "cannot read as JSON"), (newer.name, "version 99"),
                          ("20261126-gone", "has no run")):  # fmt: skip
        with pytest.raises(ValueError, match=message):
            open_run(ws.root, name)
    for bad in ("../ws", ".hidden", "a/b", ""):
        with pytest.raises(ValueError, match="not the name of a run folder"):
            run_path(ws.root, bad)
    assert folder_hash(ws.root) == digest

    choices = run_choices(item for _, item in listed.values())
    assert list(choices) == [
        "2026-11-26 01:23:45 · good", f"{newer.name} (unreadable)", f"{corrupt.name} (unreadable)"
    ]  # fmt: skip
    table = runs_table([item for _, item in listed.values()])
    assert "| 2026-11-26 01:23:45 | good | hand; hand + head | ML | 30 60 |" in table
    assert "cannot be read: " in table


def test_a_run_is_exported_as_a_zip_of_its_folder(tmp_path: Path, job) -> None:
    ws = workspace(tmp_path / "ws")

    def figures(folder: Path) -> None:
        folder.mkdir()
        (folder / "curves.png").write_bytes(b"png")

    run = save_run(ws.root, job.report(), "x", figures, created=WHEN)
    with zipfile.ZipFile(io.BytesIO(run_zip(ws.root, run.folder.name))) as archive:
        assert sorted(archive.namelist()) == sorted(
            f"{run.folder.name}/{name}"
            for name in (RUN_FILE, "results.csv", "trials.csv", "figures/curves.png")
        )
        assert archive.read(f"{run.folder.name}/{RUN_FILE}") == (run.folder / RUN_FILE).read_bytes()
    with pytest.raises(ValueError, match="has no run"):
        run_zip(ws.root, "20261126-gone")


def test_a_deleted_run_goes_to_the_trash_and_comes_back(tmp_path: Path, job) -> None:
    store = Store.open(tmp_path / "ws", lambda: WorkspaceData())
    root = store.state.workspace.root
    run = save_run(root, job.report(), "kept", created=WHEN)
    digest, learn_version = folder_hash(run.folder), store.state.learn_version

    entry = store.trash_run(run.folder.name)
    assert not run.folder.exists() and list_runs(root) == {}
    assert entry.kind == RUN_KIND and entry.paths == (f"{RUNS_DIR}/{run.folder.name}",)
    assert store.state.trash[0].name == entry.name  # Recently deleted lists it
    assert store.state.learn_version == learn_version  # nothing to learn again
    with pytest.raises(ValueError, match="has no run"):
        store.trash_run(run.folder.name)

    # Its place taken meanwhile: refused, nothing moves.
    run.folder.mkdir()
    with pytest.raises(ValueError, match="already exists"):
        store.restore(entry.name)
    run.folder.rmdir()
    store.restore(entry.name)
    assert folder_hash(run.folder) == digest and list(list_runs(root)) == [run.folder.name]
    assert store.state.trash == () and store.state.learn_version == learn_version


def test_the_trash_moves_a_run_folder_whole(tmp_path: Path, job) -> None:
    ws = workspace(tmp_path / "ws")
    run = save_run(ws.root, job.report(), "whole", created=WHEN)
    trash = Trash(ws.root)
    entry = trash_run(trash, run.folder.name)
    assert trash.missing(entry) == [] and [e.kind for e in trash.entries()] == [RUN_KIND]
    assert ws.restore(entry.name) == entry and open_run(ws.root, run.folder.name).name == "whole"


def test_a_folder_holding_only_runs_becomes_a_workspace_around_them(tmp_path: Path, job) -> None:
    root = tmp_path / "new"
    write_run(root / RUNS_DIR / "cli", job.report(), "from the command line")  # --run
    digest = folder_hash(root / RUNS_DIR)
    assert inspect_folder(root) == (FolderKind.EMPTY, "")
    store = Store.open(root, lambda: WorkspaceData())
    assert inspect_folder(root)[0] is FolderKind.WORKSPACE and store.state.demos == {}
    assert folder_hash(root / RUNS_DIR) == digest and list(list_runs(root)) == ["cli"]
    # Anything besides runs/ is still someone else's folder.
    other = tmp_path / "other"
    (other / RUNS_DIR).mkdir(parents=True)
    (other / "notes.txt").write_text("mine", encoding="utf-8")
    assert inspect_folder(other)[0] is FolderKind.FOREIGN


def test_two_runs_compared_say_what_differs_and_each_change(tmp_path: Path, job) -> None:
    ws = workspace(tmp_path / "ws")
    report = job.report()
    a = save_run(ws.root, report, "before", created=WHEN)
    fewer = json.loads(json.dumps(report))
    fewer["used"]["right"] = fewer["used"]["right"][:2]
    fewer["results"][0]["recognition_errors"] += 2
    b = save_run(ws.root, fewer, "after", created=WHEN + dt.timedelta(seconds=1))
    text = comparison_markdown(a, b, compare_runs(a, b))
    assert text.startswith("**A:** before (2026-11-26 01:23)  \n**B:** after")
    assert "only A used: right/right2" in text
    assert "**hand, ML**" in text and "**hand + head, ML**" in text
    assert "| % | errors | position (cm) | duration (s) |" in text
    first = report["results"][0]
    errors = int(first["recognition_errors"])
    assert f"| {first['percent']:g} | {errors} → {errors + 2} (+2) |" in text
    model = json.loads(json.dumps(report))
    for row in model["results"]:
        row["alpha_method"] = "model"
    c = save_run(ws.root, model, "model", created=WHEN + dt.timedelta(seconds=2))
    assert "**hand, ML → hand, model**" in comparison_markdown(a, c, compare_runs(a, c))
    same = comparison_markdown(a, a, compare_runs(a, a))
    assert "Made alike" in same and "(+" not in same


def test_a_run_of_several_methods_is_listed_and_compared_method_by_method(
    tmp_path: Path, job
) -> None:
    """A run of ours and dtw (the same rows, dtw's without position errors): the list gives
    each method's errors, the comparison with a run of ours alone pairs ours with ours and
    leaves dtw's rows alone, named, with n/a where a value is missing."""
    ws = workspace(tmp_path / "ws")
    report = json.loads(json.dumps(job.report()))
    a = save_run(ws.root, report, "ours", created=WHEN)
    both = json.loads(json.dumps(report))
    dtw = [dict(r, method="dtw", position_error_m=float("nan"), recognition_errors=1)
           for r in both["results"]]  # fmt: skip
    both["results"] += dtw
    both["settings"]["methods"] = ["ours", "dtw"]
    b = save_run(ws.root, both, "both", created=WHEN + dt.timedelta(seconds=1))
    listed = {item.name: item for _, item in list_runs(ws.root).values()}
    assert listed["both"].methods == (("ours", 12, 24), ("dtw", 4, 24))
    assert "| ours 12, DTW 1-NN 4 (of 24 each) |" in runs_table(list(listed.values()))
    assert "| 12 of 24 |" in runs_table([listed["ours"]])
    text = comparison_markdown(a, b, compare_runs(a, b))
    assert "methods ours → ours + dtw" in text
    assert "**ours: hand, ML**" in text and "**DTW 1-NN: hand, ML**" in text
    assert "| 30 | – → 1 | n/a → n/a |" not in text  # missing values say n/a, not a dash
    assert "| 30 | n/a → 1 | n/a → n/a |" in text


def test_default_name_says_what_was_observed_and_how(job) -> None:
    assert default_name(job.plan) == "each ML"
    plan_one = replace(job.plan, observe_sets=[["hand", "head"]],
                       alpha_methods=["ml", "model"])  # fmt: skip
    assert default_name(plan_one) == "hand + head ML+model"
    plan_all = replace(job.plan, observe_sets=[["hand"]],
                       methods=["ours", "seed", "dtw", "prefix-nn"])  # fmt: skip
    assert default_name(plan_all) == "hand ML ours+seed+dtw+prefix-nn"


def test_the_results_export_holds_a_confusion_matrix_per_percentage(job) -> None:
    content = results_zip(job.report(), job.outcome.result, job.plan.dataset, job.plan.layout)
    with zipfile.ZipFile(io.BytesIO(content)) as archive:
        report = json.loads(archive.read("results.json"))
        figures = [n for n in archive.namelist() if n.startswith("figures/confusion_")]
    keys = [(tuple(m["observed"]), m["alpha"], m["percent"]) for m in report["confusion"]]
    assert keys == [(obs, "ml", p) for obs in (("hand",), ("hand", "head")) for p in (30.0, 60.0)]
    assert all(len(m["counts"]) == 2 and len(m["counts"][0]) == 3 for m in report["confusion"])
    assert len(figures) == 2  # one figure per series, a panel per percentage


def test_the_section_keeps_an_ended_evaluation_and_a_cancelled_one_as_partial(tmp_path: Path):
    """Without a browser: the Saved runs section saves each evaluation once it has ended (a
    cancelled one with results marked partial, one without results not at all), under the
    name typed or its default, and lists it; it is not idle while a run is being kept."""
    import threading

    import viser

    from app.io.net import free_port
    from app.panels.data.evaluation_section import EvaluationSection
    from app.panels.data.runs_section import RunsSection

    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    store = Store.open(tmp_path / "ws", lambda: WorkspaceData())
    told: list = []
    ctx = SimpleNamespace(gui=server.gui, store=store, open_in_infer=lambda *a: None)
    try:
        evaluation = EvaluationSection(ctx, lambda client, *message: told.append(message))
        runs = RunsSection(ctx, lambda client, *message: told.append(message), evaluation)
        snapshot = SimpleNamespace(store=store.state)

        def end(job, name: str) -> None:
            evaluation.controls.run_name_text.value = name
            evaluation._job = job
            runs.step(snapshot)  # seen running: its name
            runs.step(snapshot)  # seen ended: saved on a worker
            wait_until(lambda: runs.idle, what="the run kept")

        done = fake_job()
        done.plan = replace(done.plan, source=str(store.state.workspace.root))
        drawing, drawn = threading.Event(), done.figures
        done.figures = lambda: drawing.wait() and drawn()  # its figures held until it is seen
        evaluation._job = done
        runs.step(snapshot)
        runs.step(snapshot)
        assert runs.savers[-1].is_alive() and not runs.idle  # its run being kept
        drawing.set()
        end(done, "")  # seen again: kept once
        cancelled = fake_job()
        cancelled.plan = replace(cancelled.plan, source=done.plan.source)
        cancelled.outcome = replace(cancelled.outcome, cancelled=True)
        end(cancelled, "stopped early")
        nothing = fake_job()
        nothing.plan = replace(nothing.plan, source=done.plan.source)
        nothing.outcome = replace(nothing.outcome, cancelled=True, result=None)
        savers = list(runs.savers)
        end(nothing, "nothing")
        assert runs.savers == savers  # nothing to keep

        def listed(count: int):  # the folder is read on a worker: the loop polls for it
            runs.step(snapshot)
            return len(runs._listed or {}) == count

        wait_until(lambda: listed(2), timeout=60, what="the two runs listed")
        items = [item for _, item in runs._listed.values()]
        assert [(i.name, i.partial) for i in items] == [("stopped early", True), ("each ML", False)]
        assert [t for t, *_ in told] == ["Run kept", "Run kept"]
        assert "partial" in told[1][1]
        assert runs.controls.choice.options[0].endswith("· stopped early (partial)")
        assert "*(partial)*" in runs.controls.table.content
        # Compare the two; open one: its results in the results area, under its name.
        # The newest chosen, beside the one chosen before.
        assert runs.controls.choice.value == runs.controls.choice.options[0]
        assert runs.controls.other.value == runs.controls.choice.options[1]
        assert "**B:** each ML" in runs.compare(None)
        assert runs.open(None).name == "stopped early"
        assert "stopped early" in evaluation.results.handles[0].content
    finally:
        server.stop()


def test_the_scanner_lists_on_a_worker_and_keeps_the_listing_while_nothing_changed(
    tmp_path: Path, job
) -> None:
    ws = workspace(tmp_path / "ws")
    scanner = RunsScanner(interval_s=3600.0)  # only when asked
    wait_until(lambda: scanner.poll(ws.root) is not None, timeout=30, what="the first listing")
    first = scanner.poll(ws.root)
    assert first == {}
    scanner.rescan()
    wait_until(lambda: not scanner._thread.is_alive(), timeout=30, what="the second scan")
    assert scanner.poll(ws.root) is first  # unchanged: the same listing
    run = save_run(ws.root, job.report(), "new", created=WHEN)
    assert scanner.poll(ws.root) is first  # not due: not scanned
    scanner.rescan()
    wait_until(lambda: list(scanner.poll(ws.root) or {}) == [run.folder.name], timeout=30,
               what="the new run listed")  # fmt: skip
    assert scanner.poll(tmp_path / "another") is None  # another workspace: not its listing
