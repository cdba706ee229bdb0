"""The workspace folder: exact round trips, atomic writes, safe names, clear errors, and a
SIGKILL in the middle of writing that loses nothing already written."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from app.workspace import (
    COLUMNS,
    FORMAT,
    PALETTE,
    PrimitiveEntry,
    Workspace,
    WorkspaceData,
    check_color,
    check_name,
)
from promp.data import Demonstration
from tests.conftest import REPO


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


def test_replace_all_then_load_is_an_exact_round_trip(tmp_path) -> None:
    workspace = Workspace(tmp_path / "ws")
    assert workspace.is_empty()
    data = make_data()
    workspace.replace_all(data)
    assert not workspace.is_empty()
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
    workspace = Workspace(tmp_path / "ws")
    workspace.replace_all(make_data())
    path = workspace.write_demo("reach", make_demo("reach_002", 5))
    before = path.read_bytes()
    assert not [p for p in workspace.root.rglob("*") if p.name.endswith(".tmp")]

    def failing_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(OSError, match="disk full"):
        workspace.write_demo("reach", make_demo("reach_002", 6))
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
    workspace = Workspace(tmp_path / "ws")
    workspace.replace_all(make_data())
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
        # Checked as an imported archive's index is (app.workspace.check_index).
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


def test_rename_and_delete(tmp_path) -> None:
    workspace = Workspace(tmp_path / "ws")
    workspace.replace_all(make_data())
    workspace.rename_primitive("reach", "grasp")
    assert (workspace.demo_dir("grasp") / "reach_000.csv").exists()
    assert not workspace.demo_dir("reach").exists()
    with pytest.raises(ValueError, match="already exists"):
        workspace.rename_primitive("grasp", "to_bin-2")
    workspace.delete_demo("grasp", "reach_000")
    assert not (workspace.demo_dir("grasp") / "reach_000.csv").exists()
    workspace.delete_primitive("grasp")
    assert not workspace.demo_dir("grasp").exists()


def test_a_failed_replace_leaves_the_old_workspace_untouched(tmp_path) -> None:
    workspace = Workspace(tmp_path / "ws")
    workspace.replace_all(make_data())
    before = {p: p.read_bytes() for p in workspace.root.rglob("*") if p.is_file()}
    bad = make_data()
    bad.primitives.append(PrimitiveEntry("no good", (0, 0, 0)))
    with pytest.raises(ValueError, match="invalid primitive name"):
        workspace.replace_all(bad)
    assert {p: p.read_bytes() for p in workspace.root.rglob("*") if p.is_file()} == before


WRITER = textwrap.dedent(
    """
    import sys
    import numpy as np
    from app.workspace import COLUMNS, Workspace
    from promp.data import Demonstration

    workspace = Workspace(sys.argv[1])
    rng = np.random.default_rng(0)
    for i in range(100000):
        values = rng.normal(size=(4000, len(COLUMNS)))  # ~700 kB of CSV per file
        demo = Demonstration(np.arange(4000) * 0.02, values, COLUMNS, name=f"d_{i % 5:03d}")
        workspace.write_demo("p", demo)
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
