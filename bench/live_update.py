"""Cost of one live update against the length of the movement observed so far.

The online predictor (:mod:`promp.live.predictor`) infers on every sample of the movement so
far at each update. Here the model of ``bench/live.py`` (12 channels of ``lab-records-flt``)
is learned on the set slowed ``--slow`` times (:func:`live.slowed`; 12: movements of 6.7 to
13.8 s), and the longest slowed demonstration, sampled at 250 Hz (``--rate``; 100: the
time base at the model's own rate), is observed for ``--lengths`` seconds; at each length n,
an update adds the last 1/31 s of samples (8 at 250 Hz, 3 at 100 Hz: ~31 updates a second)
to an observation already inferred on at the two lengths before, as the
predictor's previous updates did. Measured, median of ``--repeats``:

* ``dense_ms``: :func:`promp.evidence.infer` on the n samples (a new evidence: the offline
  path, what every update cost before the sums were kept);
* ``update_ms``: the same by the movement's evidence extended by the last samples
  (:meth:`promp.evidence.Evidence.extended`);
* ``statistics_ms``: the part of ``update_ms`` spent in the likelihood's sums
  (:class:`promp.evidence.sums.ObservationSums`: the basis, the correlated-noise whitening,
  the sums), and ``whiten_rows``: the rows (samples x candidate speeds) whitened in that
  update, by recognition (the new samples of the candidates kept, every sample of a new
  candidate) and by the conditioning at the estimated speed (every sample, one candidate).

Each ``*_ratio`` is the figure at the longest length over the shortest: 1 means the cost
does not grow with the movement. The updates agree with the dense inference within 1e-9
(``max_probability_difference``).

Run: ``nice -n 10 .venv/bin/python bench/live_update.py``. The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from promp.datasets import load_records_dataset  # noqa: E402
from promp.evidence import Evidence  # noqa: E402
from promp.evidence.pipeline import infer  # noqa: E402
from promp.evidence.sums import ObservationSums  # noqa: E402
from promp.inference import Observation  # noqa: E402
from promp.learn import fit  # noqa: E402
from promp.model import Settings  # noqa: E402

sys.path.insert(0, str(REPO / "bench"))
from live import DATA, LAYOUT, RATE_HZ, slowed  # noqa: E402

STEP = 8  # samples a 250 Hz update adds at ~31 updates a second


def movement(dataset: dict, rate: float) -> np.ndarray:
    """The longest demonstration's 12 channels at ``rate`` Hz: (n, 12)."""
    demo = max((d for ds in dataset.values() for d in ds), key=lambda d: d.times[-1])
    t = demo.times - demo.times[0]
    grid = np.arange(0.0, t[-1] + 1e-9, 1.0 / rate)
    return np.column_stack([np.interp(grid, t, c) for c in LAYOUT.extract(demo).T])


def observation(rows: np.ndarray, n: int, rate: float) -> Observation:
    return Observation(np.arange(n) / rate, rows[:n], LAYOUT.names)


def measure(model, rows: np.ndarray, repeats: int, rate: float) -> dict:
    step = max(int(round(STEP * rate / RATE_HZ)), 1)  # the samples of 1/31 s
    n = rows.shape[0]
    dense, update, sums, whitened, diff = [], [], [], [], 0.0
    for _ in range(repeats):
        began = time.perf_counter()
        reference = infer(model, observation(rows, n, rate))
        dense.append(time.perf_counter() - began)
        evidence = Evidence(model, observation(rows, n - 2 * step, rate))
        evidence.infer()
        evidence = evidence.extended(observation(rows, n - step, rate))
        evidence.infer()
        spent, rows_whitened = [0.0], [0]
        original = ObservationSums.__call__
        row_sums, dense_sums = ObservationSums.rows, ObservationSums.dense

        def timed(*args, original=original, spent=spent):
            began = time.perf_counter()
            try:
                return original(*args)
            finally:
                spent[0] += time.perf_counter() - began

        def counted(owner, primitive, alphas, durations, start, row_sums=row_sums,
                    rows_whitened=rows_whitened):
            rows_whitened[0] += (owner.elapsed.shape[0] - start) * alphas.shape[0]
            return row_sums(owner, primitive, alphas, durations, start)

        def counted_dense(owner, primitive, alphas, durations, dense_sums=dense_sums,
                          rows_whitened=rows_whitened):
            rows_whitened[0] += owner.elapsed.shape[0] * alphas.shape[0]
            return dense_sums(owner, primitive, alphas, durations)

        ObservationSums.__call__ = timed
        ObservationSums.rows, ObservationSums.dense = counted, counted_dense
        try:
            began = time.perf_counter()
            result = evidence.extended(observation(rows, n, rate)).infer()
            update.append(time.perf_counter() - began)
        finally:
            ObservationSums.__call__ = original
            ObservationSums.rows, ObservationSums.dense = row_sums, dense_sums
        sums.append(spent[0])
        whitened.append(rows_whitened[0])
        diff = max(diff, float(np.abs(result.probabilities - reference.probabilities).max()))
    return {"samples": n, "dense_ms": 1e3 * statistics.median(dense),
            "update_ms": 1e3 * statistics.median(update),
            "statistics_ms": 1e3 * statistics.median(sums),
            "whiten_rows": int(statistics.median(whitened)),
            "max_probability_difference": diff}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lengths", type=float, nargs="+", default=[1.0, 2.0, 5.0, 10.0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--slow", type=float, default=12.0)
    parser.add_argument("--rate", type=float, default=RATE_HZ,
                        help="the input's time base, Hz (default 250; the model's: 100)")
    parser.add_argument("--recognition", default=None, metavar="promp|mixture:H",
                        help="the model's recognition variant (default: chosen by the fit)")
    args = parser.parse_args()
    dataset = slowed(load_records_dataset(DATA), args.slow)
    model = fit(dataset, LAYOUT, Settings(recognition=args.recognition))
    rows = movement(dataset, args.rate)
    figures = {}
    for seconds in args.lengths:
        figures[f"{seconds:g}s"] = row = measure(model, rows[:int(round(seconds * args.rate)) + 1],
                                                 args.repeats, args.rate)  # fmt: skip
        print(f"{seconds:5.1f} s: {row}", flush=True)
    first, last = figures[f"{args.lengths[0]:g}s"], figures[f"{args.lengths[-1]:g}s"]
    ratios = {f"{key}_ratio": last[key] / max(first[key], 1e-12)
              for key in ("dense_ms", "update_ms", "statistics_ms", "whiten_rows")}
    print(json.dumps({"slow": args.slow, "rate": args.rate,
                      "lengths": figures} | ratios
                     | {"load_average": [round(x, 2) for x in os.getloadavg()]}))  # fmt: skip


if __name__ == "__main__":
    main()
