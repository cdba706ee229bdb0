"""The live time base: recognition and cost with the input at 250 Hz or at the model's rate.

A model learned at 100 Hz observed at 250 Hz does 2.5 times the work for nearly the same
information. Here the demonstrations of ``lab-records-flt`` (12 channels, 100 Hz; 3-fold:
each third predicted by the model learned on the other two) are resampled at 250 Hz, as
``bench/live.py`` replays them, and observed as the live predictor sees them: either those
rows as they are, or put on a regular time base at ``--rate`` Hz (default 100, the model's
own; linear interpolation, as :class:`promp.live.timebase.TimeBase` does), at 25, 50, 75 and
100 % of each movement. Measured for each: the share of observations whose recognised
primitive is the true one, the mean ``-ln p(true)``, the mean time of one
:func:`promp.evidence.infer`, and the largest difference in p(true) between the two.

Run: ``nice -n 10 .venv/bin/python bench/time_base.py``. The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "bench"))

from live import DATA, LAYOUT, RATE_HZ  # noqa: E402

from promp.datasets import load_records_dataset  # noqa: E402
from promp.evidence.pipeline import infer  # noqa: E402
from promp.inference import Observation  # noqa: E402
from promp.learn import fit  # noqa: E402

SHARES = (0.25, 0.5, 0.75, 1.0)
FOLDS = 3


def observed(demo, rate: float | None, share: float) -> Observation:
    """The first ``share`` of ``demo`` as the live predictor observes it: resampled at 250 Hz,
    then on a regular time base at ``rate`` Hz (None: the 250 Hz rows)."""
    t = demo.times - demo.times[0]
    values = LAYOUT.extract(demo)
    grid = np.arange(0.0, t[-1] + 1e-9, 1.0 / RATE_HZ)
    rows = np.column_stack([np.interp(grid, t, c) for c in values.T])
    if rate is not None:
        base = np.arange(0.0, grid[-1] + 1e-9, 1.0 / rate)
        rows = np.column_stack([np.interp(base, grid, c) for c in rows.T])
        grid = base
    n = max(int(np.searchsorted(grid, share * grid[-1], side="right")), 2)
    return Observation(grid[:n], rows[:n], LAYOUT.names)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=100.0)
    args = parser.parse_args()
    dataset = load_records_dataset(DATA)
    demos = [(k, i, d) for k, ds in dataset.items() for i, d in enumerate(ds)]
    ways = {"250 Hz rows": None, f"time base {args.rate:g} Hz": args.rate}
    found = {w: {"right": 0, "nll": [], "s": [], "p": []} for w in ways}
    for fold in range(FOLDS):
        train = {k: [d for i, d in enumerate(ds) if i % FOLDS != fold] for k, ds in dataset.items()}
        model = fit(train, LAYOUT)
        names = [p.name for p in model.primitives]
        for klass, i, demo in demos:
            if i % FOLDS != fold:
                continue
            for share in SHARES:
                for way, rate in ways.items():
                    obs = observed(demo, rate, share)
                    began = time.perf_counter()
                    inference = infer(model, obs)
                    f = found[way]
                    f["s"].append(time.perf_counter() - began)
                    p_true = float(inference.probabilities[names.index(klass)])
                    f["right"] += inference.primitive == klass
                    f["nll"].append(-np.log(max(p_true, 1e-300)))
                    f["p"].append(p_true)
    result = {}
    for way, f in found.items():
        result[way] = {"observations": len(f["s"]),
                       "recognised": round(f["right"] / len(f["s"]), 4),
                       "nll_true": round(float(np.mean(f["nll"])), 4),
                       "infer_ms_mean": round(1e3 * float(np.mean(f["s"])), 1)}  # fmt: skip
        print(way, result[way], flush=True)
    a, b = (np.array(f["p"]) for f in found.values())
    result["max_p_true_difference"] = round(float(np.abs(a - b).max()), 4)
    result["load_average"] = [round(x, 2) for x in os.getloadavg()]
    print(json.dumps(result))


if __name__ == "__main__":
    main()
