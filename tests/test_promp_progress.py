"""Progress a person can plan around (issue 28): done / total, elapsed, and the time left at
the pace so far, one pure function for the studio and the command line."""

from __future__ import annotations

import io

import pytest

from promp.progress import clock, progress_text, stderr_progress, time_left


def test_time_left_is_the_average_pace_times_what_is_left() -> None:
    assert time_left(10, 40, 35.0) == pytest.approx(105.0)
    assert time_left(1, 3, 2.0) == pytest.approx(4.0)
    assert time_left(0, 40, 12.0) is None  # nothing done: nothing to go by
    assert time_left(40, 40, 90.0) == 0.0
    assert time_left(0, 0, 0.0) == 0.0  # nothing to do is done
    for bad in ((41, 40, 1.0), (-1, 40, 1.0), (1, 40, -1.0), (1, 40, float("nan"))):
        with pytest.raises(ValueError):
            time_left(*bad)


def test_clock_and_text() -> None:
    assert [clock(s) for s in (0, 0.2, 35, 70, 725, 3723)] == [
        "0:00", "0:01", "0:35", "1:10", "12:05", "1:02:03"
    ]  # fmt: skip
    assert (
        progress_text(12, 40, 15.0, "trials") == "12 / 40 trials · 0:15 elapsed · about 0:35 left"
    )
    assert progress_text(0, 40, 3.0) == "0 / 40 · 0:03 elapsed · estimating the time left"
    assert progress_text(40, 40, 65.0, "trials") == "40 / 40 trials · 1:05 elapsed"


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_the_command_line_printer() -> None:
    log = io.StringIO()  # a log file: a line at most every 2 s, and the last one
    report = stderr_progress("ours: leave-one-out", "folds", stream=log)
    for done in range(1, 6):
        report(done, 5)
    lines = log.getvalue().splitlines()
    assert lines[0].startswith("ours: leave-one-out: 1 / 5 folds · 0:0")
    assert "about" in lines[0] and lines[-1].startswith("ours: leave-one-out: 5 / 5 folds · ")
    assert len(lines) == 2
    terminal = Terminal()  # a terminal: one line, rewritten in place
    report = stderr_progress("fit", stream=terminal)
    report(1, 2)
    report(2, 2)
    assert terminal.getvalue().count("\r") == 2 and terminal.getvalue().endswith("\n")


def test_python_m_promp_evaluate_prints_its_progress_on_stderr(tmp_path, capsys) -> None:
    from promp.datasets import write_csv_dataset
    from promp.evaluate.cli import main
    from tests.synthetic import make_dataset

    write_csv_dataset(tmp_path / "data", make_dataset(seed=2, n_demos=3))
    argv = [str(tmp_path / "data"), "--format", "csv", "--modality", "hand=x,y,z",
            "--basis", "7", "--width", "1", "--noise-scale", "1.5", "--alpha", "ml",
            "--percent", "50", "--jobs", "1"]  # fmt: skip
    assert main(argv) == 0
    err = capsys.readouterr().err.splitlines()
    # the duration's temperature is left to the data: chosen once per block, said first
    choosing = [line for line in err if "choosing the settings" in line]
    assert choosing[0].startswith("ours: choosing the settings: 0 / 6 blocks · 0:0")
    assert choosing[-1].startswith("ours: choosing the settings: 6 / 6 blocks · ")
    assert err.index(choosing[-1]) < min(k for k, line in enumerate(err) if "leave-one" in line)
    lines = [line for line in err if "leave-one-out" in line]
    assert lines[0].startswith("ours: leave-one-out: 1 / 6 held-out demonstrations · 0:0")
    assert " elapsed · about " in lines[0] and lines[0].endswith(" left")
    assert lines[-1].startswith("ours: leave-one-out: 6 / 6 held-out demonstrations · ")


def test_the_refit_says_how_long_it_has_run_and_the_last_fit_is_the_estimate() -> None:
    from types import SimpleNamespace

    from app.panels.teach.learn import fit_text, refit_clock

    assert refit_clock(None, 3.0) == ""
    assert refit_clock(5.0, 0.0) == " 0:05 elapsed"
    assert refit_clock(5.0, 8.0) == " 0:05 elapsed · about 0:03 left (as long as the last fit)"
    assert refit_clock(9.0, 8.0) == " 0:09 elapsed · longer than the last fit (0:08)"
    store = SimpleNamespace(left_out={}, learned={"a": [1, 2, 3], "b": [4, 5]})
    learner = SimpleNamespace(error=None, fit_ms=0.0)
    snapshot = SimpleNamespace(store=store, learner=learner, model=None, refitting=True)
    text = fit_text(snapshot, 12.0)
    assert "Learning again from 5 demonstrations..." in text and "0:12 elapsed" in text


def test_importing_a_dataset_on_the_command_line_says_its_stages(tmp_path, capsys) -> None:
    """``python -m app --import-dataset``: reading and checking, writing, fitting, each with
    its counts, as it goes (the serving line is tests/test_foundation.py's)."""
    from app.cli import build_parser, prepare_workspace, report_first_fit
    from app.core.session import Session
    from promp.datasets import write_csv_dataset
    from tests.conftest import FITS
    from tests.synthetic import make_dataset

    write_csv_dataset(tmp_path / "data", make_dataset(seed=4, n_demos=3))
    argv = ["--workspace", str(tmp_path / "ws"), "--import-dataset", str(tmp_path / "data")]
    prepare_workspace(build_parser().parse_args(argv))
    session = Session.open(tmp_path / "ws", fits=FITS)
    try:
        report_first_fit(session)
    finally:
        session.close()
    out = capsys.readouterr().out
    assert f"Reading {tmp_path / 'data'} (csv, 6 files) and checking" in out
    assert "Read and checked 6 demonstrations of 2 classes in 0:0" in out
    assert f"Writing the workspace {tmp_path / 'ws'} (6 demonstrations)..." in out
    assert "Fitting the model of 2 primitives to 6 demonstrations..." in out
    assert "Fitted in 0:" in out and ": 2 primitives from 6 demonstrations." in out
    stages = ["Reading", "Read and", "Writing", "Created the workspace", "Fitting", "Fitted"]
    positions = [out.index(s) for s in stages]
    assert positions == sorted(positions)


def test_a_stopped_sweep_keeps_the_folds_done_and_says_it_is_partial() -> None:
    from promp.evaluate.methods import ProMPEngine
    from promp.evaluate.sweep import run_sweep
    from promp.model import Settings
    from tests.synthetic import LAYOUT, make_dataset

    dataset = make_dataset(seed=5, n_demos=3)
    settings = Settings(n_basis=7, width=1.0, noise_scale=1.5)
    seen: list[int] = []
    result = run_sweep(
        lambda: ProMPEngine(LAYOUT, settings), dataset, LAYOUT, [50.0], ["ml"], [["hand"]],
        "ours", progress=lambda done, total: seen.append(done), keep_trials=True,
        stop=lambda: len(seen) >= 1,
    )  # fmt: skip
    assert result.partial
    assert {(t.primitive, t.demo) for t in result.trials} == {(0, "left0"), (0, "left1")}
    assert [row["trials"] for row in result.rows] == [2]
    whole = run_sweep(lambda: ProMPEngine(LAYOUT, settings), dataset, LAYOUT, [50.0], ["ml"],
                      [["hand"]], "ours", stop=lambda: False)  # fmt: skip
    assert not whole.partial and whole.rows[0]["trials"] == 6
