"""YARP dumps as a real iCub writes them (``promp.rigs.yarp_layout``): a class's numbered port
folders (``<class>/<port>/<port>:o_NNNNN/data.log``) read the same demonstrations (names,
classes, values, times) and the same findings as the same data rearranged into take folders
(``<class>/<take>/<port>/data.log``); a folder matching neither layout, and port folders whose
numbers differ, are refused with the layouts expected and what was found."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.datasets import parse_modalities, read_dataset
from promp.rigs.yarp_layout import LAYOUTS
from tests import rig_files as rf

MAPPING = "hand=state:0,1,2@m; head=head:0,1,2@deg"
NUMBERS = ("00000", "00001", "00002", "00003", "00010")  # 00000: each port's first dump


def take(duration: float, still: bool = False) -> dict:
    """A take's two ports: the hand at 100 Hz (metres; held still when ``still``), the head at
    30 Hz from 5 ms later (degrees)."""
    hand_t = np.arange(round(duration * rf.HAND_HZ)) / rf.HAND_HZ
    head_t = rf.HEAD_DELAY + np.arange(round(duration * rf.HEAD_HZ)) / rf.HEAD_HZ
    hand = rf.hand_at(0 * hand_t if still else hand_t * 2.0 / duration)
    return {"state": (hand_t, hand.tolist()),
            "head": (head_t, np.degrees(rf.head_at(head_t * 2.0 / duration)).tolist())}  # fmt: skip


def dump_takes() -> dict:
    """Two classes of five takes; reach's 00002 lasts 3x longer than the others (a duration
    finding), wave's 00003 does not move its hand (a still finding)."""
    durations = {"reach": (1.9, 2.0, 6.3, 2.1, 2.2), "wave": (1.5, 1.6, 1.7, 1.6, 1.5)}
    return {
        klass: {n: take(d, still=(klass, n) == ("wave", "00003"))
                for n, d in zip(NUMBERS, spans, strict=True)}
        for klass, spans in durations.items()
    }  # fmt: skip


@pytest.fixture(scope="module")
def dumps(tmp_path_factory) -> tuple[Path, Path]:
    """The same dump in both layouts: (numbered port folders, take folders)."""
    root = tmp_path_factory.mktemp("dumps")
    takes = dump_takes()
    return (rf.write_yarp_dump(root / "numbered", takes, numbered=True),
            rf.write_yarp_dump(root / "takes", takes, numbered=False))  # fmt: skip


def test_the_numbered_port_layout_reads_as_its_take_folders(dumps) -> None:
    numbered, folders = dumps
    assert (numbered / "reach" / "state" / "state:o_00001" / "data.log").is_file()
    assert (numbered / "reach" / "state" / "state:o" / "data.log").is_file()  # take 00000
    assert (folders / "reach" / "00001" / "state" / "data.log").is_file()
    a = read_dataset(numbered, "yarp", parse_modalities(MAPPING))
    b = read_dataset(folders, "yarp", parse_modalities(MAPPING))
    assert {k: [d.name for d in v] for k, v in a.dataset.items()} == {
        "reach": list(NUMBERS), "wave": list(NUMBERS)}  # fmt: skip
    assert {k: [d.name for d in v] for k, v in b.dataset.items()} == {
        k: [d.name for d in v] for k, v in a.dataset.items()}  # fmt: skip
    assert a.layout == b.layout and a.mapping == b.mapping and a.files == b.files
    for klass in a.dataset:
        for da, db in zip(a.dataset[klass], b.dataset[klass], strict=True):
            assert da.columns == db.columns
            assert_allclose(da.times, db.times, rtol=0, atol=0)
            assert_allclose(da.values, db.values, rtol=0, atol=0)
    # The values are the take's own (reach 00001 lasts 2 s): the head's 30 Hz clock from the
    # take's first sample (the hand's), the hand interpolated at it, in metres and radians.
    demo = a.dataset["reach"][1]
    head_t = rf.HEAD_DELAY + np.arange(60) / rf.HEAD_HZ
    assert_allclose(demo.times, head_t, atol=1e-6)
    assert_allclose(demo.values[:, :3], rf.hand_at(head_t), atol=1e-6)
    assert_allclose(demo.values[:, 3:], rf.head_at(head_t), atol=1e-6)
    # The same findings, about the same takes, in the same words.
    assert [(f.key, f.kind) for f in a.findings] == [
        (("reach", "00002"), "duration"), (("wave", "00003"), "still")]  # fmt: skip
    assert a.findings == b.findings


