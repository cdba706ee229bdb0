"""The evaluation that holds out a whole group (a subject, a session) at a time beside
leave-one-out (:mod:`promp.evaluate.groups`, :mod:`promp.evaluate.group_gap`,
:mod:`promp.evaluate.grouped`, ``python -m promp.evaluate --group-by``)."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

from promp.data import Demonstration
from promp.datasets import read_dataset, write_csv_dataset
from promp.evaluate.cli import main
from promp.evaluate.group_gap import compare_protocols
from promp.evaluate.grouped import plan_groups, run_grouped
from promp.evaluate.groups import group_of, group_pairs, parse_group_by
from promp.evaluate.methods import ProMPEngine, TrialAnswer
from promp.evaluate.registry import method_factories
from promp.evaluate.report import CSV_COLUMNS
from promp.evaluate.sweep import SweepResult, Trial, run_sweep
from promp.model import Settings
from tests.conftest import shared_set
from tests.synthetic import HANDOVER_LAYOUT, LAYOUT, handover_sessions, make_dataset

GIVEN = Settings(n_basis=7, width=1.0, noise_scale=1.5, recognition="promp")  # the grouping
# is the subject: quick (nothing chosen but the duration's temperature)


def in_sessions(dataset: dict, sessions: int) -> dict:
    """``dataset`` with its demonstrations dealt into ``session<i>/`` folders."""
    return {
        name: [Demonstration(d.times, d.values, d.columns, f"session{j % sessions}/{d.name}")
               for j, d in enumerate(demos)]
        for name, demos in dataset.items()
    }  # fmt: skip


def test_the_group_of_a_demonstration_is_read_from_its_path() -> None:
    folder, second, pattern = (parse_group_by(t) for t in ("folder", "2", r"S(\d+)_"))
    assert group_of("person1/record0", folder) == "person1"
    assert group_of("trajF/day2/record3", second) == "day2"
    assert group_of("S03_trial2", pattern) == "03"
    assert folder.describe() == "grouped by folder"
    with pytest.raises(ValueError, match="no folder below its class folder"):
        group_of("record0", folder)
    with pytest.raises(ValueError, match="1 folder level"):
        group_of("trajF/record0", second)
    with pytest.raises(ValueError, match="does not match"):
        group_of("trial2", pattern)
    for bad, why in (("0", "1 or more"), ("(a)(b)", "2 groups"), ("abc", "0 groups"),
                     ("(", "not a regular expression"), (" ", "give 'folder'")):  # fmt: skip
        with pytest.raises(ValueError, match=why):
            parse_group_by(bad)


def test_a_group_spans_the_classes_it_is_named_in() -> None:
    """``top/person2`` and ``bottom/person2`` are one subject; the groups in natural order;
    one group alone is refused."""
    data = in_sessions(make_dataset(seed=1, n_demos=6), 3)
    groups = group_pairs(data, parse_group_by("folder"))
    assert list(groups) == ["session0", "session1", "session2"]
    assert groups["session1"] == [(0, 1), (0, 4), (1, 1), (1, 4)]
    with pytest.raises(ValueError, match="one group, 'session0'"):
        group_pairs(in_sessions(make_dataset(seed=1, n_demos=3), 1), parse_group_by("folder"))
    with pytest.raises(ValueError, match="left/left0: no folder"):
        group_pairs(make_dataset(seed=1, n_demos=3), parse_group_by("folder"))


class Spy(ProMPEngine):
    """The engine, recording what every fit learned from."""

    seen: list = []

    def fit(self, dataset, sample_period, chosen=None) -> None:
        Spy.seen.append({f"{k}/{d.name}" for k, demos in dataset.items() for d in demos})
        super().fit(dataset, sample_period, chosen)


def test_a_grouped_sweep_holds_out_a_whole_group_and_tests_each_of_it_once() -> None:
    data = in_sessions(make_dataset(seed=2, n_demos=6), 3)
    groups = group_pairs(data, parse_group_by("folder"))
    Spy.seen = []
    result = run_sweep(lambda: Spy(LAYOUT, GIVEN), data, LAYOUT, [50], ["ml"], [["hand"]], "spy",
                       keep_trials=True, groups=groups)  # fmt: skip
    everyone = {f"{k}/{d.name}" for k, demos in data.items() for d in demos}
    assert [everyone - seen for seen in Spy.seen] == [
        {n for n in everyone if f"/{g}/" in n} for g in groups
    ]
    assert sorted(f"{t.primitive}/{t.demo}" for t in result.trials) == sorted(
        f"{k}/{d.name}" for k, demos in enumerate(data.values()) for d in demos
    )
    # a subset: the same folds, only its demonstrations tested
    subset = [(0, 0), (1, 5)]
    Spy.seen = []
    some = run_sweep(lambda: Spy(LAYOUT, GIVEN), data, LAYOUT, [50], ["ml"], [["hand"]], "spy",
                     keep_trials=True, groups=groups, held_out=subset)  # fmt: skip
    assert len(Spy.seen) == 2 and some.rows[0]["trials"] == 2


def test_a_grouping_that_leaves_a_class_nothing_to_learn_from_is_refused() -> None:
    data = make_dataset(seed=3, n_demos=4)
    data = {
        "left": [Demonstration(d.times, d.values, d.columns, f"alone/{d.name}")
                 for d in data["left"]],
        "right": in_sessions({"right": data["right"]}, 2)["right"],
    }  # fmt: skip
    rule = parse_group_by("folder")
    with pytest.raises(ValueError, match="group 'alone' leaves 'left' 0 demonstration"):
        plan_groups(data, rule)


def _trial(k: int, demo: str, right: bool) -> Trial:
    p = np.array([0.9, 0.1]) if right == (k == 0) else np.array([0.1, 0.9])
    answer = TrialAnswer(int(np.argmax(p)), p, 1.0, 1.0, *(np.zeros((2, 1)),) * 4)
    return Trial(k, demo, 40.0, "ml", ("hand",), answer, method="ours")


def _result(right: list[bool]) -> SweepResult:
    return SweepResult(trials=[_trial(i % 2, f"d{i}", r) for i, r in enumerate(right)])


def test_the_noise_band_is_mcnemars_on_the_paired_trials() -> None:
    """Eight trials right in leave-one-out and wrong grouped, none the other way: McNemar's
    exact p = 2 / 2^8, and the band excludes 0 (one row: 95 %); three against two: no."""
    loo = _result([True] * 20)
    grouped = _result([False] * 8 + [True] * 12)
    (c,) = compare_protocols(loo, grouped, 2)
    assert (c["worse"], c["better"], c["errors_grouped"], c["errors_leave_one_out"]) == (8, 0, 8, 0)
    assert c["p_value"] == pytest.approx(2 / 2**8) and c["differs"]
    assert 0 < c["difference_interval"][0] < 8 and c["difference_interval"][1] == 8
    assert c["log_loss_difference"] == pytest.approx(8 / 20 * (math.log(0.9) - math.log(0.1)))
    mixed = _result([False, False, False, True, True] + [True] * 15)
    back = _result([True, True, True, False, False] + [True] * 15)
    (c,) = compare_protocols(back, mixed, 2)
    assert (c["worse"], c["better"]) == (3, 2) and not c["differs"]
    assert c["p_value"] == pytest.approx(1.0)


def _grouped(session_effect: bool):
    data = handover_sessions(seed=0, session_effect=session_effect)
    methods = method_factories(["ours"], HANDOVER_LAYOUT, GIVEN)
    observe = [["hand", "emg"]]
    loo = run_sweep(methods, data, HANDOVER_LAYOUT, [40], ["ml"], observe, keep_trials=True,
                    jobs=2)  # fmt: skip
    rule = parse_group_by("folder")
    return run_grouped(methods, data, HANDOVER_LAYOUT, loo, rule, plan_groups(data, rule),
                       percents=[40], alpha_methods=["ml"], observe_sets=observe, jobs=2)


@pytest.mark.slow
def test_the_warning_fires_on_session_baselines_and_names_the_emg() -> None:
    """A handover study recorded in blocks, a session's EMG baseline its own: leave-one-out
    finds the held-out take's session-mates and recognises it; a new session does not. The
    warning says so and names the EMG (observed alone it makes the gap; the hand does not)."""
    run = _grouped(session_effect=True)
    (c,) = run.comparisons
    assert c["differs"] and c["errors_grouped"] > c["errors_leave_one_out"]
    (driver,) = run.drivers.values()
    assert driver["modality"] == "emg" and driver["by_modality"]["emg"]["differs"]
    assert not driver["by_modality"]["hand"]["differs"]
    (warning,) = run.warnings
    assert "Driven by emg" in warning and "flatters" in warning


@pytest.mark.slow
def test_no_warning_without_a_session_effect() -> None:
    run = _grouped(session_effect=False)
    assert not any(c["differs"] for c in run.comparisons)
    assert run.warnings == [] and run.single == []  # no modality compared: nothing to explain


def test_the_command_line_reports_both_protocols(tmp_path: Path, capsys) -> None:
    data = in_sessions(make_dataset(seed=4, n_demos=6), 3)
    write_csv_dataset(tmp_path / "set", data)
    out = tmp_path / "out"
    argv = [str(tmp_path / "set"), "--format", "csv", "--percent", "50", "--alpha", "ml",
            "--method", "ours", "dtw", "--basis", "7", "--width", "1", "--noise-scale", "1.5",
            "--jobs", "1", "--json", str(out / "r.json"), "--csv", str(out / "r.csv"),
            "--trials-csv", str(out / "t.csv")]  # fmt: skip
    assert main([*argv, "--group-by", "folder"]) == 0
    printed = capsys.readouterr().out
    assert "grouped by folder: 3 groups (session0, session1, session2)" in printed
    assert "leave-one-out against grouped by folder" in printed
    report = json.loads((out / "r.json").read_text())
    grouped = report["grouped"]
    assert report["settings"]["group_by"] == "folder" and grouped["protocol"] == "grouped by folder"
    assert {r["method"] for r in grouped["results"]} == {"ours", "dtw"}
    assert len(grouped["comparisons"]) == 2 and len(grouped["trials"]) == len(report["trials"])
    assert grouped["groups"]["session0"][0] == "left/session0/left0"
    table = list(csv.DictReader(io.StringIO((out / "r.csv").read_text())))
    assert list(table[0]) == list(CSV_COLUMNS)
    assert [r["protocol"] for r in table] == ["leave-one-out"] * 2 + ["grouped by folder"] * 2
    trials = list(csv.DictReader(io.StringIO((out / "t.csv").read_text())))
    assert {t["group"] for t in trials} == {"session0", "session1", "session2"}
    # refused before any sweep, with the reason
    assert main([*argv, "--group-by", "2"]) == 2
    assert "no group at level 2" in capsys.readouterr().err


@pytest.mark.parametrize("name, groups", [
    ("lab-records-heights", ["person1", "person2", "person3", "person4"]),
    ("lab-records-flt", ["trajF", "trajF2", "trajG1", "trajG2", "trajH1", "trajT2"]),
])  # fmt: skip
def test_the_shared_sets_group_by_their_folders(name: str, groups: list[str]) -> None:
    dataset = read_dataset(shared_set(name), "records").dataset
    assert list(plan_groups(dataset, parse_group_by("folder"))) == groups


def test_a_set_without_folders_below_its_classes_is_refused_clearly() -> None:
    dataset = read_dataset(shared_set("lab-records-flt-shapes"), "records").dataset
    with pytest.raises(ValueError, match="trajF/record0: no folder below its class folder"):
        plan_groups(dataset, parse_group_by("folder"))
