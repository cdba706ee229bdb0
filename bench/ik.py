"""Inverse kinematics of the iCub's left arm: drag latency and success rate.

1. Drag: a closed path of targets 1 cm apart over the table (what dragging the hand gizmo in the
   browser does), each solve warm-started from the previous solution. Goal: median <= 2 ms.
2. Success: random in-limit configurations, their hand positions as targets, each solved from the
   natural pose; the fraction reached within 1 mm.

The last line printed is one JSON object (``ik_ms_median``, ``success_rate`` and details).

    .venv/bin/python bench/ik.py [--targets 500] [--seed 0]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from robots.icub.ik import solve_ik  # noqa: E402
from robots.icub.kinematics import ArmChain, load_arm  # noqa: E402

STEP_M = 0.01


def drag_path(step: float = STEP_M, laps: int = 3) -> np.ndarray:
    """A closed curve over the table, inside the reach of the arm alone (torso locked), resampled
    ``step`` apart and repeated ``laps`` times, shape (n, 3)."""
    s = np.linspace(0.0, 2.0 * np.pi, 4000)
    curve = np.column_stack(
        [
            -0.26 + 0.03 * np.sin(2.0 * s),
            -0.19 + 0.11 * np.sin(s),
            0.08 + 0.06 * np.cos(s),
        ]
    )
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(curve, axis=0), axis=1))])
    stops = np.arange(0.0, arc[-1], step)
    one_lap = np.column_stack([np.interp(stops, arc, curve[:, k]) for k in range(3)])
    return np.vstack([one_lap] * laps)


def bench_drag(arm: ArmChain, lock_torso: bool) -> dict[str, float]:
    targets = drag_path()
    q = solve_ik(arm, targets[0], arm.rest, lock_torso=lock_torso).q
    times, errors, iterations = [], [], []
    for target in targets[1:]:
        start = time.perf_counter()
        result = solve_ik(arm, target, q, lock_torso=lock_torso)
        times.append(time.perf_counter() - start)
        q = result.q
        errors.append(result.position_error_m)
        iterations.append(result.iterations)
    ms = 1e3 * np.array(times)
    return {
        "n": len(times),
        "ms_median": float(np.median(ms)),
        "ms_p95": float(np.percentile(ms, 95)),
        "ms_max": float(ms.max()),
        "iterations_median": float(np.median(iterations)),
        "max_error_mm": 1e3 * float(np.max(errors)),
    }


def bench_success(
    arm: ArmChain, n: int, seed: int, lock_torso: bool, restarts: int
) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    configurations = arm.random_configurations(rng, n)
    if lock_torso:
        configurations[:, :3] = arm.rest[:3]
    errors, times = [], []
    for q in configurations:
        target = arm.position(q)
        start = time.perf_counter()
        result = solve_ik(arm, target, arm.rest, lock_torso=lock_torso, restarts=restarts)
        times.append(time.perf_counter() - start)
        if not arm.within_limits(result.q):
            raise RuntimeError("the IK left the joint limits")
        errors.append(result.position_error_m)
    errors = np.array(errors)
    return {
        "n": n,
        "success_rate": float(np.mean(errors <= 1e-3)),
        "ms_median": 1e3 * float(np.median(times)),
        "ms_max": 1e3 * float(np.max(times)),
    }


def main(targets: int = 500, seed: int = 0) -> dict[str, float]:
    arm = load_arm()
    drag = bench_drag(arm, lock_torso=False)
    drag_locked = bench_drag(arm, lock_torso=True)
    print(f"drag, {drag['n']} targets {100 * STEP_M:.0f} cm apart, warm-started:")
    for label, d in (("10 joints", drag), ("torso locked", drag_locked)):
        print(
            f"  {label:13s} median {d['ms_median']:.3f} ms, p95 {d['ms_p95']:.3f} ms, "
            f"max {d['ms_max']:.3f} ms, {d['iterations_median']:.0f} iterations (median), "
            f"max error {d['max_error_mm']:.3f} mm"
        )
    runs = {}
    print(f"random reachable targets ({targets}, seed {seed}), solved from the natural pose:")
    for lock in (False, True):
        for restarts in (0, 5):
            r = bench_success(arm, targets, seed, lock, restarts)
            runs[(lock, restarts)] = r
            label = ("torso locked" if lock else "10 joints") + f", {restarts} restarts"
            print(
                f"  {label:25s} reached within 1 mm: {100 * r['success_rate']:.1f} %, "
                f"median {r['ms_median']:.2f} ms, max {r['ms_max']:.1f} ms"
            )
    summary = {
        "ik_ms_median": round(drag["ms_median"], 4),
        "success_rate": runs[(False, 0)]["success_rate"],
        "ik_ms_median_locked_torso": round(drag_locked["ms_median"], 4),
        "success_rate_locked_torso": runs[(True, 0)]["success_rate"],
        "success_rate_5_restarts": runs[(False, 5)]["success_rate"],
        "success_rate_locked_torso_5_restarts": runs[(True, 5)]["success_rate"],
    }
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--targets", type=int, default=500, help="random targets (default 500)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    args = parser.parse_args()
    if args.targets < 1:
        parser.error("--targets must be >= 1")
    main(args.targets, args.seed)
