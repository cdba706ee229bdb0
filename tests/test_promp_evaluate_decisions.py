"""``--decide``: when each method would act, judged as early classification is (accuracy,
earliness, their harmonic mean at a threshold chosen without the trial under test)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from promp.datasets import write_csv_dataset
from promp.evaluate.cli import main
from promp.evaluate.decisions import (
    DECISION_COLUMNS,
    candidate_thresholds,
    decide,
    harmonic_mean,
    nested_choice,
    outcomes,
)
from promp.evaluate.methods import ProMPEngine
from promp.evaluate.paths import DECISION_PERCENTS, ProbabilityPath
from promp.evaluate.registry import method_factories
from promp.evaluate.runs import compare_decisions, comparison_text, read_run
from promp.evaluate.sweep import run_sweep
from promp.model import Settings
from tests.synthetic import LAYOUT, make_dataset

PERCENTS = np.array(DECISION_PERCENTS)


def path(primitive: int, probabilities, demo: str = "d", method: str = "m") -> ProbabilityPath:
    """A trial of a 1 s movement observed every 2 %."""
    p = np.asarray(probabilities, dtype=float)
    return ProbabilityPath(method, primitive, demo, "ml", ("hand",), PERCENTS[: len(p)],
                           PERCENTS[: len(p)] / 100.0, p)  # fmt: skip


def rising(primitive: int, towards: int, at: int, n_primitives: int = 2, top: float = 0.95):
    """Uniform until step ``at``, then ``towards`` at ``top``: (50, n_primitives)."""
    p = np.full((50, n_primitives), 1.0 / n_primitives)
    p[at:] = (1.0 - top) / (n_primitives - 1)
    p[at:, towards] = top
    return path(primitive, p, demo=f"{primitive}-{towards}-{at}")


def test_accuracy_earliness_and_their_harmonic_mean_with_known_answers() -> None:
    """Three trials at one threshold: right at 20 % observed, wrong at 40 %, and one that never
    commits (wrong, earliness 1)."""
    paths = [rising(0, 0, 9), rising(1, 0, 19), path(1, np.full((50, 2), 0.5))]
    result = outcomes(paths, np.array([0.9]), window=0.0)
    assert result.committed.tolist() == [[True, True, False]]
    assert result.correct.tolist() == [[True, False, False]]
    np.testing.assert_allclose(result.earliness, [[0.2, 0.4, 1.0]])
    np.testing.assert_allclose(result.percent[0, :2], [20.0, 40.0])
    accuracy, earliness = 1 / 3, (0.2 + 0.4 + 1.0) / 3
    expected = 2 * accuracy * (1 - earliness) / (accuracy + 1 - earliness)
    assert float(harmonic_mean(accuracy, earliness)) == pytest.approx(expected)
    assert float(harmonic_mean(0.0, 1.0)) == 0.0
    # A window of 0.1 s (5 steps of this 1 s movement) moves each commitment 5 steps later.
    later = outcomes(paths, np.array([0.9]), window=0.1)
    np.testing.assert_allclose(later.earliness, [[0.3, 0.5, 1.0]])


def random_paths(rng: np.random.Generator, n: int, n_primitives: int = 3) -> list:
    """Trials whose probabilities wander towards their truth (or another primitive) at random
    speeds: a spread of commitments, right and wrong, early and late."""
    out = []
    for i in range(n):
        truth = int(rng.integers(n_primitives))
        lead = truth if rng.random() < 0.7 else int(rng.integers(n_primitives))
        logits = np.cumsum(rng.normal(0.0, 0.6, (50, n_primitives)), axis=0)
        logits[:, lead] += np.linspace(0.0, rng.uniform(1.0, 12.0), 50)
        p = np.exp(logits - logits.max(axis=1, keepdims=True))
        out.append(path(truth, p / p.sum(axis=1, keepdims=True), demo=f"t{i}"))
    return out


def test_the_nested_threshold_never_sees_the_held_out_trial() -> None:
    """Each trial's threshold is the best over the *other* trials: it is what choosing on the
    others alone gives (in-sample on them, the same tie rule), and it does not move however the
    trial's own probabilities change, while the others' do move it."""
    rng = np.random.default_rng(3)
    paths = random_paths(rng, 16)
    thresholds = candidate_thresholds(3)
    chosen = nested_choice(outcomes(paths, thresholds, 0.06))
    assert len(set(chosen.tolist())) > 1  # the choice depends on which trial is out
    for i in range(len(paths)):
        others = outcomes(paths[:i] + paths[i + 1 :], thresholds, 0.06)
        score = harmonic_mean(others.correct.mean(axis=1), others.earliness.mean(axis=1))
        tied = np.flatnonzero(score >= score.max() - 1e-12)
        assert chosen[i] == tied[(tied.size - 1) // 2]
        for replacement in random_paths(rng, 3):  # any other probabilities for trial i
            changed = paths[:i] + [replacement] + paths[i + 1 :]
            assert nested_choice(outcomes(changed, thresholds, 0.06))[i] == chosen[i]
    # The order of the trials changes nothing.
    order = rng.permutation(len(paths))
    shuffled = nested_choice(outcomes([paths[j] for j in order], thresholds, 0.06))
    assert shuffled.tolist() == chosen[order].tolist()
    with pytest.raises(ValueError, match="two trials"):
        nested_choice(outcomes(paths[:1], thresholds, 0.06))


def test_decide_gives_one_row_per_method_the_in_sample_curve_and_every_trials_decision() -> None:
    rng = np.random.default_rng(5)
    paths = random_paths(rng, 10)
    paths += [ProbabilityPath("other", p.primitive, p.demo, "ml", ("hand",), p.percents,
                              p.times, p.probabilities[:, ::-1]) for p in paths]  # fmt: skip
    decisions = decide(paths, ["a", "b", "c"], window=0.04)
    assert [r["method"] for r in decisions.rows] == ["m", "other"]
    for row in decisions.rows:
        assert {"method", "observed", "alpha_method", "threshold", "earliness", "accuracy",
                "harmonic_mean", "never_committed", "trials", "window_s"} <= set(row)  # fmt: skip
        assert row["trials"] == 10 and row["window_s"] == 0.04
        assert row["selection"] == "held-out"
        assert row["threshold_low"] <= row["threshold"] <= row["threshold_high"]
        mine = [t for t in decisions.trials if t["method"] == row["method"]]
        assert row["accuracy"] == pytest.approx(np.mean([t["correct"] for t in mine]))
        never = [t["committed"] == "" for t in mine]
        assert row["never_committed"] == pytest.approx(np.mean(never))
        earliness = [1.0 if t["committed"] == "" else t["percent"] / 100 for t in mine]
        assert row["earliness"] == pytest.approx(np.mean(earliness))
        assert row["harmonic_mean"] == pytest.approx(
            float(harmonic_mean(row["accuracy"], row["earliness"])))  # fmt: skip
    assert len(decisions.curve) == 2 * len(candidate_thresholds(3))
    assert {c["selection"] for c in decisions.curve} == {"in-sample"}


class Counted(ProMPEngine):
    fits = 0

    def fit(self, dataset, sample_period, chosen=None):
        Counted.fits += 1
        super().fit(dataset, sample_period, chosen)


def test_a_fold_is_fitted_once_and_its_paths_are_the_methods_own_answers() -> None:
    """With --decide every fold still fits each method once; every step of a path is what the
    method's ``infer`` says at that share (ours and the toolbox recognise without predicting,
    the baselines are asked ``infer``)."""
    dataset = make_dataset(seed=6, n_demos=3)
    factories = method_factories(["seed", "dtw"], LAYOUT)
    factories = {"ours": lambda: Counted(LAYOUT, Settings(n_basis=6)), **factories}
    Counted.fits = 0
    result = run_sweep(factories, dataset, LAYOUT, [20, 40], ["ml"], [["hand"]], jobs=1,
                       keep_trials=True, decide_percents=DECISION_PERCENTS)  # fmt: skip
    assert Counted.fits == 6  # one per fold
    assert len(result.paths) == 3 * 6
    for trial in result.trials:
        (p,) = [p for p in result.paths if (p.method, p.primitive, p.demo) ==
                (trial.method, trial.primitive, trial.demo)]  # fmt: skip
        step = int(np.flatnonzero(p.percents == trial.percent)[0])
        np.testing.assert_array_equal(p.probabilities[step], trial.inferred.probabilities)
    demo = dataset["left"][0]
    (p,) = [p for p in result.paths if p.method == "ours" and p.demo == demo.name
            and p.primitive == 0]  # fmt: skip
    assert p.times[-1] == pytest.approx(demo.duration)
    assert np.all(np.isfinite(p.probabilities))
    with pytest.raises(ValueError, match="decide_percents"):
        run_sweep(factories, dataset, LAYOUT, [20], ["ml"], [["hand"]],
                  decide_percents=[40, 20])  # fmt: skip


def test_the_command_line_writes_the_decisions_beside_the_fixed_share_table(
    tmp_path: Path, capsys
) -> None:
    write_csv_dataset(tmp_path / "data", make_dataset(seed=2, n_demos=4))
    common = [str(tmp_path / "data"), "--format", "csv", "--percent", "40", "--alpha", "ml",
              "--method", "ours", "dtw", "--basis", "6", "--jobs", "1"]  # fmt: skip
    out, table = tmp_path / "out.json", tmp_path / "decisions.csv"
    code = main([*common, "--observe", "hand", "--observe", "head", "--decide",
                 "--decide-window", "0.05", "--json", str(out), "--decisions-csv", str(table),
                 "--plots", str(tmp_path / "plots"), "--run", str(tmp_path / "run")])  # fmt: skip
    assert code == 0
    printed = capsys.readouterr().out
    assert "when the robot acts" in printed and "harmonic mean" in printed
    report = json.loads(out.read_text())
    rows = report["decisions"]
    assert [(r["method"], r["observed"]) for r in rows] == [
        ("ours", ["hand"]), ("ours", ["head"]), ("dtw", ["hand"]), ("dtw", ["head"])]  # fmt: skip
    for row in rows:
        assert {"method", "threshold", "earliness", "accuracy", "harmonic_mean",
                "never_committed"} <= set(row)  # fmt: skip
        assert row["trials"] == 8 and 0.0 <= row["harmonic_mean"] <= 1.0
    assert report["settings"]["decide"] == {"window_s": 0.05, "percents": list(PERCENTS)}
    assert len(report["decision_trials"]) == 4 * 8
    assert {c["selection"] for c in report["decision_curve"]} == {"in-sample"}
    lines = list(csv.DictReader(table.open(newline="")))
    assert list(lines[0]) == list(DECISION_COLUMNS)
    held_out = [line for line in lines if line["selection"] == "held-out"]
    assert len(held_out) == 4 and len(lines) == 4 + len(report["decision_curve"])
    for line, row in zip(held_out, rows, strict=True):
        assert line["method"] == row["method"] and line["observed"] == "+".join(row["observed"])
        assert float(line["harmonic_mean"]) == pytest.approx(row["harmonic_mean"])
        assert float(line["never_committed"]) == pytest.approx(row["never_committed"])
    assert (tmp_path / "plots" / "decisions_ours+dtw.png").stat().st_size > 0
    run = read_run(tmp_path / "run")
    assert (tmp_path / "run" / "decisions.csv").read_text() == table.read_text()
    assert (tmp_path / "run" / "figures" / "decisions_ours+dtw.png").exists()
    compared = compare_decisions(run, run)
    assert [r["harmonic_mean_diff"] for r in compared] == [0.0] * 4
    assert "when the robot acts" in comparison_text(run, run, [])
    # Without --decide: nothing of it, and --decisions-csv alone is refused.
    assert main([*common, "--json", str(out)]) == 0
    assert "decisions" not in json.loads(out.read_text())
    assert main([*common, "--decisions-csv", str(table)]) == 2
    assert "--decisions-csv needs --decide" in capsys.readouterr().err
