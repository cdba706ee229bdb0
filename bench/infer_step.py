"""The Infer tab's computation of one scrub step, without viser, against another commit's on the
same model, in one run.

A step is :func:`app.live.inference.inferred` on the first p % of a held-out test demonstration
(hand and head observed, alpha ``ml``), and what the studio draws of its result read: every
position's region and path, the hand's future, the errors, the prediction. The sweep is
``bench/scrub.py``'s (5 to 100 % and back in steps of 5) on the studio's simulated scenario,
with the model learned here, its settings then given to both sides: the two sides compute with
the same model, so the ratio is the code's, not what each commit's learning chose (a refit of
the default workspace may choose another number of basis functions, and a step costs with it).
``bench/scrub.py`` times the step in the running studio, with its own model, beside the
learner's background work.

``--baseline DIR`` runs the same in a checkout of another commit (e.g. ``git worktree add
/tmp/base 9d0abac``), each side in its own process, the sides alternated (ABBA) for
``--rounds``; the ratio is this tree's median over the baseline's.

Run: ``.venv/bin/python bench/infer_step.py [--baseline DIR] [--rounds N]``. The last line is
one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SWEEP = list(range(5, 101, 5)) + list(range(95, 4, -5))


def worker(settings: dict, repeats: int) -> list[float]:
    """Every step's ms in this process's tree (``sys.path`` set by the caller)."""
    from app.live import inference
    from promp.inference import Observation
    from promp.learn import fit
    from promp.model import Settings
    from promp.timing import n_observed_for
    from robots.icub.layout import STUDIO_LAYOUT
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=0)
    train = {k: (v[1:] if k == "curved" else v) for k, v in dataset.items()}
    model = fit(train, STUDIO_LAYOUT, Settings(**settings))
    demo = dataset["curved"][0]

    def step(percent: int) -> None:
        n = n_observed_for(percent, demo.n_samples)
        obs = Observation.from_demo(model, demo, n, ("hand", "head"))
        result = inference.inferred(model, obs, "ml", truth=demo)
        _ = (result.positions, result.future, result.prediction, result.weights)
        _ = getattr(result, "errors", None)  # derived when read here; computed by inferred before

    for percent in SWEEP:  # warm up
        step(percent)
    times = []
    for _ in range(repeats):
        for percent in SWEEP:
            start = time.perf_counter()
            step(percent)
            times.append(1e3 * (time.perf_counter() - start))
    return times


def run_side(root: Path, settings: dict, repeats: int) -> list[float]:
    """The steps' ms of the tree at ``root``, in a process of its own."""
    out = subprocess.run(
        [sys.executable, __file__, "--worker", str(root), "--settings", json.dumps(settings),
         "--repeats", str(repeats)],
        check=True, capture_output=True, text=True, cwd=root,
    )  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


def chosen_settings() -> dict:
    """The settings this tree's learning chooses on the scenario, as given values."""
    sys.path.insert(0, str(REPO))
    from promp.learn import fit
    from robots.icub.layout import STUDIO_LAYOUT
    from robots.icub.scenario import generate_scenario

    s = fit(generate_scenario(seed=0), STUDIO_LAYOUT).settings
    return {"n_basis": s.n_basis, "width": s.width, "noise_scale": s.noise_scale,
            "duration_temperature": s.duration_temperature}  # fmt: skip


def main(baseline: Path | None, rounds: int, repeats: int) -> None:
    settings = chosen_settings()
    sides = {"this": REPO} | ({"baseline": baseline} if baseline is not None else {})
    times: dict[str, list[float]] = {name: [] for name in sides}
    medians: dict[str, list[float]] = {name: [] for name in sides}
    for r in range(rounds):
        order = list(sides) if r % 2 == 0 else list(reversed(sides))  # ABBA
        for name in order:
            steps = run_side(sides[name], settings, repeats)
            times[name] += steps
            medians[name].append(statistics.median(steps))
            print(f"round {r + 1} {name:8s} median {medians[name][-1]:6.2f} ms "
                  f"(load {os.getloadavg()[0]:.1f})", flush=True)  # fmt: skip
    result = {f"{name}_ms_median": round(statistics.median(t), 3) for name, t in times.items()}
    result |= {f"{name}_ms_median_per_round": [round(m, 3) for m in medians[name]]
               for name in sides}  # fmt: skip
    if baseline is not None:
        result["ratio"] = round(result["this_ms_median"] / result["baseline_ms_median"], 3)
    result |= {"settings": settings, "steps_per_round": repeats * len(SWEEP),
               "load_average_1min": round(os.getloadavg()[0], 2), "cpus": os.cpu_count()}
    line = f"this tree {result['this_ms_median']:.2f} ms a step"
    if baseline is not None:
        line += (f", baseline {result['baseline_ms_median']:.2f} ms: ratio {result['ratio']:.2f}"
                 f" (the same model, {settings['n_basis']} basis functions)")
    print(line)
    print(json.dumps(result))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", type=Path, help="a checkout of the commit to compare with")
    parser.add_argument("--rounds", type=int, default=4, help="runs of each side, alternated")
    parser.add_argument("--repeats", type=int, default=2, help="sweeps a run")
    parser.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--settings", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker is not None:
        sys.path.insert(0, str(args.worker))
        print(json.dumps(worker(json.loads(args.settings), args.repeats)))
    else:
        main(args.baseline, args.rounds, args.repeats)
