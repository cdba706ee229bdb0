"""What the automatic settings cost beside the given ones (issue 37, the standing rule).

One run, this machine:

1. **Per fold, one process**: the synthetic set of :mod:`bench.baselines` (70 demonstrations x
   15 columns), ``--folds`` demonstrations held out one at a time (evenly spread over every
   primitive), each fold fitted on the others with the automatic settings and with the given
   ones (``--basis 7 --width 1 --noise-scale 1.5``): CPU seconds per fold of each, their ratio
   (goal <= 2) and the settings each automatic fit chose (the same list before and after a
   speed change: what is chosen must not change).
2. **The evaluation** (``--cli``): ``python -m promp.evaluate`` on that set, every modality
   observed, ML, the default percentages, every core, automatic and given: wall seconds
   (goal: the automatic run within 60 s) with the load average beside them (the machine is
   shared: a loaded machine stretches the wall clock, not the CPU ratio of 1.). With
   ``--cli-jobs 1`` the folds run in this process and its CPU seconds are reported too
   (``cli_cpu_s_*``): the measure a shared machine keeps; two idle cores cannot take less
   than half of it.

With ``--data FOLDER`` (a set in the records format, e.g. /work/shared/data/lab-records-heights)
1. is measured on that set instead (2. is the synthetic set's alone).

Run: ``.venv/bin/python bench/sweep_speed.py [--folds 10] [--cli [--cli-jobs 1]]
[--data FOLDER]``. The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.baselines import GOAL_S, MODALITIES, synthetic_set  # noqa: E402
from bench.faults import evaluate as run_cli  # noqa: E402
from promp.datasets import write_csv_dataset  # noqa: E402
from promp.evaluate import cli  # noqa: E402
from promp.evaluate.sweep import spread_subset  # noqa: E402
from promp.learn import fit  # noqa: E402
from promp.model import Settings  # noqa: E402

GIVEN = Settings(n_basis=7, width=1.0, noise_scale=1.5, recognition="promp")
GIVEN_ARGS = ["--basis", "7", "--width", "1", "--noise-scale", "1.5", "--recognition", "promp"]
MODALITY_ARGS = [a for n, c in MODALITIES.items() for a in ("--modality", f"{n}={','.join(c)}")]


def per_fold(dataset, layout, folds: int) -> dict:
    """CPU seconds per fold of the automatic and the given fits, and the automatic choices."""
    per_primitive = max(1, folds // len(dataset))
    held_out = spread_subset(dataset, per_primitive)
    names = list(dataset)
    train = [
        {n: [d for j, d in enumerate(v) if (names.index(n), j) != (k, i)]
         for n, v in dataset.items()}
        for k, i in held_out
    ]  # fmt: skip
    fit(train[0], layout, GIVEN), fit(train[0], layout, Settings())  # imports and caches warm
    seconds = {"auto": 0.0, "given": 0.0}
    chosen = []
    for fold in train:
        start = time.process_time()
        fit(fold, layout, GIVEN)
        seconds["given"] += time.process_time() - start
        start = time.process_time()
        model = fit(fold, layout, Settings())
        seconds["auto"] += time.process_time() - start
        s = model.settings
        chosen.append([s.n_basis, s.width, s.noise_scale, s.duration_temperature])
    return {
        "folds": len(train),
        "cpu_s_per_fold_auto": round(seconds["auto"] / len(train), 3),
        "cpu_s_per_fold_given": round(seconds["given"] / len(train), 3),
        "cpu_ratio": round(seconds["auto"] / seconds["given"], 2),
        "chosen": chosen,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folds", type=int, default=10)
    parser.add_argument("--cli", action="store_true", help="also time the whole evaluation")
    parser.add_argument("--data", type=Path, help="a set in the records format (for 1.)")
    parser.add_argument("--cli-jobs", type=int, default=-1,
                        help="the evaluation's --jobs (1: in this process, its CPU reported)")
    args = parser.parse_args()
    if args.data is not None and args.cli:
        parser.error("--cli times the synthetic set: give --data or --cli, not both")
    dataset = synthetic_set()
    out: dict = {"load_average_start": round(os.getloadavg()[0], 2), "cores": os.cpu_count()}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "set"
        write_csv_dataset(folder, dataset)
        source = ([str(folder), "--format", "csv", *MODALITY_ARGS] if args.data is None
                  else [str(args.data), "--format", "records"])  # fmt: skip
        loaded = cli.load(cli.build_parser().parse_args(source))
        out["set"] = "synthetic 70 x 15" if args.data is None else str(args.data)
        out.update(per_fold(loaded.dataset, loaded.layout, args.folds))
        print(f"1. per fold: automatic {out['cpu_s_per_fold_auto']} s CPU, given "
              f"{out['cpu_s_per_fold_given']} s: x{out['cpu_ratio']} (goal <= 2)")  # fmt: skip
        if args.cli:
            common = [*MODALITY_ARGS, "--observe", ",".join(MODALITIES), "--alpha", "ml",
                      "--jobs", str(args.cli_jobs)]  # fmt: skip
            for name, extra in (("given", GIVEN_ARGS), ("auto", [])):
                load, cpu = os.getloadavg()[0], time.process_time()
                _, seconds = run_cli(folder, extra, common, Path(tmp) / f"{name}.json", "csv")
                out[f"cli_s_{name}"], out[f"cli_load_{name}"] = round(seconds, 1), round(load, 2)
                if args.cli_jobs == 1:
                    out[f"cli_cpu_s_{name}"] = round(time.process_time() - cpu, 1)
            out["cli_ratio"] = round(out["cli_s_auto"] / out["cli_s_given"], 2)
            out["cli_goal_met"] = out["cli_s_auto"] <= GOAL_S
            print(f"2. evaluation: automatic {out['cli_s_auto']} s (load {out['cli_load_auto']}),"
                  f" given {out['cli_s_given']} s (load {out['cli_load_given']}); goal "
                  f"<= {GOAL_S:.0f} s")  # fmt: skip
    out["load_average_end"] = round(os.getloadavg()[0], 2)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
