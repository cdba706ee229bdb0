"""The two exact forms of the marginal likelihood, timed on the same whitened sums: the
weight-space form (one ``(P_o + 1)`` Cholesky factorisation per candidate speed,
:mod:`promp.evidence.weight_space`) against the Woodbury form (:mod:`promp.evidence.woodbury`),
for models of the shared set ``lab-records-flt`` over four modalities (12 dimensions) with
7 and 12 basis functions (P_o = 84, 144 observed weights) learned from 3 to 19 demonstrations
per class (rank r = 12 to 76), 32 candidate speeds, 40 % of a held-out movement observed.
Prints per case both times, their ratio, the largest difference of the log-likelihoods, and
the form :func:`promp.evidence.weight_space.cheaper_than_woodbury` chooses and whether it is
the faster; the last line is one JSON object (the load average beside it).

Run: ``.venv/bin/python bench/likelihood_forms.py``.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from promp.datasets import load_records_dataset  # noqa: E402
from promp.evidence import weight_space, woodbury  # noqa: E402
from promp.evidence.evidence import Evidence  # noqa: E402
from promp.inference import Observation  # noqa: E402
from promp.learn import fit  # noqa: E402
from promp.model import Settings  # noqa: E402
from promp.timing import duration_from_alpha  # noqa: E402

sys.path.insert(0, str(REPO / "bench"))
from live import DATA, LAYOUT  # noqa: E402  (the four modalities of lab-records-flt)


def best_of(f, rounds: int = 5, n: int = 10) -> float:
    """The fastest of ``rounds`` means of ``n`` calls, ms (the least disturbed by load)."""
    f()
    times = []
    for _ in range(rounds):
        began = time.perf_counter()
        for _ in range(n):
            f()
        times.append((time.perf_counter() - began) / n * 1e3)
    return min(times)


def case(dataset: dict, n_basis: int, per_class: int) -> dict:
    sub = {c: v[:per_class] for c, v in dataset.items()}
    settings = Settings(n_basis=n_basis, width=1.0, noise_scale=1.5, duration_temperature=1.0,
                        recognition="promp")
    model = fit(sub, LAYOUT, settings)
    demo = dataset[sorted(dataset)[0]][-1]  # not learned from
    obs = Observation.first(model, demo, 40, list(LAYOUT.names))
    evidence = Evidence(model, obs)
    primitive, dims = model.primitives[0], evidence.dims
    alphas = np.exp(np.linspace(np.log(0.5), np.log(2.0), 32))
    durations = duration_from_alpha(alphas, model.sample_period, model.settings.s_bar)
    ok = durations >= obs.elapsed[-1]
    sums = evidence._sums(primitive, alphas[ok], durations[ok])
    noise = primitive.noise_var[dims][None, :]
    u = primitive.observed_factor(dims)
    p, r = u.shape[0] * u.shape[1], u.shape[2]
    weight = best_of(lambda: weight_space.log_likelihoods(sums, primitive, dims, noise))
    wood = best_of(lambda: woodbury.log_likelihoods(sums, primitive, dims, noise))
    diff = np.abs(weight_space.log_likelihoods(sums, primitive, dims, noise)
                  - woodbury.log_likelihoods(sums, primitive, dims, noise)).max()  # fmt: skip
    chosen = "weight" if weight_space.cheaper_than_woodbury(p, r) else "woodbury"
    faster = "weight" if weight <= wood else "woodbury"
    return {"P": p, "r": r, "candidates": int(ok.sum()), "weight_ms": round(weight, 3),
            "woodbury_ms": round(wood, 3), "ratio_weight_over_woodbury": round(weight / wood, 2),
            "max_abs_diff": float(diff), "chosen": chosen, "faster": faster}  # fmt: skip


def main() -> dict:
    if not DATA.is_dir():
        raise SystemExit(f"{DATA} is missing (the shared data)")
    dataset = load_records_dataset(DATA)
    rows = []
    for n_basis in (7, 12):
        for per_class in (3, 5, 8, 12, 19):
            row = case(dataset, n_basis, per_class)
            print(json.dumps(row), flush=True)
            rows.append(row)
    close = [r for r in rows if 0.8 <= r["ratio_weight_over_woodbury"] <= 1.25]
    wrong = [r for r in rows if r["chosen"] != r["faster"] and r not in close]
    return {"cases": len(rows), "chosen_the_faster": len(rows) - len(wrong),
            "wrong_beyond_25_percent": [(r["P"], r["r"]) for r in wrong],
            "load_average": [round(x, 2) for x in os.getloadavg()]}  # fmt: skip


if __name__ == "__main__":
    print(json.dumps(main()))
