"""Evaluation runs kept as folders, compared; confusion matrices; figures a person can read."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from promp.data import Layout, Modality
from promp.datasets import write_csv_dataset
from promp.evaluate.cli import main
from promp.evaluate.compare import main as compare_main
from promp.evaluate.methods import TrialAnswer
from promp.evaluate.plots import display_unit, example
from promp.evaluate.report import confusion_matrices
from promp.evaluate.runs import RUN_FILE, compare_runs, read_run, write_run
from promp.evaluate.sweep import Trial
from tests.synthetic import make_dataset

ROWS = [
    {"primitive": p, "recognised": r, "observed": ["hand"], "alpha_method": "ml", "percent": pc}
    for p, r, pc in (("a", "a", 40), ("a", "b", 40), ("b", "", 40), ("b", "b", 80))
]


def test_confusion_matrices_count_every_trial_failed_ones_last() -> None:
    matrices = confusion_matrices(ROWS, ["a", "b"])
    assert [(m["percent"], m["alpha"]) for m in matrices] == [(40.0, "ml"), (80.0, "ml")]
    assert matrices[0]["counts"] == [[1, 1, 0], [0, 0, 1]]
    assert matrices[1]["counts"] == [[0, 0, 0], [0, 1, 0]]


def _report(errors: int, log_loss: float) -> dict:
    row = {"percent": 40.0, "alpha_method": "ml", "observed": ["hand"], "recognition_errors":
           errors, "trials": 10, "log_loss": log_loss, "position_error_m": 0.01,
           "duration_error_s": 0.2, "duration_coverage": 0.9, "goal_error_m": 0.02,
           "nrmse_prior": 0.3, "nrmse_posterior": 0.2, "confident_mistakes": 0,
           "worst_log_loss": 1.0, "failed": [], "method": "ours"}  # fmt: skip
    return {"results": [row], "trials": []}


def test_a_run_is_written_whole_into_a_new_folder_and_read_back(tmp_path: Path) -> None:
    def figures(folder: Path) -> None:
        folder.mkdir()
        (folder / "f.png").write_bytes(b"x")

    run = write_run(tmp_path / "runs" / "first", _report(3, 0.5), "before", figures=figures)
    assert run.name == "before" and run.code_version.startswith("0.")
    assert sorted(p.name for p in run.folder.iterdir()) == sorted(
        [RUN_FILE, "figures", "results.csv", "trials.csv"]
    )
    assert read_run(run.folder).report == run.report
    # nothing is ever written over: an existing folder (here holding a user's file) is refused
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="already exists"):
        write_run(taken, _report(3, 0.5), "x")
    assert [p.name for p in taken.iterdir()] == ["notes.txt"]
    assert not list(tmp_path.glob(".taken.*"))  # no staging left behind


def test_what_is_not_a_run_is_refused_with_the_reason(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="has no run.json"):
        read_run(tmp_path)
    (tmp_path / RUN_FILE).write_text("{not json")
    with pytest.raises(ValueError, match="cannot read as JSON"):
        read_run(tmp_path)
    (tmp_path / RUN_FILE).write_text(json.dumps({"format": "other"}))
    with pytest.raises(ValueError, match="not an evaluation run"):
        read_run(tmp_path)
    (tmp_path / RUN_FILE).write_text(
        json.dumps({"format": "icub-intention-studio/evaluation-run", "version": 99})
    )
    with pytest.raises(ValueError, match="version"):
        read_run(tmp_path)


def test_two_runs_compared_row_by_row(tmp_path: Path, capsys) -> None:
    a = write_run(tmp_path / "a", _report(5, 0.6), "a")
    b = write_run(tmp_path / "b", _report(3, 0.4), "b")
    (row,) = compare_runs(a, b)
    assert row["errors_a"] == 5 and row["errors_b"] == 3 and row["errors_diff"] == -2
    assert row["log_loss_diff"] == pytest.approx(-0.2)
    assert compare_main([str(a.folder), str(b.folder), "--csv", str(tmp_path / "c.csv")]) == 0
    assert "5->3" in capsys.readouterr().out
    with open(tmp_path / "c.csv", newline="") as handle:
        assert next(csv.DictReader(handle))["errors_diff"] == "-2.0"
    assert compare_main([str(a.folder), str(tmp_path)]) == 2


def test_runs_made_with_two_alpha_methods_compare_row_by_row(tmp_path: Path, capsys) -> None:
    """ML in one run, the model alpha in the other: each percentage's rows side by side (not
    two half-empty rows), named by both; a row without any twin stays alone."""
    ml = _report(5, 0.6)
    model = _report(7, 0.7)
    model["results"][0]["alpha_method"] = "model"
    extra = dict(model["results"][0], percent=80.0, observed=["head"])
    model["results"].append(extra)
    a = write_run(tmp_path / "a", ml, "ml")
    b = write_run(tmp_path / "b", model, "model")
    paired, alone = compare_runs(a, b)
    assert (paired["alpha"], paired["alpha_b"], paired["percent"]) == ("ml", "model", 40.0)
    assert paired["errors_a"] == 5 and paired["errors_b"] == 7 and paired["errors_diff"] == 2
    assert alone["observed_b"] == "head" and math.isnan(alone["errors_a"])
    assert compare_main([str(a.folder), str(b.folder)]) == 0
    assert "ml>model" in capsys.readouterr().out


def test_runs_of_several_methods_compare_method_by_method(tmp_path: Path, capsys) -> None:
    """A run of ours and dtw against a run of ours: ours beside ours, dtw's row alone (n/a in
    A); a run of dtw alone against a run of ours alone: the two rows side by side."""
    ours = _report(5, 0.6)
    both = _report(3, 0.4)
    both["results"].append(dict(both["results"][0], method="dtw", recognition_errors=8,
                                position_error_m=math.nan))  # fmt: skip
    a = write_run(tmp_path / "a", ours, "ours")
    b = write_run(tmp_path / "b", both, "both")
    same, alone = compare_runs(a, b)
    assert (same["method"], same["method_b"], same["errors_a"], same["errors_b"]) == (
        "ours", "ours", 5, 3
    )  # fmt: skip
    assert alone["method"] == "dtw" and math.isnan(alone["errors_a"]) and alone["errors_b"] == 8
    assert compare_main([str(a.folder), str(b.folder)]) == 0
    text = capsys.readouterr().out
    assert "dtw" in text and "n/a->8" in text and "n/a->n/a" in text
    dtw_only = _report(8, 0.9)
    dtw_only["results"][0]["method"] = "dtw"
    c = write_run(tmp_path / "c", dtw_only, "dtw")
    (paired,) = compare_runs(a, c)
    assert (paired["method"], paired["method_b"], paired["errors_diff"]) == ("ours", "dtw", 3)
    assert compare_main([str(a.folder), str(c.folder)]) == 0
    assert "ours>dtw" in capsys.readouterr().out


def test_the_command_line_keeps_a_run_and_refuses_an_existing_folder_at_once(
    tmp_path: Path, capsys
) -> None:
    write_csv_dataset(tmp_path / "data", make_dataset(seed=2, n_demos=4))
    args = [str(tmp_path / "data"), "--format", "csv", "--percent", "40", "--alpha", "ml",
            "--basis", "6", "--width", "1", "--noise-scale", "1.5", "--duration-temperature",
            "0.5", "--jobs", "1"]  # fmt: skip
    assert main([*args, "--run", str(tmp_path / "run"), "--run-name", "first try"]) == 0
    run = read_run(tmp_path / "run")
    assert run.name == "first try"
    assert {name: len(demos) for name, demos in run.report["used"].items()} == {
        "left": 4, "right": 4
    }
    assert run.report["confusion"][0]["counts"]
    assert {p.name for p in (run.folder / "figures").iterdir()} >= {"curves_ours.png"}
    capsys.readouterr()
    assert main([*args, "--run", str(tmp_path / "run")]) == 2
    assert "already exists" in capsys.readouterr().err


def test_an_example_of_many_dimensions_is_a_grid_in_the_studios_units(tmp_path: Path) -> None:
    hand = Modality("hand", ("x", "y", "z"), unit="m")
    head = Modality("head", ("roll", "pitch", "yaw"), unit="rad", kind="angle")
    emg = Modality("emg", tuple(f"e{i}" for i in range(8)), unit="V")
    layout = Layout((hand, head, emg))
    assert display_unit(hand) == (100.0, "cm")
    assert display_unit(head) == pytest.approx((180 / math.pi, "°"))
    assert display_unit(emg) == (1.0, "V")
    from promp.data import Demonstration

    t = np.linspace(0.0, 1.0, 50)
    demo = Demonstration(t, np.tile(t[:, None], (1, 14)), layout.columns, name="d")
    curve = np.tile(np.linspace(0, 1, 40)[:, None], (1, 14))
    inferred = TrialAnswer(0, np.array([1.0]), 1.0, 1.0, curve, 0 * curve + 0.1, curve,
                        0 * curve + 0.05, 0.9, 1.1)  # fmt: skip
    trial = Trial(0, "d", 40.0, "ml", ("hand",), inferred)
    path = tmp_path / "example.png"
    example(trial, {"p": [demo]}, layout, path)
    width, height = Image.open(path).size
    assert width <= 2000 and height <= 1400
