"""Natural order of names (``promp.names``): record2 before record10 wherever demonstrations,
takes, classes or files are read or listed: the dataset readers, the workspace, the workspace
archive, the rigs' recordings, the import's preview and the Teach list."""

from __future__ import annotations

import random
from pathlib import Path, PurePosixPath
from types import SimpleNamespace

import numpy as np
import pytest

from app.io import exchange
from app.io.dataset_import import read_folder
from app.io.workspace import Workspace, WorkspaceData
from app.io.workspace_index import PALETTE, PrimitiveEntry
from promp.data import Demonstration
from promp.datasets import read_dataset, write_csv_dataset
from promp.names import natural_key, natural_sorted
from tests import rig_files as rf
from tests.synthetic import COLUMNS, make_demo

RECORDS = [f"record{k}" for k in range(14)]  # record0 .. record13


def shuffled(items: list, seed: int = 0) -> list:
    out = list(items)
    random.Random(seed).shuffle(out)
    return out


def test_numbers_in_names_compare_as_numbers() -> None:
    assert natural_sorted(shuffled(RECORDS)) == RECORDS
    assert sorted(RECORDS) != RECORDS  # as text: record0, record1, record10, ..., record2
    assert natural_sorted(["take10-2", "take2-10", "take2-9", "take10-1"]) == [
        "take2-9", "take2-10", "take10-1", "take10-2"]  # fmt: skip
    # Case aside, then the name as written: a total order, the same everywhere.
    assert natural_sorted(["b", "B1", "a2", "A10", "a", "A"]) == ["A", "a", "a2", "A10", "b", "B1"]
    assert natural_sorted(["x007", "x7", "x07"]) == ["x007", "x07", "x7"]
    # Paths compare part by part; a name with no digit, or only digits, sorts too.
    paths = [PurePosixPath(p) for p in ("reach/take10/arm", "reach/take2/arm", "reach2/take1",
                                         "reach/take2/arm10", "reach/take2/arm9", "12", "3")]
    assert natural_sorted(paths) == [PurePosixPath(p) for p in (
        "3", "12", "reach/take2/arm", "reach/take2/arm9", "reach/take2/arm10",
        "reach/take10/arm", "reach2/take1")]  # fmt: skip
    assert natural_key("record²") != natural_key("record2")  # only ASCII digits are numbers
    assert natural_sorted([3, 1], key=lambda n: f"r{n}") == [1, 3]
    assert natural_sorted(RECORDS, reverse=True) == RECORDS[::-1]


TARGET = np.array([0.2, -0.2, 0.1, 0.0, 0.3, -0.6])


def demos(names: list[str], seed: int = 0) -> list[Demonstration]:
    rng = np.random.default_rng(seed)
    return [make_demo(rng, TARGET, name=name) for name in names]


@pytest.fixture
def csv_dataset(tmp_path: Path) -> Path:
    """Two classes of record0..record13 (and a class folder named with a number), in CSV."""
    root = tmp_path / "dataset"
    write_csv_dataset(root, {"reach10": demos(RECORDS[:3]), "reach2": demos(shuffled(RECORDS))})
    return root


def test_the_readers_take_classes_and_files_in_natural_order(csv_dataset: Path) -> None:
    read = read_dataset(csv_dataset, "csv")
    assert list(read.dataset) == ["reach2", "reach10"]
    assert [d.name for d in read.dataset["reach2"]] == RECORDS
    assert list(read.files)[:3] == [("reach2", "record0"), ("reach2", "record1"),
                                    ("reach2", "record2")]  # fmt: skip
    # The import's preview lists them so too.
    _, summary = read_folder(csv_dataset, "csv")
    assert list(summary.counts) == ["reach2", "reach10"]


def test_records_in_subfolders_are_read_in_natural_order(tmp_path: Path) -> None:
    """The lab-record layout, ``<class>/<person>/record<k>.txt``, person2 before person10."""
    rng = np.random.default_rng(1)
    for person in ("person10", "person2"):
        for name in shuffled(RECORDS[:12], seed=3):
            demo = make_demo(rng, TARGET, name=name)
            table = np.zeros((demo.n_samples, 13))
            table[:, 0] = demo.times
            table[:, 1:4] = demo.values[:, :3]
            path = tmp_path / "reach" / person / f"{name}.txt"
            path.parent.mkdir(parents=True, exist_ok=True)
            np.savetxt(path, table, fmt="%.10g")
    names = [d.name for d in read_dataset(tmp_path, "records").dataset["reach"]]
    assert names == [f"{p}/{r}" for p in ("person2", "person10") for r in RECORDS[:12]]


def test_the_workspace_and_its_archive_keep_the_natural_order(tmp_path: Path) -> None:
    data = WorkspaceData(
        primitives=[PrimitiveEntry("left", PALETTE[0])],
        demos={"left": [Demonstration(d.times, d.values, COLUMNS, d.name)
                        for d in demos(shuffled(RECORDS))]},  # fmt: skip
    )
    workspace = Workspace.create(tmp_path / "ws", data)
    assert [d.name for d in workspace.load().demos["left"]] == RECORDS
    upload = exchange.read_workspace_zip(exchange.workspace_zip(data))
    assert [d.name for d in upload.data.demos["left"]] == RECORDS


def test_the_teach_list_is_in_order_newest_first(tmp_path: Path) -> None:
    """The Teach tab's list of a workspace of record0..record13: record13 down to record0
    (the list is newest first), never record9 ... record2, record13, ..., record1, record0."""
    import viser

    from app.core.learner_state import LearnerState
    from app.core.snapshot import Snapshot
    from app.core.store import Store
    from app.core.view_state import ViewState
    from app.io.net import free_port
    from app.panels.teach.demos import DemoList

    data = WorkspaceData(
        primitives=[PrimitiveEntry("left", PALETTE[0])],
        demos={"left": [Demonstration(d.times, d.values, COLUMNS, d.name)
                        for d in demos(shuffled(RECORDS))]},  # fmt: skip
    )
    Workspace.create(tmp_path / "ws", data)
    store = Store.open(tmp_path / "ws")
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        listing = DemoList(SimpleNamespace(gui=server.gui))
        assert listing.show(Snapshot(store.state, LearnerState(), ViewState()), "left")
        assert [handle.label for _, handle in listing._rows] == RECORDS[::-1]
    finally:
        server.stop()


def test_rig_recordings_are_taken_in_natural_order(tmp_path: Path) -> None:
    """Whole YARP takes, one per demonstration: take2 before take10."""
    t = rf.YARP_START + np.arange(0, 1.0, 0.01)
    for k in (10, 2, 1):
        rf.write_yarp_port(tmp_path / "reach" / f"take{k}" / "arm", "/arm:o", t,
                           rf.hand_at(t - rf.YARP_START).tolist())  # fmt: skip
    from promp.datasets import parse_modalities

    read = read_dataset(tmp_path, "yarp", parse_modalities("hand=arm:0,1,2@m"))
    assert [d.name for d in read.dataset["reach"]] == ["take1", "take2", "take10"]
