"""The workspace folder: exact round trips, atomic writes, safe names, clear errors, a SIGKILL
in the middle of writing that loses nothing already written, folders that are not the
studio's left untouched, and deletions that go to a trash and come back byte for byte."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from app.io.workspace import FolderKind, Workspace, WorkspaceData, inspect_folder
from app.io.workspace_index import FORMAT, PALETTE, PrimitiveEntry, check_color, check_name
from promp.data import Demonstration, Layout, Modality
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT
from tests.conftest import REPO

COLUMNS = LAYOUT.columns


def make_demo(name: str, seed: int, n: int = 50) -> Demonstration:
    rng = np.random.default_rng(seed)
    times = np.cumsum(rng.uniform(0.015, 0.025, n)) - 0.01
    values = rng.normal(size=(n, len(COLUMNS))) * [0.1, 0.1, 0.1, 0.3, 0.3, 0.3]
    return Demonstration(times - times[0], values, COLUMNS, name=name)


def make_data() -> WorkspaceData:
    return WorkspaceData(
        primitives=[PrimitiveEntry("reach", PALETTE[0]), PrimitiveEntry("to_bin-2", (1, 2, 3))],
        demos={
            "reach": [make_demo("reach_000", 0), make_demo("reach_001", 1)],
            "to_bin-2": [make_demo("to_bin-2_000", 2)],
        },
        settings={"n_basis": 12, "width": 1.25, "shrinkage": None},
    )


def snapshot(root) -> dict:
    """Every file under ``root`` with its bytes (and every folder), to compare states."""
    return {
        p.relative_to(root).as_posix(): (p.read_bytes() if p.is_file() else None)
        for p in sorted(root.rglob("*"))
    }


def test_create_then_load_is_an_exact_round_trip(tmp_path) -> None:
    assert inspect_folder(tmp_path / "ws") == (FolderKind.ABSENT, "")
    data = make_data()
    workspace = Workspace.create(tmp_path / "ws", data)
    assert inspect_folder(workspace.root)[0] is FolderKind.WORKSPACE
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ws"]  # no staging folder left
    loaded = workspace.load()
    assert loaded.primitives == data.primitives
    assert loaded.settings == data.settings
    assert loaded.problems == []
    for name, demos in data.demos.items():
        assert [d.name for d in loaded.demos[name]] == [d.name for d in demos]
        for a, b in zip(loaded.demos[name], demos, strict=True):
            np.testing.assert_array_equal(a.times, b.times)  # bit for bit
            np.testing.assert_array_equal(a.select(COLUMNS), b.values)
    index = json.loads(workspace.index_path.read_text())
    assert index["format"] == FORMAT
    assert [m["name"] for m in index["layout"]] == ["hand", "head"]
    header = workspace.demo_path("reach", "reach_000").read_text().splitlines()[0]
    assert header == "t,x,y,z,roll,pitch,yaw"


def test_writes_leave_no_temporary_files_and_a_failed_write_keeps_the_old_file(
    tmp_path, monkeypatch
) -> None:
    workspace = Workspace.create(tmp_path / "ws", make_data())
    path = workspace.write_demo("reach", make_demo("reach_002", 5), LAYOUT)
    before = path.read_bytes()
    assert not [p for p in workspace.root.rglob("*") if p.name.endswith(".tmp")]

    def failing_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(OSError, match="disk full"):
        workspace.write_demo("reach", make_demo("reach_002", 6), LAYOUT)
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert not [p for p in workspace.root.rglob("*") if p.name.endswith(".tmp")]


@pytest.mark.parametrize("name", ["", "a b", "../evil", "x/y", "_hidden", "a" * 41, "é", None])
def test_unsafe_names_are_refused(name) -> None:
    with pytest.raises(ValueError, match="invalid primitive name"):
        check_name(name)


@pytest.mark.parametrize("color", [(0, 0), (0, 0, 256), (-1, 0, 0), (1, 2, 3, 4)])
def test_bad_colours_are_refused(color) -> None:
    with pytest.raises(ValueError, match="three integers in 0-255"):
        check_color(color)


def test_demo_paths_cannot_leave_the_workspace(tmp_path) -> None:
    workspace = Workspace(tmp_path / "ws")
    with pytest.raises(ValueError, match="invalid demonstration name"):
        workspace.demo_path("reach", "../../etc/passwd")
    with pytest.raises(ValueError, match="invalid primitive name"):
        workspace.demo_dir("..")


def test_unreadable_demonstrations_are_reported_and_the_rest_loads(tmp_path) -> None:
    workspace = Workspace.create(tmp_path / "ws", make_data())
    broken = workspace.demo_path("reach", "reach_001")
    broken.write_text("t,x\n0,1\n")  # missing columns
    (workspace.demo_dir("reach") / "notes.txt").write_text("not a demo")
    loaded = workspace.load()
    assert [d.name for d in loaded.demos["reach"]] == ["reach_000"]
    assert len(loaded.problems) == 1 and "reach_001" in loaded.problems[0]


@pytest.mark.parametrize(
    "content, message",
    [
        ("{not json", "not a readable workspace index"),
        (json.dumps({"format": "other"}), "not a studio workspace index"),
        (json.dumps({"format": FORMAT, "version": 99}), "unsupported workspace version 99"),
        # Checked as an imported archive's index is (app.io.workspace_index.check_index).
        (
            json.dumps({"format": FORMAT, "version": 1, "primitives": [{"name": "a"}]}),
            "primitive 0 needs a 'name' and a 'color'",
        ),
        (
            json.dumps({"format": FORMAT, "version": 1, "settings": {"n_basis": 0}}),
            "invalid learning settings",
        ),
    ],
)
def test_a_bad_index_is_a_clear_error(tmp_path, content, message) -> None:
    workspace = Workspace(tmp_path / "ws")
    workspace.root.mkdir()
    workspace.index_path.write_text(content)
    with pytest.raises(ValueError, match=message):
        workspace.load()


def test_a_file_where_the_workspace_should_be_is_an_error(tmp_path) -> None:
    (tmp_path / "ws").write_text("")
    with pytest.raises(ValueError, match="not a folder"):
        Workspace(tmp_path / "ws")


def test_rename(tmp_path) -> None:
    workspace = Workspace.create(tmp_path / "ws", make_data())
    workspace.rename_primitive("reach", "grasp")
    assert (workspace.demo_dir("grasp") / "reach_000.csv").exists()
    assert not workspace.demo_dir("reach").exists()
    with pytest.raises(ValueError, match="already exists"):
        workspace.rename_primitive("grasp", "to_bin-2")


def test_folders_are_told_apart_and_a_foreign_one_is_described(tmp_path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    assert inspect_folder(empty) == (FolderKind.EMPTY, "")
    mine = tmp_path / "recordings"
    (mine / "reach").mkdir(parents=True)
    for i in range(3):
        (mine / "reach" / f"take{i}.csv").write_text("t,x\n0,1\n1,2\n")
    kind, message = inspect_folder(mine)
    assert kind is FolderKind.FOREIGN
    assert "holds 3 file(s) (e.g. reach/take0.csv" in message
    assert "--import-dataset" in message and "not a studio workspace" in message
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="not a folder"):
        inspect_folder(tmp_path / "file")
    with pytest.raises(ValueError, match="holds 3 file"):
        Workspace.create(mine, make_data())
    assert len(list(mine.rglob("*"))) == 4  # untouched


def test_a_failed_creation_leaves_nothing(tmp_path, monkeypatch) -> None:
    def failing_rename(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "rename", failing_rename)
    with pytest.raises(OSError, match="disk full"):
        Workspace.create(tmp_path / "ws", make_data())
    monkeypatch.undo()
    assert list(tmp_path.iterdir()) == []  # neither the workspace nor its staging folder
    bad = make_data()
    bad.primitives.append(PrimitiveEntry("no good", (0, 0, 0)))
    with pytest.raises(ValueError, match="invalid primitive name"):
        Workspace.create(tmp_path / "ws", bad)
    assert list(tmp_path.iterdir()) == []


def test_a_deleted_demonstration_goes_to_the_trash_and_comes_back_byte_for_byte(tmp_path) -> None:
    workspace = Workspace.create(tmp_path / "ws", make_data())
    before = snapshot(workspace.root)
    reach = PrimitiveEntry("reach", PALETTE[0])
    entry = workspace.trash_demo(reach, "reach_001")
    assert not workspace.demo_path("reach", "reach_001").exists()
    assert entry.kind == "demo" and entry.paths == ("demos/reach/reach_001.csv",)
    trashed = workspace.trash.root / entry.name / "files" / "demos/reach/reach_001.csv"
    assert trashed.read_bytes() == before["demos/reach/reach_001.csv"]
    (listed,) = Workspace(workspace.root).trash.entries()  # on disk: survives a restart
    assert listed == entry
    workspace.restore(entry.name)
    after = snapshot(workspace.root)
    assert {k: v for k, v in after.items() if not k.startswith("trash")} == before
    assert workspace.trash.entries() == []
    with pytest.raises(ValueError, match="the trash has no entry"):
        workspace.restore(entry.name)


def test_a_deleted_primitive_comes_back_in_its_place_with_its_colour(tmp_path) -> None:
    workspace = Workspace.create(tmp_path / "ws", make_data())
    before = snapshot(workspace.root)
    index = workspace.read_index()
    reach = index.primitives[0]
    workspace.save_index(index.primitives[1:], index.settings, index.layout, index.checks)
    entry = workspace.trash_primitive(reach, 0)
    assert not workspace.demo_dir("reach").exists()
    # A demonstration of a deleted primitive brings its primitive back too.
    other = workspace.trash_demo(index.primitives[1], "to_bin-2_000")
    workspace.save_index([], index.settings, index.layout, index.checks)
    workspace.trash_primitive(index.primitives[1], 0)
    workspace.restore(entry.name)
    workspace.restore(other.name)
    loaded = workspace.load()
    assert [p.name for p in loaded.primitives] == ["reach", "to_bin-2"]
    assert loaded.primitives[1].color == (1, 2, 3)
    path = "demos/reach/reach_000.csv"
    assert snapshot(workspace.root)[path] == before[path]
    # A name taken since: refused, nothing moves.
    entry = workspace.trash_demo(loaded.primitives[0], "reach_000")
    workspace.write_demo("reach", make_demo("reach_000", 9), LAYOUT)
    state = snapshot(workspace.root)
    with pytest.raises(ValueError, match="already exists"):
        workspace.restore(entry.name)
    assert snapshot(workspace.root) == state


def test_replacing_keeps_the_old_workspace_in_the_trash_and_restoring_swaps_back(
    tmp_path,
) -> None:
    workspace = Workspace.create(tmp_path / "ws", make_data())
    (workspace.root / "notes.txt").write_text("the user's own file")
    before = snapshot(workspace.root)
    other = WorkspaceData(
        primitives=[PrimitiveEntry("wave", (9, 9, 9))],
        demos={"wave": [make_demo("wave_000", 7), make_demo("wave_001", 8)]},
        layout=LAYOUT,
    )
    entry = workspace.replace_all(other, "replaced by a test")
    assert entry.kind == "workspace" and set(entry.paths) == {"demos", "studio.json"}
    assert [p.name for p in workspace.load().primitives] == ["wave"]
    assert (workspace.root / "notes.txt").read_text() == "the user's own file"
    assert not [p for p in workspace.root.iterdir() if p.name.startswith(".staging")]
    workspace.restore(entry.name)
    after = snapshot(workspace.root)
    assert {k: v for k, v in after.items() if not k.startswith("trash")} == before
    (swapped,) = workspace.trash.entries()  # the imported content, restorable in turn
    assert swapped.kind == "workspace"


def test_a_failed_replace_leaves_the_old_workspace_untouched(tmp_path) -> None:
    workspace = Workspace.create(tmp_path / "ws", make_data())
    before = snapshot(workspace.root)
    bad = make_data()
    bad.primitives.append(PrimitiveEntry("no good", (0, 0, 0)))
    with pytest.raises(ValueError, match="invalid primitive name"):
        workspace.replace_all(bad)
    assert snapshot(workspace.root) == before


def test_a_workspace_of_other_modalities_round_trips(tmp_path) -> None:
    layout = Layout((Modality("emg", ("e1", "e2"), unit="mV"),))
    demo = Demonstration(np.arange(5) * 0.1, np.arange(10.0).reshape(5, 2), ("e1", "e2"), "d_0")
    data = WorkspaceData([PrimitiveEntry("grip", (1, 1, 1))], {"grip": [demo]}, layout=layout)
    workspace = Workspace.create(tmp_path / "ws", data)
    loaded = workspace.load()
    assert loaded.layout == layout
    np.testing.assert_array_equal(loaded.demos["grip"][0].values, demo.values)
    bad = WorkspaceData(layout=Layout((Modality("hand", ("x", "y")),)))
    with pytest.raises(ValueError, match="'hand' drives the 3D view"):
        Workspace.create(tmp_path / "other", bad)


WRITER = textwrap.dedent(
    """
    import sys
    import numpy as np
    from app.io.workspace import Workspace
    from robots.icub.layout import STUDIO_LAYOUT as LAYOUT
    COLUMNS = LAYOUT.columns
    from promp.data import Demonstration

    workspace = Workspace(sys.argv[1])
    rng = np.random.default_rng(0)
    for i in range(100000):
        values = rng.normal(size=(4000, len(COLUMNS)))  # ~700 kB of CSV per file
        demo = Demonstration(np.arange(4000) * 0.02, values, COLUMNS, name=f"d_{i % 5:03d}")
        workspace.write_demo("p", demo, LAYOUT)
        print(i, flush=True)
    """
)


def test_sigkill_while_writing_leaves_only_complete_files(tmp_path) -> None:
    from promp.datasets import read_csv_demo

    root = tmp_path / "ws"
    proc = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(root)],
        cwd=REPO,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        for _ in range(7):  # files are being overwritten when the kill lands
            assert proc.stdout.readline(), "the writer stopped early"
    finally:
        proc.kill()
        proc.wait(timeout=30)
        proc.stdout.close()
    files = sorted((root / "demos" / "p").glob("*.csv"))
    assert [f.stem for f in files] == [f"d_{i:03d}" for i in range(5)]
    for path in files:  # every file is complete: the old version or the new one
        assert read_csv_demo(path).n_samples == 4000
