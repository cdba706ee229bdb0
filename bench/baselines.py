"""What the early-classification baselines (``--method dtw prefix-nn``) cost, beside ours.

One run, this machine:

1. **The goal**: ``python -m promp.evaluate`` (through its ``main``) with ``--method dtw
   prefix-nn`` on a synthetic set of 70 demonstrations of 15 columns (5 primitives x 14, five
   modalities of 3 columns: a hand in m, a head in rad, a force in N, a moment in N m, a gaze in
   rad; 100 Hz, 1.4 to 2.6 s), every modality observed, ML, the default percentages (10 ... 90),
   every core: 70 folds x 9 percentages = 630 trials per baseline. Target: within 60 s
   (wall clock; the load average is printed beside it, the machine is shared).
2. **Per trial, against ours**: the same set, the same 10 held-out demonstrations (2 per
   primitive) for ``ours`` (automatic settings), ``dtw`` and ``prefix-nn`` on one process: CPU
   seconds per trial (a held-out demonstration at one percentage, fit included) and each
   baseline's ratio to ours.

Run: ``.venv/bin/python bench/baselines.py``. The last line is one JSON object.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.faults import evaluate as run_cli  # noqa: E402
from promp.data import Demonstration  # noqa: E402
from promp.datasets import write_csv_dataset  # noqa: E402
from promp.evaluate import cli  # noqa: E402
from promp.evaluate.registry import method_factories  # noqa: E402
from promp.evaluate.sweep import run_sweep, spread_subset  # noqa: E402

MODALITIES = {
    "hand": ("x", "y", "z"),
    "head": ("roll", "pitch", "yaw"),
    "force": ("fx", "fy", "fz"),
    "moment": ("mx", "my", "mz"),
    "gaze": ("gaze_yaw", "gaze_pitch", "gaze_roll"),
}
COLUMNS = tuple(c for columns in MODALITIES.values() for c in columns)
PRIMITIVES, PER_PRIMITIVE, RATE = 5, 14, 100.0
PERCENTS = (10, 20, 30, 40, 50, 60, 70, 80, 90)
GOAL_S = 60.0


def synthetic_set(seed: int = 0) -> dict[str, list[Demonstration]]:
    """5 primitives x 14 demonstrations of 15 columns: each primitive a smooth rise to its own
    target (of each column's scale: 0.3 m, 0.5 rad, 10 N, 1 N m, 0.4 rad), each demonstration
    of its own duration, amplitude and timing, with sensor noise."""
    rng = np.random.default_rng(seed)
    scale = np.repeat([0.3, 0.5, 10.0, 1.0, 0.4], 3)
    out = {}
    for k in range(PRIMITIVES):
        target = scale * rng.uniform(-1.0, 1.0, len(COLUMNS))
        demos = []
        for i in range(PER_PRIMITIVE):
            n = int(RATE * rng.uniform(1.4, 2.6))
            z = np.linspace(0.0, 1.0, n)[:, None]
            centre = 0.5 + 0.06 * rng.standard_normal(len(COLUMNS))
            rise = 1.0 / (1.0 + np.exp(-(z - centre) * 10.0))
            start = 0.05 * scale * rng.standard_normal(len(COLUMNS))
            values = start + rise * target * (1 + 0.1 * rng.standard_normal(len(COLUMNS)))
            values = values + 0.01 * scale * rng.standard_normal(values.shape)
            demos.append(Demonstration(np.arange(n) / RATE, values, COLUMNS, f"p{k}_{i:02d}"))
        out[f"p{k}"] = demos
    return out


def goal_run(folder: Path, out: Path) -> tuple[dict, float]:
    """The command line's evaluation of both baselines (item 1): (its report, seconds)."""
    modality_args = [a for name, cols in MODALITIES.items()
                     for a in ("--modality", f"{name}={','.join(cols)}")]  # fmt: skip
    common = [*modality_args, "--observe", ",".join(MODALITIES), "--alpha", "ml"]
    return run_cli(folder, ["--method", "dtw", "prefix-nn"], common, out, data_format="csv")


def per_trial(dataset, layout) -> dict[str, float]:
    """CPU seconds per trial of each method on the same 10 held-out demonstrations (item 2)."""
    held_out = spread_subset(dataset, 2)
    observe = [list(MODALITIES)]
    out = {}
    for name, factory in method_factories(["ours", "dtw", "prefix-nn"], layout).items():
        start = time.process_time()
        result = run_sweep(factory, dataset, layout, PERCENTS, ["ml"], observe, name,
                           jobs=1, held_out=held_out)  # fmt: skip
        trials = sum(r["trials"] for r in result.rows)
        out[name] = (time.process_time() - start) / trials
    return out


def main() -> None:
    dataset = synthetic_set()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "set"
        write_csv_dataset(folder, dataset)
        load = os.getloadavg()[0]
        report, goal = goal_run(folder, Path(tmp) / "report.json")
        loaded = cli.load(cli.build_parser().parse_args(
            [str(folder), "--format", "csv",
             *[a for n, c in MODALITIES.items() for a in ("--modality", f"{n}={','.join(c)}")]]
        ))  # fmt: skip
    trials = sum(r["trials"] for r in report["results"])
    errors = {r["method"]: 0 for r in report["results"]}
    for r in report["results"]:
        errors[r["method"]] += r["recognition_errors"]
    print(f"1. 70 demonstrations x 15 columns, --method dtw prefix-nn, 9 percentages, every "
          f"core: {goal:.1f} s for {trials} trials (load average {load:.1f} at the start; "
          f"goal <= {GOAL_S:.0f} s: {'PASS' if goal <= GOAL_S else 'FAIL'})")  # fmt: skip
    cpu = per_trial(loaded.dataset, loaded.layout)
    for name, seconds in cpu.items():
        ratio = seconds / cpu["ours"]
        print(f"2. {name:9s} {1e3 * seconds:7.1f} ms CPU per trial ({ratio:.3f}x ours)")
    print(json.dumps({
        "goal_run_s": round(goal, 2), "goal_s": GOAL_S, "goal_met": goal <= GOAL_S,
        "goal_trials": trials, "load_average": round(load, 2), "cores": os.cpu_count(),
        "errors": errors,
        **{f"cpu_ms_per_trial_{n.replace('-', '_')}": round(1e3 * s, 2) for n, s in cpu.items()},
        "ratio_dtw_to_ours": round(cpu["dtw"] / cpu["ours"], 3),
        "ratio_prefix_nn_to_ours": round(cpu["prefix-nn"] / cpu["ours"], 3),
    }))  # fmt: skip


if __name__ == "__main__":
    main()
