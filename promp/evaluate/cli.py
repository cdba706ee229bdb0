"""``python -m promp.evaluate``: the paper's leave-one-out analysis on any dataset.

::

    python -m promp.evaluate DATASET --format records|csv [--modality NAME=COL,COL,...]...
        [--observe NAME[,NAME...]]... [--percent P ...] [--alpha ml model] [--method ours|seed]
        [--json OUT.json] [--csv OUT.csv] [--plots DIR] [--basis M] [--width W]
        [--shrinkage S|auto] [--noise-scale X] [--subset N] [--jobs N]
        [--backend local|dask --scheduler ADDRESS]

``--format records`` reads the lab-record format, ``--format csv`` reads ``DATASET/<primitive>/
<demo>.csv`` (:func:`promp.datasets.read_dataset`, the reader the studio's import uses too).
``--modality`` maps columns to modalities; without it they are guessed from the columns
(``hand`` = x, y, z, ``head`` = roll, pitch, yaw; for lab records, ``hand`` is the hand in the
robot's root frame). ``--observe`` (default: the hand) may be repeated to sweep several
modality sets in one run. The folds run on every core (``--jobs``), or on a Dask cluster
(``--backend dask --scheduler ADDRESS``); the results are the same. ``--subset N`` holds out
only N demonstrations per primitive, evenly spread (each still tested by a model fitted on
every other demonstration): a quick run, the same for every method.

``--json`` writes the report (settings, the result rows, the failed trials), ``--csv`` the
result table (:mod:`promp.evaluate.report`, which the studio's "Export results" writes too),
``--plots`` the figures (:mod:`promp.evaluate.plots`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from promp.data import Layout
from promp.datasets import Dataset, parse_modality, read_dataset
from promp.evaluate.methods import ProMPEngine
from promp.evaluate.report import basis_settings, report_json, results_csv, results_report
from promp.evaluate.seed import ToolboxBaseline
from promp.evaluate.sweep import position_modality, run_sweep, spread_subset, tqdm_progress
from promp.model import Settings

DEFAULT_PERCENTS = (10, 20, 30, 40, 50, 60, 70, 80, 90)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m promp.evaluate",
        description=(
            "Leave-one-out evaluation of multi-modal ProMP intention prediction: recognition "
            "errors, position, goal and duration errors and NRMSE against the percentage of "
            "the movement observed (Dermy et al., Figs. 6, 8, 10, 11)."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument("dataset", type=Path, help="dataset folder")
    parser.add_argument("--format", choices=("records", "csv"), required=True)
    parser.add_argument(
        "--modality",
        action="append",
        default=[],
        metavar="NAME=COL,COL,...",
        help="a modality: a name and its columns (repeatable); e.g. hand=x,y,z "
        "head=roll,pitch,yaw, or for lab records wrench=fx,fy,fz,mx,my,mz",
    )
    parser.add_argument(
        "--observe",
        action="append",
        default=None,
        metavar="NAME[,NAME...]",
        help="observed modalities (repeatable to sweep several sets); default: hand",
    )
    parser.add_argument("--percent", type=float, nargs="+", default=list(DEFAULT_PERCENTS))
    parser.add_argument("--alpha", nargs="+", choices=("ml", "model"), default=["ml", "model"])
    parser.add_argument("--method", choices=("ours", "seed"), default="ours")
    parser.add_argument(
        "--basis",
        type=int,
        default=None,
        metavar="M",
        help="basis functions per dimension (ours); default: chosen by every fit from its "
        "training demonstrations (promp.selection)",
    )
    parser.add_argument(
        "--width",
        type=float,
        default=None,
        help="basis width, in spacings (ours); default: chosen by every fit",
    )
    parser.add_argument(
        "--shrinkage",
        default="auto",
        help="'auto': each primitive's covariance under a prior pooled across primitives, its "
        "strength by marginal likelihood, chosen inside every fold; or a fixed shrinkage "
        "intensity in (0, 1] of each primitive's own sample covariance (ours)",
    )
    parser.add_argument(
        "--noise-scale",
        type=float,
        default=None,
        help="multiplies the estimated observation noise (ours); default: chosen by every fit",
    )
    parser.add_argument(
        "--subset",
        type=int,
        default=None,
        metavar="N",
        help="hold out only N demonstrations per primitive, evenly spread over each "
        "primitive's list (deterministic; each still tested by a model fitted on all the "
        "others); default: every demonstration",
    )
    parser.add_argument(
        "--jobs", type=int, default=-1, help="processes running the folds (-1: every core)"
    )
    parser.add_argument(
        "--backend",
        choices=("local", "dask"),
        default="local",
        help="run the folds here, or on a Dask cluster (needs --scheduler and the "
        "'cluster' extra)",
    )
    parser.add_argument(
        "--scheduler", default=None, metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786"
    )
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    parser.add_argument(
        "--csv", type=Path, default=None, help="write the result table here (one line per row)"
    )
    parser.add_argument("--plots", type=Path, default=None, help="write PNG figures here")
    return parser


def load(args: argparse.Namespace) -> tuple[Dataset, Layout, list[list[str]]]:
    """The dataset, its layout and the observed modality sets the arguments name."""
    observe = [
        [name.strip() for name in spec.split(",") if name.strip()] for spec in (args.observe or [])
    ]
    modalities = [parse_modality(spec) for spec in args.modality]
    dataset, layout = read_dataset(args.dataset, args.format, modalities or None)
    observe = observe or [[position_modality(layout)]]
    for names in observe:
        layout.dims(names)  # unknown names are an error before any work
    return dataset, layout, observe


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        dataset, layout, observe = load(args)
        if any(not 0 < p <= 100 for p in args.percent):
            raise ValueError("--percent values must be in (0, 100]")
        try:
            shrinkage = None if args.shrinkage == "auto" else float(args.shrinkage)
        except ValueError:
            raise ValueError(
                f"--shrinkage expects a number in (0, 1] or 'auto', got {args.shrinkage!r}"
            ) from None
        settings = Settings(
            n_basis=args.basis,
            width=args.width,
            shrinkage=shrinkage,
            noise_scale=args.noise_scale,
        )
        if args.method == "seed":

            def factory():
                return ToolboxBaseline(layout)

        else:

            def factory():
                return ProMPEngine(layout, settings)

        if args.backend == "dask" and not args.scheduler:
            raise ValueError("--backend dask needs --scheduler ADDRESS")
        if args.jobs == 0 or args.jobs < -1:
            raise ValueError(f"--jobs must be a positive number or -1, got {args.jobs}")
        held_out = None if args.subset is None else spread_subset(dataset, args.subset)
        n_demos = sum(len(v) for v in dataset.values()) if held_out is None else len(held_out)
        result = run_sweep(
            factory,
            dataset,
            layout,
            percents=args.percent,
            alpha_methods=args.alpha,
            observe_sets=observe,
            method_name=args.method,
            progress=tqdm_progress(f"{args.method}: leave-one-out over {n_demos} demos"),
            keep_trials=args.plots is not None,
            jobs=args.jobs,
            scheduler=args.scheduler if args.backend == "dask" else None,
            held_out=held_out,
        )
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    report = results_report(
        result,
        dataset,
        layout,
        source=str(args.dataset),
        data_format=args.format,
        method=args.method,
        observe=observe,
        percents=args.percent,
        alpha_methods=args.alpha,
        basis=basis_settings(settings),
        subset=args.subset,
    )
    print_table(result.rows)
    for failure in result.failures:
        print(
            f"failed: {failure['primitive']}/{failure['demo']} at {failure['percent']:g} % "
            f"({'+'.join(failure['observed'])}, alpha {failure['alpha_method']}): "
            f"{failure['error']}"
        )
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(report_json(report))
    if args.csv is not None:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        args.csv.write_text(results_csv(result.rows))
    if args.plots is not None:
        from promp.evaluate.plots import write_figures

        write_figures(args.plots, result, dataset, layout, args.method)
    return 0


def print_table(rows: list[dict]) -> None:
    header = (
        f"{'observed':14s} {'alpha':5s} {'%':>4s} {'errors':>9s} {'pos cm':>7s} "
        f"{'goal cm':>7s} {'dur s':>6s} {'nrmse prior':>11s} {'post':>6s} {'log-loss':>8s} "
        f"{'p<0.01':>6s} {'worst':>6s}"
    )
    print(header)
    for r in rows:
        print(
            f"{','.join(r['observed']):14s} {r['alpha_method']:5s} {r['percent']:4.0f} "
            f"{r['recognition_errors']:>4d}/{r['trials']:<4d} {100 * r['position_error_m']:7.2f} "
            f"{100 * r['goal_error_m']:7.2f} {r['duration_error_s']:6.2f} "
            f"{r['nrmse_prior']:11.3f} {r['nrmse_posterior']:6.3f} {r['log_loss']:8.3f} "
            f"{r['confident_mistakes']:6d} {r['worst_log_loss']:6.1f}"
        )
