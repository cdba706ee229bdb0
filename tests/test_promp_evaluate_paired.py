"""The first method against each other one on the same trials (:mod:`promp.evaluate.paired`):
the discordant trials, McNemar's band and p, one family per pair of methods, and the command
line's table and JSON."""

from __future__ import annotations

import json
import random
from pathlib import Path

import numpy as np
import pytest

from promp.datasets import write_csv_dataset
from promp.evaluate.cli import main
from promp.evaluate.methods import TrialAnswer
from promp.evaluate.paired import compare_methods, count_band, mcnemar_p
from promp.evaluate.sweep import Trial
from tests.synthetic import make_dataset


def _trial(method: str, demo: str, right: bool | None, percent: float = 40.0) -> Trial:
    """A trial of primitive 0 recognised (``right``), mistaken, or failed (None)."""
    if right is None:
        return Trial(0, demo, percent, "ml", ("hand",), None, error="failed", method=method)
    p = np.array([0.9, 0.1]) if right else np.array([0.1, 0.9])
    answer = TrialAnswer(int(np.argmax(p)), p, 1.0, 1.0, *(np.zeros((2, 1)),) * 4)
    return Trial(0, demo, percent, "ml", ("hand",), answer, method=method)


def _trials(method: str, right: list[bool | None], percent: float = 40.0) -> list[Trial]:
    return [_trial(method, f"d{i}", r, percent) for i, r in enumerate(right)]


def test_only_the_discordant_trials_count_and_mcnemars_p_is_exact() -> None:
    """ours right on 8 trials dtw gets wrong, never the reverse, both wrong on 3: the
    difference is -8, McNemar's p = 2 / 2^8, and the band excludes 0 (one row: 95 %)."""
    ours = _trials("ours", [True] * 8 + [False] * 3 + [True] * 9)
    dtw = _trials("dtw", [False] * 8 + [False] * 3 + [True] * 9)
    (c,) = compare_methods(ours + dtw)
    assert (c["method"], c["against"], c["trials"]) == ("ours", "dtw", 20)
    assert (c["errors"], c["errors_against"], c["worse"], c["better"]) == (3, 11, 0, 8)
    assert c["p_value"] == pytest.approx(2 / 2**8) and c["confidence"] == pytest.approx(0.95)
    assert c["difference_interval"][0] == -8 and c["difference_interval"][1] < 0
    assert c["verdict"] == "fewer"
    (back,) = compare_methods(dtw + ours)  # the first named is the reference
    assert (back["method"], back["verdict"], back["worse"], back["better"]) == ("dtw", "more",
                                                                                 8, 0)


def test_a_gap_within_the_noise_is_level() -> None:
    """55 against 54 errors, 24 and 23 trials each way (heights at 20 % against DTW): level,
    p = 1."""
    ours = _trials("ours", [False] * 24 + [True] * 23 + [False] * 31 + [True] * 44)
    dtw = _trials("dtw", [True] * 24 + [False] * 23 + [False] * 31 + [True] * 44)
    (c,) = compare_methods(ours + dtw)
    assert (c["errors"], c["errors_against"], c["worse"], c["better"]) == (55, 54, 24, 23)
    assert c["verdict"] == "level" and c["p_value"] == pytest.approx(1.0)
    low, high = c["difference_interval"]
    assert low < 0 < high


def test_each_pair_of_methods_is_one_family_of_rows() -> None:
    """0 against 6 discordant trials excludes 0 at 95 % (one row) but not at 97.5 % (two rows
    of the same pair): the band widens with the rows compared, not with the methods."""
    right = [True] * 6 + [True] * 4
    wrong = [False] * 6 + [True] * 4
    one = compare_methods(_trials("ours", right) + _trials("dtw", wrong))
    assert [c["verdict"] for c in one] == ["fewer"]
    two = compare_methods(_trials("ours", right) + _trials("ours", right, 60.0)
                          + _trials("dtw", wrong) + _trials("dtw", wrong, 60.0))  # fmt: skip
    assert [c["verdict"] for c in two] == ["level", "level"]
    assert all(c["confidence"] == pytest.approx(0.975) for c in two)
    three = compare_methods(_trials("ours", right) + _trials("dtw", wrong)
                            + _trials("seed", wrong))  # fmt: skip
    assert [(c["against"], c["verdict"]) for c in three] == [("dtw", "fewer"), ("seed", "fewer")]


def test_trials_are_paired_by_demonstration_not_by_order() -> None:
    """The other method's trials shuffled, a trial each method alone holds (ignored), a trial
    the first method failed on (wrong)."""
    ours = _trials("ours", [None, True, True, False, True]) + [_trial("ours", "own", False)]
    dtw = _trials("dtw", [True, True, False, True, False]) + [_trial("dtw", "extra", True)]
    random.Random(0).shuffle(dtw)
    (c,) = compare_methods(ours + dtw)
    assert (c["trials"], c["errors"], c["errors_against"]) == (5, 2, 2)
    assert (c["worse"], c["better"]) == (2, 2)
    assert compare_methods(ours) == []


def test_the_band_and_p_at_their_edges() -> None:
    assert count_band(0, 0, 0.95) == (0.0, 0.0) and mcnemar_p(0, 0) == 1.0
    low, high = count_band(6, 0, 0.95)  # p = 2 / 64 < 0.05: excludes 0
    assert high == 6 and 0 < low < 6
    low, high = count_band(5, 0, 0.95)  # p = 2 / 32 > 0.05: holds it
    assert high == 5 and low < 0
    assert mcnemar_p(5, 0) == pytest.approx(2 / 32) and mcnemar_p(0, 5) == mcnemar_p(5, 0)


def test_the_command_line_prints_and_writes_the_paired_comparison(tmp_path: Path,
                                                                  capsys) -> None:  # fmt: skip
    write_csv_dataset(tmp_path / "set", make_dataset(seed=4, n_demos=5))
    out = tmp_path / "r.json"
    argv = [str(tmp_path / "set"), "--format", "csv", "--percent", "30", "60", "--alpha", "ml",
            "--method", "ours", "dtw", "prefix-nn", "--basis", "7", "--width", "1",
            "--noise-scale", "1.5", "--recognition", "promp", "--jobs", "1", "--json", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "ours against each other method, on the same trials" in printed
    report = json.loads(out.read_text())
    paired = report["paired"]
    assert [(c["against"], c["percent"]) for c in paired] == [
        ("dtw", 30.0), ("dtw", 60.0), ("prefix-nn", 30.0), ("prefix-nn", 60.0)]
    errors = {(r["method"], r["percent"]): r["recognition_errors"] for r in report["results"]}
    for c in paired:
        assert c["errors"] == errors[("ours", c["percent"])]
        assert c["errors_against"] == errors[(c["against"], c["percent"])]
        assert c["trials"] == 10 and c["confidence"] == pytest.approx(1 - 0.05 / 2)
    assert main([*argv[:10], "--basis", "7", "--width", "1", "--noise-scale", "1.5",
                 "--recognition", "promp", "--jobs", "1"]) == 0  # fmt: skip
    assert "on the same trials" not in capsys.readouterr().out  # one method: nothing paired
