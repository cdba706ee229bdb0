"""``python -m promp.evaluate``: the paper's leave-one-out analysis on any dataset.

::

    python -m promp.evaluate DATASET --format records|csv [--modality NAME=COL,COL,...]...
        [--observe NAME[,NAME...]]... [--percent P ...] [--alpha ml model] [--method ours|seed]
        [--json OUT.json] [--plots DIR] [--basis M] [--width W] [--shrinkage S|loo]

``--format records`` reads the lab-record format (modalities ``position`` and ``wrench``
predefined, default ``--observe position``); ``--format csv`` reads ``DATASET/<primitive>/
<demo>.csv`` with modalities named by ``--modality`` (``hand=x,y,z`` is assumed when none is
given and the columns exist; columns named roll/pitch/yaw form an angular ``head`` modality by
default). ``--observe`` may be repeated to sweep several modality sets in one run.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from promp.data import Layout, Modality
from promp.datasets import (
    Dataset,
    check_columns,
    load_csv_dataset,
    load_records_dataset,
    records_layout,
)
from promp.evaluate.methods import Ours
from promp.evaluate.seed import Seed
from promp.evaluate.sweep import position_modality, run_sweep, stderr_progress
from promp.model import Settings

DEFAULT_PERCENTS = (10, 20, 30, 40, 50, 60, 70, 80, 90)
ANGLE_COLUMNS = {"roll", "pitch", "yaw"}


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
        help="a modality of a CSV dataset (repeatable); e.g. hand=x,y,z head=roll,pitch,yaw",
    )
    parser.add_argument(
        "--observe",
        action="append",
        default=None,
        metavar="NAME[,NAME...]",
        help="observed modalities (repeatable to sweep several sets); default: position for "
        "records, hand for csv",
    )
    parser.add_argument("--percent", type=float, nargs="+", default=list(DEFAULT_PERCENTS))
    parser.add_argument("--alpha", nargs="+", choices=("ml", "model"), default=["ml", "model"])
    parser.add_argument("--method", choices=("ours", "seed"), default="ours")
    parser.add_argument(
        "--basis",
        type=int,
        default=Settings().n_basis,
        metavar="M",
        help="basis functions per dimension (ours)",
    )
    parser.add_argument(
        "--width", type=float, default=Settings().width, help="basis width, in spacings (ours)"
    )
    parser.add_argument(
        "--shrinkage",
        default=str(Settings().shrinkage),
        help="covariance shrinkage intensity in (0, 1], or 'loo' for the leave-one-out "
        "estimate per modality (ours); python -m promp.evaluate.select chooses these three",
    )
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    parser.add_argument("--plots", type=Path, default=None, help="write PNG figures here")
    return parser


def parse_modalities(specs: Sequence[str]) -> list[Modality]:
    modalities = []
    for spec in specs:
        name, sep, cols = spec.partition("=")
        columns = tuple(c.strip() for c in cols.split(",") if c.strip())
        if not sep or not name.strip() or not columns:
            raise ValueError(f"--modality expects NAME=COL,COL,..., got {spec!r}")
        kind = "angle" if set(columns) <= ANGLE_COLUMNS else "linear"
        unit = "rad" if kind == "angle" else "m"
        modalities.append(Modality(name.strip(), columns, unit=unit, kind=kind))
    return modalities


def default_csv_layout(dataset: Dataset) -> Layout:
    """``hand`` = x, y, z and ``head`` = roll, pitch, yaw when the columns exist."""
    columns = set(next(iter(dataset.values()))[0].columns)
    modalities = []
    if {"x", "y", "z"} <= columns:
        modalities.append(Modality("hand", ("x", "y", "z"), unit="m"))
    if {"roll", "pitch", "yaw"} <= columns:
        modalities.append(Modality("head", ("roll", "pitch", "yaw"), unit="rad", kind="angle"))
    if not modalities:
        raise ValueError("no --modality given and the CSV has no x,y,z or roll,pitch,yaw columns")
    return Layout(tuple(modalities))


def load(args: argparse.Namespace) -> tuple[Dataset, Layout, list[list[str]]]:
    observe = [
        [name.strip() for name in spec.split(",") if name.strip()] for spec in (args.observe or [])
    ]
    if args.format == "records":
        if args.modality:
            raise ValueError("--modality is for --format csv; records have position and wrench")
        observe = observe or [["position"]]
        needed = sorted({name for names in observe for name in names} | {"position"})
        layout = records_layout(needed)
        dataset = load_records_dataset(args.dataset, needed)
    else:
        dataset = load_csv_dataset(args.dataset)
        if args.modality:
            layout = Layout(tuple(parse_modalities(args.modality)))
        else:
            layout = default_csv_layout(dataset)
        check_columns(dataset, layout.columns)
        observe = observe or [[position_modality(layout)]]
    for names in observe:
        layout.dims(names)  # unknown names are an error before any work
    position_modality(layout)
    return dataset, layout, observe


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        dataset, layout, observe = load(args)
        if any(not 0 < p <= 100 for p in args.percent):
            raise ValueError("--percent values must be in (0, 100]")
        if args.method == "seed":

            def factory():
                return Seed(layout)

        else:
            try:
                shrinkage = None if args.shrinkage == "loo" else float(args.shrinkage)
            except ValueError:
                raise ValueError(
                    f"--shrinkage expects a number in (0, 1] or 'loo', got {args.shrinkage!r}"
                ) from None
            settings = Settings(n_basis=args.basis, width=args.width, shrinkage=shrinkage)

            def factory():
                return Ours(layout, settings)

        n_demos = sum(len(v) for v in dataset.values())
        result = run_sweep(
            factory,
            dataset,
            layout,
            percents=args.percent,
            alpha_methods=args.alpha,
            observe_sets=observe,
            method_name=args.method,
            progress=stderr_progress(f"{args.method}: leave-one-out over {n_demos} demos"),
            keep_trials=args.plots is not None,
        )
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    report = {
        "dataset": str(args.dataset),
        "settings": {
            "format": args.format,
            "method": args.method,
            "modalities": {m.name: list(m.columns) for m in layout.modalities},
            "observe": observe,
            "percents": list(args.percent),
            "alpha": list(args.alpha),
            "basis": {"n_basis": args.basis, "width": args.width, "shrinkage": args.shrinkage},
            "primitives": {name: len(demos) for name, demos in dataset.items()},
        },
        "results": result.rows,
    }
    print_table(result.rows)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=1))
    if args.plots is not None:
        from promp.evaluate.plots import write_figures

        write_figures(args.plots, result, dataset, layout, args.method)
    return 0


def print_table(rows: list[dict]) -> None:
    header = (
        f"{'observed':14s} {'alpha':5s} {'%':>4s} {'errors':>9s} {'pos cm':>7s} "
        f"{'goal cm':>7s} {'dur s':>6s} {'nrmse prior':>11s} {'post':>6s}"
    )
    print(header)
    for r in rows:
        print(
            f"{','.join(r['observed']):14s} {r['alpha_method']:5s} {r['percent']:4.0f} "
            f"{r['recognition_errors']:>4d}/{r['trials']:<4d} {100 * r['position_error_m']:7.2f} "
            f"{100 * r['goal_error_m']:7.2f} {r['duration_error_s']:6.2f} "
            f"{r['nrmse_prior']:11.3f} {r['nrmse_posterior']:6.3f}"
        )
