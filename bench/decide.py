"""What ``--decide`` costs: every held-out demonstration observed every 2 % (50 steps) beside
the fixed-share table, per method.

One run, one process (CPU seconds, robust to the shared machine's load, which the wall clock
is not): on each set, a few held-out demonstrations per primitive (evenly spread, as
``--subset``), each method's leave-one-out folds run twice, at 20/40/60/80 % only and with
``--decide`` too (the same folds, ML, the hand observed; on the synthetic 70 x 15 set of
``bench/baselines.py``, every modality). Printed: CPU seconds per fold without and with it,
the ratio, and the whole set's estimated CPU time with it (per fold x folds; on two idle cores
the wall clock is about half of it).

Run: ``.venv/bin/python bench/decide.py [--sets synthetic heights flt flt-shapes]
[--per-primitive N]``. The shared sets are read from ``../shared/data`` or the folder
``STUDIO_SHARED_DATA`` names (skipped when absent).
The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.baselines import MODALITIES, synthetic_set  # noqa: E402
from promp.data import Layout, Modality  # noqa: E402
from promp.datasets import read_dataset  # noqa: E402
from promp.evaluate.paths import DECISION_PERCENTS  # noqa: E402
from promp.evaluate.registry import METHODS, method_factories  # noqa: E402
from promp.evaluate.sweep import run_sweep, spread_subset  # noqa: E402

SHARED = Path(os.environ.get("STUDIO_SHARED_DATA") or ROOT.parent / "shared" / "data")
PERCENTS = (20, 40, 60, 80)


def load(name: str):
    """(dataset, layout, observed modalities) of ``name``, or None when it is not here."""
    if name == "synthetic":
        layout = Layout(tuple(Modality(m, cols) for m, cols in MODALITIES.items()))
        return synthetic_set(), layout, list(MODALITIES)
    folder = SHARED / f"lab-records-{name}"
    if not folder.is_dir():
        return None
    read = read_dataset(folder, "records")
    return read.dataset, read.layout, ["hand"]


def cpu_per_fold(factory, dataset, layout, observe, held_out, decide: bool) -> float:
    start = time.process_time()
    run_sweep(factory, dataset, layout, PERCENTS, ["ml"], [observe], jobs=1, held_out=held_out,
              decide_percents=DECISION_PERCENTS if decide else ())  # fmt: skip
    return (time.process_time() - start) / len(held_out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", nargs="+", default=["synthetic", "heights", "flt", "flt-shapes"])
    parser.add_argument("--per-primitive", type=int, default=2)
    args = parser.parse_args()
    out: dict = {"load_average": round(os.getloadavg()[0], 2), "cores": os.cpu_count()}
    for name in args.sets:
        loaded = load(name)
        if loaded is None:
            print(f"{name}: not here, skipped")
            continue
        dataset, layout, observe = loaded
        held_out = spread_subset(dataset, args.per_primitive)
        folds = sum(len(d) for d in dataset.values())
        total_without = total_with = 0.0
        for method, factory in method_factories(list(METHODS), layout).items():
            without = cpu_per_fold(factory, dataset, layout, observe, held_out, False)
            with_ = cpu_per_fold(factory, dataset, layout, observe, held_out, True)
            total_without, total_with = total_without + without, total_with + with_
            print(f"{name:10s} {method:9s} {without:6.3f} s CPU per fold, with --decide "
                  f"{with_:6.3f} s ({with_ / without:4.1f}x)", flush=True)  # fmt: skip
            out[f"{name}/{method}"] = {"without_s": round(without, 4), "with_s": round(with_, 4)}
        print(f"{name:10s} all four  {total_without:6.3f} s CPU per fold, with --decide "
              f"{total_with:6.3f} s ({total_with / total_without:4.1f}x); {folds} folds: "
              f"~{folds * total_with:.0f} s CPU with --decide, ~{folds * total_without:.0f} s "
              f"without", flush=True)  # fmt: skip
        out[name] = {"folds": folds, "cpu_with_s": round(folds * total_with, 1),
                     "cpu_without_s": round(folds * total_without, 1),
                     "ratio": round(total_with / total_without, 2)}  # fmt: skip
    print(json.dumps(out))


if __name__ == "__main__":
    main()