def test_a_numbered_dump_through_the_command_line_and_the_upload(dumps, tmp_path, capsys) -> None:
    """``python -m app --import-dataset`` on the dump as it is, and its zip uploaded in the
    Data tab: the format told by its files, the same demonstrations as the take folders."""
    from app.cli import build_parser, prepare_workspace
    from app.io.dataset_import import extract_dataset_zip
    from app.io.workspace import Workspace
    from tests.test_dataset_import import zip_folder

    numbered, folders = dumps
    mapping = tmp_path / "mapping.txt"
    mapping.write_text(MAPPING.replace("; ", "\n"))
    args = build_parser().parse_args(["--workspace", str(tmp_path / "ws"), "--import-dataset",
                                      str(numbered), "--mapping", str(mapping)])  # fmt: skip
    prepare_workspace(args)
    out = capsys.readouterr().out
    assert "2 primitives, 10 demonstrations: reach (5), wave (5)" in out
    assert "reach/00001 ← reach/00001" in out
    data = Workspace(tmp_path / "ws").load()
    assert [d.name for d in data.demos["reach"]] == list(NUMBERS)
    upload = extract_dataset_zip(zip_folder(numbered, prefix="dump/"), "dump.zip")
    try:
        assert upload.format == "yarp"
        _, summary = upload.read(modalities=parse_modalities(MAPPING))
        assert summary.counts == {"reach": 5, "wave": 5}
        assert summary.findings == read_dataset(folders, "yarp",
                                                parse_modalities(MAPPING)).findings
    finally:
        upload.close()


def refused(root: Path, *match: str) -> str:
    with pytest.raises(ValueError) as error:
        read_dataset(root, "yarp", parse_modalities(MAPPING))
    message = str(error.value)
    for part in match:
        assert part in message, message
    return message


def test_port_folders_whose_numbers_differ_are_refused(dumps, tmp_path) -> None:
    """Matched by number, a port lacking a take another has would pair the wrong streams: an
    error naming the port and the takes, nothing read."""
    root = tmp_path / "gap"
    shutil.copytree(dumps[0], root)
    shutil.rmtree(root / "reach" / "head" / "head:o_00002")
    refused(root, "reach: its numbered port folders do not hold the same takes (head lacks "
                  "take 00002; the takes are 00000, 00001, 00002, 00003, 00010)",
            "rearrange the dump as <class>/<take>/<port>/")  # fmt: skip
    # A port dumped only once (its one unnumbered folder) beside numbered ones: take 00000 only.
    root = tmp_path / "once"
    shutil.copytree(dumps[0], root)
    for number in NUMBERS[1:]:
        shutil.rmtree(root / "wave" / "head" / f"head:o_{number}")
    refused(root, "wave: its numbered port folders do not hold the same takes (head lacks "
                  "takes 00001, 00002, 00003, 00010")  # fmt: skip


def test_a_folder_matching_neither_layout_is_refused_with_both(dumps, tmp_path) -> None:
    numbered, folders = dumps
    # The dumps of two ports in one folder (the dumpers started without a port folder each).
    root = tmp_path / "flat"
    for port in ("state", "head"):
        for number in ("00001", "00002"):
            shutil.copytree(numbered / "reach" / port / f"{port}:o_{number}",
                            root / "reach" / f"{port}:o_{number}")  # fmt: skip
    refused(root, LAYOUTS, "found reach/ holding the dumps of several ports (head:o_00001, "
                           "head:o_00002, state:o_00001, state:o_00002)")  # fmt: skip
    # Numbered port folders beside take folders in one class.
    root = tmp_path / "mixed"
    shutil.copytree(numbered / "reach", root / "reach")
    shutil.copytree(folders / "reach" / "00001", root / "reach" / "take1")
    refused(root, LAYOUTS, "found reach/ holding both numbered port folders (head, state) and "
                           "take folders (take1)")  # fmt: skip
    # A take folder holding its own data.log beside its port folders.
    root = tmp_path / "nested"
    shutil.copytree(folders / "wave" / "00001", root / "wave" / "00001")
    shutil.copy(folders / "wave" / "00001" / "state" / "data.log",
                root / "wave" / "00001" / "data.log")  # fmt: skip
    refused(root, LAYOUTS, "found wave/00001/ holding its own data.log beside folders with "
                           "theirs")  # fmt: skip


def test_a_missing_stream_says_how_the_dump_was_read(dumps, tmp_path) -> None:
    """What the issue met: a port the mapping names is not in a take. The error now says which
    layout the take was read in, its ports, and the two layouts."""
    root = tmp_path / "short"
    shutil.copytree(dumps[1] / "reach" / "00001", root / "reach" / "00001")
    shutil.copytree(dumps[1] / "reach" / "00002", root / "reach" / "00002")
    shutil.rmtree(root / "reach" / "00002" / "head")
    refused(root, "reach/00002: no numeric stream 'head' for modality 'head'",
            "reach/00002 was read as a take folder, its ports state; " + LAYOUTS)  # fmt: skip
