"""Export workspace, for every kind of workspace: the Data tab's "Export workspace" writes the
workspace's own layout, checks and settings, and the zip imports back with the same layout and
demonstrations (issue 28: an imported workspace with other modalities could not be exported,
"has no column(s) ['roll', 'pitch', 'yaw']")."""

from __future__ import annotations

import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.core.store import Store
from app.io import exchange
from app.io.dataset_import import read_folder
from app.io.workspace import Workspace
from promp.datasets import parse_modalities


@pytest.fixture(scope="module")
def server():
    import viser

    from app.io.net import free_port

    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    yield server
    server.stop()


def exported(server, root: Path, learned: int = 0) -> tuple[Store, exchange.WorkspaceUpload, list]:
    """The Data tab on the workspace at ``root`` exports it (no model: the layout and the
    demonstrations are what is checked); the store, the zip read back, and what it told.
    ``learned``: the store's version the learner's model answers (-1: still learning)."""
    from app.panels.data import DataPanel

    store = Store.open(root)
    learner = SimpleNamespace(state=SimpleNamespace(learn_version=learned, fit_ms=2500.0,
                                                    model=object()))  # fmt: skip
    told: list = []
    guard = SimpleNamespace(max_bytes=exchange.MAX_UPLOAD_BYTES, close=lambda: None,
                            dismiss=lambda client: None)  # fmt: skip
    ctx = SimpleNamespace(
        gui=server.gui,
        store=store,
        notify=lambda title, body, color="blue", **_: told.append((title, body, color)),
        guard_upload=lambda *args: guard,
        wait_for_model=lambda: None,
        learner=learner,
        open_in_infer=lambda request, client: None,
    )
    panel = DataPanel(ctx)
    try:
        content = panel.export_workspace(None)
    finally:
        panel.close()
    return store, exchange.read_upload("exported.zip", content), told


def assert_same_workspace(store: Store, upload: exchange.WorkspaceUpload) -> None:
    state, data = store.state, upload.data
    assert data.layout == state.layout
    assert [p.name for p in data.primitives] == list(state.names)
    for name in state.names:
        ours, theirs = state.demos[name], data.demos[name]
        assert [d.name for d in theirs] == [d.name for d in ours]
        for a, b in zip(ours, theirs, strict=True):
            assert b.columns == state.layout.columns
            assert_allclose(b.times, a.times, atol=1e-9)
            assert_allclose(b.select(state.layout.columns), a.select(state.layout.columns),
                            atol=1e-9)  # fmt: skip
    assert dict(data.settings) == dict(state.settings)
    assert data.checks == state.checks


def test_the_default_simulated_workspace_exports_and_imports_back(server, tmp_path) -> None:
    from app.studio import default_workspace

    Workspace.create(tmp_path / "ws", default_workspace())
    store, upload, told = exported(server, tmp_path / "ws")
    assert_same_workspace(store, upload)
    assert [m.name for m in upload.data.layout.modalities] == ["hand", "head"]
    assert told[-1][0] == "Workspace exported" and "40 demonstrations" in told[-1][1]


def hand_and_emg_csv(folder: Path) -> None:
    """Two classes x 3 demonstrations with a hand (x, y, z), 4 EMG channels and a robot's hand
    (bx, by, bz), no head."""
    rng = np.random.default_rng(3)
    for k, name in enumerate(("give", "take")):
        for i in range(3):
            n = 40 + 5 * i
            t = np.arange(n) * 0.02
            hand = np.cumsum(rng.normal(scale=0.01, size=(n, 3)), axis=0) + 0.1 * k
            emg = np.abs(rng.normal(size=(n, 4)))
            robot = hand[::-1] + 0.5
            rows = np.column_stack([t, hand, emg, robot])
            path = folder / name / f"trial{i}.csv"
            path.parent.mkdir(parents=True, exist_ok=True)
            header = "t,x,y,z,e0,e1,e2,e3,bx,by,bz\n"
            path.write_text(header + "\n".join(",".join(f"{v:.6f}" for v in r) for r in rows))


def test_an_imported_csv_dataset_with_other_modalities_exports(server, tmp_path) -> None:
    hand_and_emg_csv(tmp_path / "csv")
    mapping = parse_modalities("hand=x,y,z; emg=e0,e1,e2,e3; robot=bx,by,bz")
    data, _ = read_folder(tmp_path / "csv", "csv", mapping)
    Workspace.create(tmp_path / "ws", data)
    store, upload, told = exported(server, tmp_path / "ws")
    assert [m.name for m in store.state.layout.modalities] == ["hand", "emg", "robot"]
    assert_same_workspace(store, upload)
    assert told[-1][0] == "Workspace exported" and "6 demonstrations" in told[-1][1]


def test_an_imported_lab_records_dataset_exports(server, tmp_path, heights_dir) -> None:
    data, _ = read_folder(heights_dir, "records", parse_modalities("hand=x,y,z; force=fx,fy,fz"))
    Workspace.create(tmp_path / "ws", data)
    store, upload, _ = exported(server, tmp_path / "ws")
    assert [m.name for m in store.state.layout.modalities] == ["hand", "force"]
    assert_same_workspace(store, upload)


