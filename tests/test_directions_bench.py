"""bench/directions.py, issue 37's experiment (docs/evaluation.md, "Directions (i) and (iii)
measured"): its harness is the evaluation's, and its mixture at bandwidth 1 is the ProMP."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

from promp.datasets import read_dataset, write_csv_dataset
from promp.evaluate.sweep import leave_one_out
from promp.model import Settings
from promp.quality import split_flagged
from tests.synthetic import make_dataset

BENCH = Path(__file__).resolve().parents[1] / "bench" / "directions.py"


def test_the_experiment_scores_as_the_evaluation_and_its_mixture_at_one_is_the_promp(
    tmp_path: Path,
) -> None:
    write_csv_dataset(tmp_path / "data", make_dataset(seed=2, n_demos=5, noise=0.02))
    done = subprocess.run(
        [sys.executable, str(BENCH), "--set", str(tmp_path / "data"), "--format", "csv",
         "--percent", "30", "60", "--variant", "promp", "mixture:1", "mixture:0.5", "ebip:1",
         "start:1", "start:0.5"],
        capture_output=True, text=True, timeout=300, check=True,
    )  # fmt: skip
    table = json.loads(done.stdout.strip().splitlines()[-1])["table"]
    read = read_dataset(tmp_path / "data", "csv")
    kept, left_out = split_flagged(read.dataset, read.findings)  # as the evaluation does
    assert left_out  # (this set has a flagged take: the harness must leave it out too)
    ours = leave_one_out(kept, read.layout, [30, 60], Settings(recognition="promp"),
                         alpha_methods=["ml"])  # fmt: skip
    for row in ours.rows:
        cell = table["promp"][str(int(row["percent"]))]
        assert cell["errors"] == row["recognition_errors"]
        assert math.isclose(cell["log_loss"], row["log_loss"], abs_tol=1e-8)
    for percent, cell in table["promp"].items():
        for one in ("mixture:1", "start:1"):
            same = table[one][percent]
            assert same["errors"] == cell["errors"]
            assert math.isclose(same["log_loss"], cell["log_loss"], abs_tol=1e-8)
            assert math.isclose(same["position_cm"], cell["position_cm"], abs_tol=1e-5)
    for variant in ("mixture:0.5", "ebip:1", "start:0.5"):  # scored, and differently from the ProMP
        cells = table[variant].values()
        assert all(math.isfinite(c["log_loss"]) and 0 <= c["errors"] <= 10 for c in cells)
    for variant in ("mixture:0.5", "start:0.5"):
        assert any(
            not math.isclose(table[variant][p]["log_loss"], table["promp"][p]["log_loss"],
                             abs_tol=1e-6)
            for p in table["promp"]
        )  # fmt: skip
