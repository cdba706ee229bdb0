"""Fixed settings compared by the whole leave-one-out sweep: the outer check of the rule.

``python -m promp.evaluate.fixed_settings DATASET --format ...`` scores each candidate
setting of :data:`CANDIDATES` (number of basis functions per dimension M, width,
observation noise scale) by the mean negative log posterior probability of the true
primitive, over every held-out demonstration and every observed percentage (10 ... 90 %): a
proper scoring rule of what the studio does, averaged over the whole movement rather than one
percentage, so it is not tuned to a single operating point. The lowest wins. It works on any
dataset the evaluation reads. It is an outer check of fixed candidates (each scored by the
whole leave-one-out sweep); by default the sweep chooses the settings from training
demonstrations instead, once per block of a tenth of the set (:mod:`promp.selection`, the same
score inside the training set), and the covariance prior needs no search (marginal
likelihood, per fit).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

from promp.evaluate.cli import add_check_arguments, add_dataset_arguments, load, print_findings
from promp.evaluate.methods import ProMPEngine
from promp.evaluate.sweep import run_sweep
from promp.model import Settings
from promp.progress import stderr_progress

__all__ = ["CANDIDATES", "PERCENTS", "main", "score"]

# (basis functions per dimension, width, noise scale); the covariance prior is chosen by
# marginal likelihood inside every fold
CANDIDATES = (
    (5, 1.0, 1.5),
    (7, 1.0, 1.0),
    (7, 1.0, 1.5),
    (7, 1.0, 2.0),
    (10, 1.0, 1.5),
)
PERCENTS = (10, 20, 30, 40, 50, 60, 70, 80, 90)


def score(rows: list[dict]) -> dict:
    """Mean log-loss and total recognition errors of one sweep."""
    n = sum(r["trials"] for r in rows)
    return {
        "log_loss": float(sum(r["log_loss"] * r["trials"] for r in rows) / n),
        "errors": int(sum(r["recognition_errors"] for r in rows)),
        "trials": int(sum(r["trials"] for r in rows)),
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m promp.evaluate.fixed_settings", description=__doc__
    )
    add_dataset_arguments(parser)
    parser.add_argument("--observe", action="append", default=None)
    parser.add_argument("--json", default=None)
    parser.add_argument("--jobs", type=int, default=-1, help="processes (-1: every core)")
    add_check_arguments(parser)
    args = parser.parse_args(argv)
    try:
        loaded = load(args)
        dataset, layout, observe = loaded.dataset, loaded.layout, loaded.observe
        print_findings(loaded, args.include_flagged)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    results = []
    for n_basis, width, noise_scale in CANDIDATES:
        settings = Settings(n_basis=n_basis, width=width, noise_scale=noise_scale)
        sweep = run_sweep(
            lambda settings=settings: ProMPEngine(layout, settings),
            dataset,
            layout,
            percents=PERCENTS,
            alpha_methods=["ml"],
            observe_sets=observe,
            method_name="ours",
            progress=stderr_progress(f"M={n_basis} width={width} noise x{noise_scale}", "folds"),
            jobs=args.jobs,
        )
        row = {
            "n_basis": n_basis,
            "width": width,
            "noise_scale": noise_scale,
            **score(sweep.rows),
        }
        results.append(row)
        print(
            f"M={n_basis:3d} width={width:4.1f} noise x{noise_scale}: "
            f"log-loss {row['log_loss']:.3f}, "
            f"errors {row['errors']}/{row['trials']}",
            flush=True,
        )
    best = min(results, key=lambda r: r["log_loss"])
    print(
        f"chosen: n_basis={best['n_basis']} width={best['width']} "
        f"noise_scale={best['noise_scale']}"
    )
    if args.json:
        with open(args.json, "w") as handle:
            json.dump({"candidates": results, "chosen": best}, handle, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
