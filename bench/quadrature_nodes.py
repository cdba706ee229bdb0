"""How well recognition's quadrature over the speed resolves its integrand: the recognition and
the timing of this code's quadrature (:data:`promp.evidence.speed.N_NODES` coarse nodes and
:func:`promp.evidence.speed.refined_nodes`) against a fine quadrature of the same integrand
(``--reference`` nodes over the same range, none refined), and what an inference costs; with
``--baseline COMMIT``, the same for that commit's code (a temporary git worktree,
:mod:`bench.checkout`; its bench run as a child process on its own ``promp``) in the same run,
and the cost's ratio: a change of the quadrature (the branch ``wip/adaptive-quadrature``: 16
nodes and a refinement read from the peak's width) is measured against main this way.

For each shared set (the hand observed; flagged takes left out, as the evaluation does) and for
the 12-dimension model of ``bench/live.py`` (``lab-records-flt``'s four modalities), a model is
learned on the whole set with its automatic settings, and every demonstration is observed at
20, 40, 60, 80 and 100 % (in-sample: the quadrature's error is the question, not the method's),
under both speed priors (``ml``, and ``model``, whose half centred on the regression is
narrower than the training prior and asks more of the nodes). Per set and prior:

* ``dp_max``, ``dp_p99``: the largest and the 99th percentile of the largest difference of a
  class probability from the fine quadrature's, over the observations;
* ``dlogp_max``: the largest difference of a log probability, over the classes whose
  probability is above 1e-6;
* ``duration_max``: the largest relative difference of the predicted duration (the posterior
  median of the recognised primitive's, :mod:`promp.duration`);
* ``flips``: observations whose recognised primitive differs from the fine quadrature's;
* ``nodes``: the mean nodes scored per primitive;
* ``infer_ms``: the mean time of :meth:`promp.evidence.Evidence.infer` on the observations (a
  new evidence each: the offline path); ``cost_ratio``: this code's over the baseline's.

Run: ``.venv/bin/python bench/quadrature_nodes.py [--baseline 14520d2] [--reference 1201]``. The
last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
# the baseline's child imports that commit's promp (--repo), this bench's helpers from here
_CODE = Path(sys.argv[sys.argv.index("--repo") + 1]) if "--repo" in sys.argv else REPO
sys.path.insert(0, str(REPO / "bench"))
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(_CODE))

import numpy as np  # noqa: E402
from checkout import checkout  # noqa: E402

import promp.evidence.speed as speed  # noqa: E402
from promp.datasets import load_records_dataset  # noqa: E402
from promp.evidence.evidence import Evidence  # noqa: E402
from promp.evidence.speed import ALPHA_METHODS  # noqa: E402
from promp.learn import fit  # noqa: E402
from promp.observation import Observation  # noqa: E402

SHARED = REPO.parent / "shared" / "data"
_REFINE = getattr(speed, "N_REFINE", None)  # the code's own refined nodes, where it fixes them
SETS = ("lab-records-heights", "lab-records-flt", "lab-records-flt-shapes")
PERCENTS = (20, 40, 60, 80, 100)


def nodes(n_nodes: int, reference: bool = False) -> None:
    """Recognition's quadrature at ``n_nodes`` coarse nodes (the module's constant, read at each
    call; the lattice cache cleared); the ``reference`` refines nothing (``N_REFINE`` 0, where
    the code has it; a code that refines by the peak's width refines as it does)."""
    speed.N_NODES = n_nodes
    if _REFINE is not None:
        speed.N_REFINE = 0 if reference else _REFINE
    speed._lattice.cache_clear()


def cases() -> list[tuple[str, object, list[Observation]]]:
    """(name, model, observations) of each set, and of the live bench's model."""
    from live import DATA, LAYOUT  # the 12 dimensions of bench/live.py
    from tube_coverage import read

    sets = []
    for name in SETS:
        if not (SHARED / name).is_dir():
            print(f"{name}: not found under {SHARED}, left out", flush=True)
            continue
        dataset, layout = read([str(SHARED / name), "--format", "records"])
        sets.append((name, dataset, layout, ("hand",)))
    if DATA.is_dir():
        sets.append(("lab-records-flt, 12 dimensions", load_records_dataset(DATA), LAYOUT,
                     LAYOUT.names))  # fmt: skip
    result = []
    for name, dataset, layout, observed in sets:
        model = fit(dataset, layout)
        dims = model.layout.dims(list(observed))
        observations = []
        for demos in dataset.values():
            for demo in demos:
                values = layout.extract(demo)[:, dims]
                times = demo.times - demo.times[0]
                for percent in PERCENTS:
                    n = max(3, int(round(percent / 100 * times.shape[0])))
                    observations.append(Observation(times[:n], values[:n], tuple(observed)))
        result.append((name, model, observations))
    return result


def measure(model, observations: list[Observation], reference: int, alpha_method: str) -> dict:
    coarse = speed.N_NODES
    nodes(reference, reference=True)
    fine = []
    for obs in observations:
        evidence = Evidence(model, obs, alpha_method)
        fine.append((evidence.recognition.probabilities, evidence.timing.duration.value,
                     evidence.recognition.index))  # fmt: skip
    nodes(coarse)
    dp, dlogp, dur, flips, spent, scored = [], [], [], 0, 0.0, 0
    for obs, (p_ref, d_ref, k_ref) in zip(observations, fine, strict=True):
        began = time.perf_counter()
        evidence = Evidence(model, obs, alpha_method)
        evidence.infer()
        spent += time.perf_counter() - began
        p = evidence.recognition.probabilities
        dp.append(float(np.abs(p - p_ref).max()))
        big = p_ref > 1e-6
        dlogp.append(float(np.abs(np.log(np.maximum(p[big], 1e-300)) - np.log(p_ref[big])).max()))
        dur.append(abs(evidence.timing.duration.value - d_ref) / d_ref)
        flips += int(evidence.recognition.index != k_ref)
        scored += sum(c.shape[0] for c in evidence.recognition.candidates)
    return {
        "dp_max": float(np.max(dp)), "dp_p99": float(np.percentile(dp, 99)),
        "dlogp_max": float(np.max(dlogp)), "duration_max": float(np.max(dur)), "flips": flips,
        "nodes": scored / len(observations) / len(model.primitives),
        "infer_ms": 1e3 * spent / len(observations), "observations": len(observations),
    }  # fmt: skip


def main(reference: int) -> dict:
    result: dict = {"reference_nodes": reference, "coarse_nodes": speed.N_NODES}
    for name, model, observations in cases():
        for alpha_method in ALPHA_METHODS:
            row = result[f"{name}, {alpha_method}"] = measure(model, observations, reference,
                                                              alpha_method)  # fmt: skip
            print(f"{name:31s} {alpha_method:5s}: " + ", ".join(
                f"{k} {v:.3g}" for k, v in row.items()), flush=True)  # fmt: skip
    result["load_average"] = [round(x, 2) for x in os.getloadavg()]
    return result


def paired(baseline: str, reference: int) -> dict:
    """This code's figures and ``baseline``'s, from one run (the baseline's first)."""
    with checkout(baseline) as where:
        child = subprocess.run(
            [sys.executable, str(Path(__file__).resolve()), "--reference", str(reference),
             "--repo", str(where)], capture_output=True, text=True, check=True,
        )  # fmt: skip
    before = json.loads(child.stdout.strip().splitlines()[-1])
    print(f"baseline {baseline}: " + json.dumps(before), flush=True)
    after = main(reference)
    for key, row in after.items():
        if isinstance(row, dict) and key in before:
            row["cost_ratio"] = row["infer_ms"] / before[key]["infer_ms"]
    return {"baseline": baseline, "this": after, "before": before}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", metavar="COMMIT", help="the code to compare with, same run")
    parser.add_argument("--reference", type=int, default=1201, help="the fine quadrature's nodes")
    parser.add_argument("--repo", type=Path, help=argparse.SUPPRESS)  # the baseline's child
    args = parser.parse_args()
    print(json.dumps(paired(args.baseline, args.reference) if args.baseline
                     else main(args.reference)))  # fmt: skip