def test_an_export_that_waits_for_the_model_says_so(server, tmp_path) -> None:
    hand_and_emg_csv(tmp_path / "csv")
    data, _ = read_folder(tmp_path / "csv", "csv", parse_modalities("hand=x,y,z"))
    Workspace.create(tmp_path / "ws", data)
    _, _, told = exported(server, tmp_path / "ws", learned=-1)
    title, body, _ = told[0]
    assert title == "Export workspace: waiting for the model"
    assert body == (
        "Learning again from 6 demonstrations (the last fit took 0:03); the file follows once "
        "it is learned."
    )
    assert told[-1][0] == "Workspace exported"


def panel_on(server, root: Path):
    """The Data tab on the workspace at ``root`` (its model taken as learned), and what it
    tells."""
    from app.panels.data import DataPanel

    store = Store.open(root)
    learner = SimpleNamespace(state=SimpleNamespace(learn_version=0, fit_ms=10.0,
                                                    model=object(), error=None))  # fmt: skip
    told: list = []
    guard = SimpleNamespace(max_bytes=exchange.MAX_UPLOAD_BYTES, close=lambda: None,
                            dismiss=lambda client: None)  # fmt: skip
    ctx = SimpleNamespace(
        gui=server.gui, store=store, learner=learner, wait_for_model=lambda: None,
        notify=lambda title, body, color="blue", **_: told.append((title, body, color)),
        guard_upload=lambda *args: guard, open_in_infer=lambda request, client: None,
    )  # fmt: skip
    return DataPanel(ctx), store, told


def run_tree(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file()}  # fmt: skip


def test_the_saved_runs_travel_with_the_workspace_and_none_is_overwritten(
    server, tmp_path
) -> None:
    """Export workspace carries runs/ (the readable runs, file for file); importing the archive
    into another workspace brings them back beside its own runs: the same run already there is
    left as it is, another run of a taken name comes in as <name>-imported."""
    import datetime as dt

    from app.io.runs_folder import RUNS_DIR, list_runs, save_run
    from tests.test_data_tab import fake_job

    when = dt.datetime(2026, 11, 26, 1, 23, 45, tzinfo=dt.UTC)
    report = fake_job().report()
    hand_and_emg_csv(tmp_path / "csv")
    data, _ = read_folder(tmp_path / "csv", "csv", parse_modalities("hand=x,y,z"))
    source = Workspace.create(tmp_path / "source", data).root
    first = save_run(source, report, "hand ML", created=when)
    second = save_run(source, report, "hand model", created=when + dt.timedelta(1))
    broken = source / RUNS_DIR / "20261125-000000-broken"
    broken.mkdir()
    (broken / "run.json").write_text("{not json")
    panel, _, told = panel_on(server, source)
    try:
        content = panel.export_workspace(None)
    finally:
        panel.close()
    title, body, color = told[-1]
    assert title == "Workspace exported" and "6 demonstrations, 2 evaluation run(s)" in body
    assert "Left out, unreadable: 20261125-000000-broken (" in body and color == "yellow"
    upload = exchange.read_upload("shared.zip", content)
    assert sorted(upload.runs) == sorted([first.folder.name, second.folder.name])
    for run in (first, second):
        assert upload.runs[run.folder.name] == run_tree(run.folder)  # file for file
        assert "run.json" in upload.runs[run.folder.name]

    # Another workspace, with the first run already (a copy) and another run of the
    # second's name.
    hand_and_emg_csv(tmp_path / "csv2")
    other, _ = read_folder(tmp_path / "csv2", "csv", parse_modalities("hand=x,y,z"))
    target = Workspace.create(tmp_path / "target", other).root
    shutil.copytree(first.folder, target / RUNS_DIR / first.folder.name)
    taken = save_run(target, {**report, "note": "theirs"}, "hand model",
                     created=when + dt.timedelta(1))  # fmt: skip
    assert taken.folder.name == second.folder.name
    before = {p.name: run_tree(p) for p in (target / RUNS_DIR).iterdir()}
    panel, store, told = panel_on(server, target)
    try:
        assert panel.replace_workspace(None, upload)
    finally:
        panel.close()
    title, body, _ = told[-1]
    assert title == "Workspace imported"
    assert "; 1 evaluation run(s) added to the saved runs, 1 run(s) already there, left as " \
           "they were." in body
    runs = {p.name: run_tree(p) for p in (target / RUNS_DIR).iterdir()}
    imported = f"{second.folder.name}-imported"
    assert set(runs) == {first.folder.name, second.folder.name, imported}
    for name, files in before.items():
        assert runs[name] == files  # nothing overwritten
    assert runs[imported] == run_tree(second.folder)
    assert imported in list_runs(target)  # listed in the Data tab
    assert [p.name for p in store.state.primitives] == [p.name for p in upload.data.primitives]
    # Importing again adds nothing: every run is there.
    panel, _, told = panel_on(server, target)
    try:
        panel.replace_workspace(None, upload)
    finally:
        panel.close()
    assert "added" not in told[-1][1] and "; 2 run(s) already there" in told[-1][1]
    assert {p.name: run_tree(p) for p in (target / RUNS_DIR).iterdir()} == runs
