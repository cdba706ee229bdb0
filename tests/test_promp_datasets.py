"""Dataset formats: the CSV folder and the lab records."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from promp.datasets import (
    guess_layout,
    load_csv_dataset,
    load_records_dataset,
    parse_modalities,
    parse_modality,
    read_csv_demo,
    read_dataset,
    read_record,
    write_csv_dataset,
    write_csv_demo,
)
from tests.synthetic import LAYOUT, make_dataset


def test_csv_round_trip_is_exact(tmp_path: Path) -> None:
    dataset = make_dataset(seed=3, n_demos=3)
    write_csv_dataset(tmp_path, dataset)
    loaded = load_csv_dataset(tmp_path, LAYOUT)
    assert list(loaded) == sorted(dataset)
    for name, demos in dataset.items():
        for original, read in zip(demos, loaded[name], strict=True):
            assert_array_equal(read.times, original.times)
            assert_array_equal(read.values, original.values)
            assert read.columns == original.columns


def test_csv_write_is_atomic(tmp_path: Path) -> None:
    demo = make_dataset(n_demos=1)["left"][0]
    path = tmp_path / "p" / "d.csv"
    write_csv_demo(path, demo)
    assert [p.name for p in path.parent.iterdir()] == ["d.csv"]  # no temp file left over


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "empty file"),
        ("x,y\n1,2\n3,4\n", "no 't'"),
        ("t,x\n", "no samples"),
        ("t,x\n0,1\n1,2,3\n", "every row"),
        ("t,x\n0,1\n1,abc\n", "non-numeric"),
        ("t,x\n0,1\n1,nan\n", "NaN"),
        ("t,x\n0,1\n", "at least 2 samples"),
        ("t,x\n0,1\n0,2\n", "strictly increasing"),
    ],
)
def test_bad_csv_files_say_what_is_wrong(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as info:
        read_csv_demo(path)
    assert "bad.csv" in str(info.value)


def test_dataset_needs_the_layout_columns(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "d.csv").write_text("t,x,y,z\n0,0,0,0\n1,1,1,1\n")
    with pytest.raises(ValueError, match=r"missing column\(s\) \['roll', 'pitch', 'yaw'\]"):
        load_csv_dataset(tmp_path, LAYOUT)
    with pytest.raises(ValueError, match="no <primitive>"):
        load_csv_dataset(tmp_path / "a")
    with pytest.raises(ValueError, match="does not exist"):
        load_csv_dataset(tmp_path / "nowhere")


def _write_record(path: Path, rows: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, rows)


def test_records_group_sub_folders_by_class_and_drop_missing_wrench(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    rows = np.column_stack([np.arange(5) * 0.01, rng.normal(size=(5, 12))])
    rows[2, 4:10] = -1.0  # no wrench reading in row 2
    _write_record(tmp_path / "up" / "person1" / "record0.txt", rows)
    _write_record(tmp_path / "up" / "person2" / "record0.txt", rows)
    _write_record(tmp_path / "down" / "person1" / "record0.txt", rows)
    read = read_dataset(tmp_path, "records")
    position, layout = read.dataset, read.layout
    assert layout.names == ("hand",) and layout.modality("hand").unit == "m"
    assert {k: len(v) for k, v in position.items()} == {"down": 1, "up": 2}
    assert [d.name for d in position["up"]] == ["person1/record0", "person2/record0"]
    assert position["up"][0].n_samples == 5  # positions are valid in that row: kept
    assert_array_equal(layout.extract(position["up"][0]), rows[:, 10:13])
    read = read_dataset(
        tmp_path, "records", parse_modalities("hand=x,y,z; wrench=fx,fy,fz,mx,my,mz")
    )
    wrench, layout = read.dataset, read.layout
    assert layout.modality("wrench").unit == "N|N m"
    assert wrench["up"][0].n_samples == 4  # dropped when the wrench is used
    assert 0.02 not in wrench["up"][0].times
    assert load_records_dataset(tmp_path, drop_missing_wrench=True)["up"][0].n_samples == 4


def test_records_reject_wrong_files(tmp_path: Path) -> None:
    path = tmp_path / "c" / "p" / "r.txt"
    _write_record(path, np.ones((3, 5)))
    with pytest.raises(ValueError, match="13 columns"):
        read_record(path)
    path.write_text("not numbers at all\n")
    with pytest.raises(ValueError, match="not a lab record"):
        read_record(path)
    with pytest.raises(ValueError, match=r"lab records have no column\(s\) \['gaze'\]"):
        read_dataset(tmp_path, "records", [parse_modality("eyes=gaze")])
    with pytest.raises(ValueError, match="unknown dataset format"):
        read_dataset(tmp_path, "xls")


def test_modalities_are_parsed_and_guessed_from_the_columns() -> None:
    hand, head = parse_modalities("hand=x,y,z;\n head = roll, pitch,yaw")
    assert (hand.name, hand.columns) == ("hand", ("x", "y", "z"))
    assert (hand.unit, hand.kind) == ("m", "linear")
    assert (head.unit, head.kind) == ("rad", "angle")
    assert parse_modality("emg=e1,e2").unit == ""
    for bad, message in [
        ("hand", "NAME=COL"),
        ("=x", "NAME=COL"),
        ("hand=", "NAME=COL"),
        ("1hand=x", "invalid modality name"),
        ("h and=x", "invalid modality name"),
    ]:
        with pytest.raises(ValueError, match=message):
            parse_modality(bad)
    with pytest.raises(ValueError, match="at least one modality"):
        parse_modalities(" ; ")
    assert guess_layout(["t", "x", "y", "z", "roll", "pitch", "yaw"]).names == ("hand", "head")
    assert guess_layout(["t", "yaw", "pitch", "roll"]).names == ("head",)
    signal = guess_layout(["t", "emg1", "emg2"])
    assert signal.names == ("signal",) and signal.columns == ("emg1", "emg2")
    with pytest.raises(ValueError, match="no column besides the time"):
        guess_layout(["t"])


def test_csv_demonstrations_in_sub_folders_are_named_by_their_path(tmp_path: Path) -> None:
    for person in ("ann", "bob"):
        folder = tmp_path / "reach" / person
        folder.mkdir(parents=True)
        (folder / "take1.csv").write_text("t,x,y,z\n0,0,0,0\n1,1,1,1\n")
    read = read_dataset(tmp_path, "csv")
    dataset, layout = read.dataset, read.layout
    assert [d.name for d in dataset["reach"]] == ["ann/take1", "bob/take1"]
    assert layout.names == ("hand",)
    with pytest.raises(ValueError, match=r"missing column\(s\) \['w'\]"):
        read_dataset(tmp_path, "csv", [parse_modality("hand=x,y,w")])


def test_real_heights_records(heights_dir: Path) -> None:
    dataset = read_dataset(heights_dir, "records").dataset
    assert {k: len(v) for k, v in dataset.items()} == {"bottom": 40, "middle": 40, "top": 42}
    lengths = [d.n_samples for demos in dataset.values() for d in demos]
    assert min(lengths) == 63 and max(lengths) == 405
