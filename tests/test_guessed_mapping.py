"""The modalities guessed for a dataset, shown ready to edit: ``read_dataset`` takes mapping
strings as they are written; ``guessed_mapping`` gives the guess alone, for every format;
``python -m app --import-dataset`` and ``python -m promp.evaluate`` print it as ``--modality``
options to paste, after an import and after a refusal too (the Data tab's preview is
``tests/test_import_in_data_tab.py``'s)."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
from numpy.testing import assert_array_equal

import promp
from app.cli import build_parser, prepare_workspace
from promp.datasets import (
    command_line_modalities,
    guessed_mapping,
    modality_options,
    parse_modalities,
    read_dataset,
    write_csv_dataset,
)
from tests import rig_files as rf
from tests.synthetic import make_dataset

WRENCH = "cartesianEndEffectorWrench"
GUESSED = f"{WRENCH}={WRENCH}:0,1,2,3,4,5; state=state:0,1,2,3,4,5,6"
PASTE = f"--modality {WRENCH}={WRENCH}:0,1,2,3,4,5 --modality state=state:0,1,2,3,4,5,6"


def test_read_dataset_takes_mapping_strings(tmp_path: Path) -> None:
    rf.write_icub_dump(tmp_path, {"reach": 2, "wave": 2})
    typed = "hand=state:0,1,2@m"
    objects = promp.read_dataset(tmp_path, "yarp", modalities=parse_modalities(typed))
    for given in ([typed], typed, [f"{typed}; turn=state:3,4,5,6"], (typed,)):
        read = promp.read_dataset(tmp_path, "yarp", modalities=given)
        assert read.mapping.startswith(typed) and read.files == objects.files
        assert_array_equal(read.dataset["wave"][1].values[:, :3],
                           objects.dataset["wave"][1].values)  # fmt: skip
    write_csv_dataset(tmp_path / "csv", make_dataset(seed=1, n_demos=2))
    csv = read_dataset(tmp_path / "csv", "csv", ["hand=x,y,z"])
    assert csv.layout.names == ("hand",) and csv.layout.modalities[0].unit == "m"
    for bad, said in [
        ([3], "got int 3"),
        (3, "got int"),
        ([b"hand=x,y,z"], "got bytes"),
        ({"hand": "x,y,z"}, "got dict"),
        (["hand"], "a modality is NAME=COL,COL"),
    ]:
        with pytest.raises(ValueError, match=said) as refused:
            read_dataset(tmp_path / "csv", "csv", bad)
        assert "NAME=COL" in str(refused.value) or "mapping strings, e.g. 'hand=x,y,z'" in str(
            refused.value)  # fmt: skip


def test_the_guess_alone_for_every_format(tmp_path: Path, heights_dir: Path) -> None:
    rf.write_icub_dump(tmp_path / "dump", {"reach": 2})
    assert guessed_mapping(tmp_path / "dump", "yarp") == GUESSED
    assert guessed_mapping(tmp_path / "dump", "yarp") == read_dataset(tmp_path / "dump",
                                                                      "yarp").mapping
    write_csv_dataset(tmp_path / "csv", make_dataset(seed=1, n_demos=2))
    assert guessed_mapping(tmp_path / "csv", "csv") == "hand=x,y,z; head=roll,pitch,yaw"
    assert guessed_mapping(heights_dir, "records") == "hand=x,y,z"
    assert guessed_mapping(tmp_path / "nothing", "xdf") == ""  # nothing to guess from
    # Pasted back, the options give the same modalities.
    pasted = command_line_modalities(shlex.split(PASTE)[1::2])
    assert "; ".join(m.spec() for m in pasted) == GUESSED
    braces = modality_options("hand=/pose:pose.position.{x,y,z}@mm; head=h:0,1")
    assert braces == "--modality 'hand=/pose:pose.position.{x,y,z}@mm' --modality head=h:0,1"


def import_dataset(tmp_path: Path, source: Path, *more: str) -> None:
    args = build_parser().parse_args(["--workspace", str(tmp_path / "ws"), "--import-dataset",
                                      str(source), "--format", "yarp", *more])  # fmt: skip
    prepare_workspace(args)


def test_the_studio_command_line_prints_the_guess_to_paste(tmp_path: Path, capsys) -> None:
    rf.write_icub_dump(tmp_path / "dump", {"reach": 2, "wave": 2})
    import_dataset(tmp_path, tmp_path / "dump")
    out = capsys.readouterr().out
    assert f"  Mapping: {GUESSED}" in out
    assert f"The modalities were guessed; to change them, edit and pass: {PASTE}\n" in out
    assert f"reach/00000: stream '{WRENCH}' starts at 0.037 s" in out  # the cut, said
    # Refused for a port too late: the guess still printed, to edit.
    rf.write_icub_dump(tmp_path / "late", {"reach": 2}, delay=1.5)
    with pytest.raises(ValueError) as refused:
        import_dataset(tmp_path / "again", tmp_path / "late")
    text = str(refused.value)
    assert text.startswith(f"reach/00000: stream '{WRENCH}' starts at 1.500 s")
    assert text.endswith(f"\nThe modalities guessed (edit them, then pass them back): {PASTE}")
    assert not (tmp_path / "again" / "ws").exists()
    # Given modalities: nothing guessed, nothing printed about it.
    with pytest.raises(ValueError) as given:
        import_dataset(tmp_path / "given", tmp_path / "late", "--modality",
                       "hand=state:0,1,2@m", "--modality", f"w={WRENCH}:0")  # fmt: skip
    assert "--modality" not in str(given.value)
    import_dataset(tmp_path / "typed", tmp_path / "late", "--modality", "hand=state:0,1,2@m")
    out = capsys.readouterr().out
    assert "1 primitives, 2 demonstrations: reach (2)" in out and "were guessed" not in out


def test_the_evaluation_prints_the_guess_to_paste(tmp_path: Path, capsys) -> None:
    from promp.evaluate.cli import main

    rf.write_icub_dump(tmp_path / "late", {"reach": 3, "wave": 3}, delay=1.5)
    assert main([str(tmp_path / "late"), "--format", "yarp"]) == 2
    err = capsys.readouterr().err
    assert f"error: reach/00000: stream '{WRENCH}' starts at 1.500 s" in err
    assert f"The modalities guessed (edit them, then pass them back): {PASTE}" in err
    rf.write_icub_dump(tmp_path / "dump", {"reach": 3, "wave": 3})
    code = main([str(tmp_path / "dump"), "--format", "yarp", "--cut", "still", "--percent", "50",
                 "--alpha", "ml", "--basis", "5", "--width", "1", "--shrinkage", "0.5",
                 "--noise-scale", "1", "--jobs", "1", "--subset", "2",
                 "--observe", "state"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 0, err
    assert f"mapping: {GUESSED}\n" in err
    assert f"  guessed; to change it, edit and pass: {PASTE}\n" in err
