"""``python -m promp.evaluate``: the paper's leave-one-out analysis on any dataset.

::

    python -m promp.evaluate DATASET --format records|csv|yarp|rosbag|xdf|c3d
        [--modality NAME=COL,COL,...]... [--mapping FILE] [--cut auto|markers|still|files]
        [--rate HZ] [--markers STREAM]
        [--observe NAME[,NAME...]]... [--percent P ...] [--alpha ml model]
        [--method ours seed dtw prefix-nn] [--baseline-scaling modality|column|none]
        [--json OUT.json] [--csv OUT.csv] [--plots DIR] [--basis M] [--width W]
        [--shrinkage S|auto] [--noise-scale X] [--duration-temperature T]
        [--select loo|cv] [--recognition auto|promp|mixture:H] [--subset N]
        [--group-by folder|LEVEL|REGEX] [--jobs N]
        [--backend local|dask --scheduler ADDRESS] [--include-flagged] [--repair-gaps cut|split]
        [--trials-csv OUT.csv] [--run DIR [--run-name NAME]]
        [--decide [--decide-window S] [--decisions-csv OUT.csv]]
        [--rerun OUT.rrd] [--mcap OUT.mcap]

``--format records`` reads the lab-record format, ``--format csv`` reads ``DATASET/<primitive>/
<demo>.csv``, ``yarp``, ``rosbag``, ``xdf`` and ``c3d`` a rig's recordings (:mod:`promp.rigs`:
``--modality NAME=STREAM:FIELD,...``, sessions cut by ``--cut``, streams put on one clock)
(:func:`promp.datasets.read_dataset`, the reader the studio's import uses too).
``--modality`` maps columns to modalities; without it they are guessed from the columns
(``hand`` = x, y, z, ``head`` = roll, pitch, yaw; for lab records, ``hand`` is the hand in the
robot's root frame). ``--observe`` (default: the hand) may be repeated to sweep several
modality sets in one run. The folds run on every core (``--jobs``), or on a Dask cluster
(``--backend dask --scheduler ADDRESS``); the results are the same. Ours chooses its settings
once per tenth of the set, without it (``--choice-blocks``). ``--subset N`` holds out
only N demonstrations per primitive, evenly spread (each still tested by a model fitted on
every other demonstration): a quick run, the same for every method. ``--group-by`` also holds
out a whole group at a time (a subject's or a session's folder, :mod:`promp.evaluate.groups`),
every method on the same folds, and prints the grouped rows beside leave-one-out's with a
warning where they differ beyond the noise, naming the modality that drives it
(:mod:`promp.evaluate.group_gap`).

Before the sweep, every demonstration is checked (:mod:`promp.quality`: timestamps that do
not increase, gaps, jumps, a demonstration that does not move, a rate or a duration far from the
others', a round trip, a start or an end far from the others'); what is found is printed with
the file, the time and the size, and the flagged demonstrations are left out of the sweep
(neither learned from nor tested) unless ``--include-flagged``. ``--repair-gaps cut|split``
repairs the gaps first (never by default).

``--method`` takes several methods: they run on the same folds, trials and settings, and the
tables, the report and the run hold a row per method (:mod:`promp.evaluate.registry`); the
printed tables end with the methods side by side (:mod:`promp.evaluate.tables`).

``--json`` writes the report (settings, the result rows, the failed trials, every trial, the
findings and what was left out), ``--csv`` the result table, ``--trials-csv`` one line per
trial (:mod:`promp.evaluate.report`, which the studio's "Export results" writes too),
``--plots`` the figures (:mod:`promp.evaluate.plots`). ``--rerun`` and ``--mcap`` write every
trial for Rerun and for Foxglove or PlotJuggler (:mod:`promp.evaluate.viewer_files`).

``--decide`` also judges when each method would act (:mod:`promp.evaluate.decide_options`,
:mod:`promp.evaluate.decisions`): printed, in the JSON (``decisions``, ``decision_curve``,
``decision_trials``), the figures and the run, and as CSV with ``--decisions-csv``.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from promp.datasets import (
    FORMATS,
)
from promp.evaluate import decide_options
from promp.evaluate.baselines import SCALINGS
from promp.evaluate.folds import CHOICE_BLOCKS
from promp.evaluate.grouped import plan_groups, run_grouped
from promp.evaluate.groups import GROUP_BY_HELP, parse_group_by
from promp.evaluate.loading import Loaded, load, print_findings
from promp.evaluate.methods import ALPHA_ROWS
from promp.evaluate.registry import METHODS, method_factories
from promp.evaluate.report import (
    basis_settings,
    every_row,
    every_trial,
    report_json,
    results_csv,
    results_report,
    trials_csv,
)
from promp.evaluate.settings_options import add_settings_arguments, settings_of
from promp.evaluate.sweep import SweepResult, run_sweep, spread_subset
from promp.evaluate.tables import grouped_text, paired_text, results_text, side_by_side_text
from promp.evaluate.viewer_files import (
    add_viewer_arguments,
    check_viewer_arguments,
    write_viewer_files,
)
from promp.gaps import REPAIRS
from promp.model import Settings
from promp.progress import stderr_progress
from promp.rigs import MAPPING_HELP, add_rig_arguments

__all__ = [
    "add_check_arguments",
    "add_dataset_arguments",
    "add_group_arguments",
    "build_parser",
    "DEFAULT_PERCENTS",
    "load",
    "Loaded",
    "main",
    "print_findings",
    "print_table",
]

DEFAULT_PERCENTS = (10, 20, 30, 40, 50, 60, 70, 80, 90)


def add_dataset_arguments(parser: argparse.ArgumentParser) -> None:
    """``DATASET``, ``--format``, ``--modality`` and the recordings' options (what
    :func:`load` reads)."""
    parser.add_argument("dataset", type=Path, help="dataset folder (or a session file)")
    parser.add_argument("--format", choices=FORMATS, required=True)
    parser.add_argument(
        "--modality",
        action="append",
        default=[],
        metavar="NAME=COL,COL,...",
        help="a modality: a name and its columns (repeatable); e.g. hand=x,y,z "
        f"head=roll,pitch,yaw, or for lab records wrench=fx,fy,fz,mx,my,mz; {MAPPING_HELP}",
    )
    add_rig_arguments(parser)


def add_check_arguments(parser: argparse.ArgumentParser) -> None:
    """``--include-flagged`` and ``--repair-gaps`` (what :func:`load` reads)."""
    parser.add_argument(
        "--include-flagged",
        action="store_true",
        help="learn from and test the demonstrations the checks flag (a gap, a jump, one that "
        "does not move, a rate or duration far from the others'); default: they are left out "
        "of the sweep and listed with the reason",
    )
    parser.add_argument(
        "--repair-gaps",
        choices=REPAIRS,
        default=None,
        help="repair the demonstrations with a gap in their timestamps before the checks: "
        "'cut' keeps the part before the first gap, 'split' makes every part a demonstration "
        "of its own; default: no repair (they are flagged)",
    )


def add_group_arguments(parser: argparse.ArgumentParser) -> None:
    """``--group-by`` (:mod:`promp.evaluate.groups`)."""
    parser.add_argument("--group-by", default=None, metavar="folder|LEVEL|REGEX",
                        help=GROUP_BY_HELP)  # fmt: skip


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
    add_dataset_arguments(parser)
    _add_sweep_arguments(parser)
    add_settings_arguments(parser)
    _add_run_arguments(parser)
    add_group_arguments(parser)
    add_check_arguments(parser)
    _add_output_arguments(parser)
    decide_options.add_decide_arguments(parser)
    add_viewer_arguments(parser)
    return parser


def _add_sweep_arguments(parser: argparse.ArgumentParser) -> None:
    """What is swept: the observed modalities, the percentages, the speed rows, the methods."""
    parser.add_argument(
        "--observe",
        action="append",
        default=None,
        metavar="NAME[,NAME...]",
        help="observed modalities (repeatable to sweep several sets); default: hand",
    )
    parser.add_argument("--percent", type=float, nargs="+", default=list(DEFAULT_PERCENTS))
    parser.add_argument(
        "--alpha",
        nargs="+",
        choices=ALPHA_ROWS,
        default=["ml", "model"],
        help="how the speed is found: ml (integrated over the primitive's speed prior), model "
        "(Eq. 7 from the early motion), true (the test movement's true duration told: the "
        "oracle row, how far a perfect duration estimate would take the method)",
    )
    parser.add_argument(
        "--method",
        nargs="+",
        choices=METHODS,
        default=["ours"],
        help="the methods, run on the same folds and settings and reported side by side: ours "
        "(this project's ProMP engine), seed (the authors' 2017 toolbox), dtw (open-end DTW "
        "1-NN) and prefix-nn (prefix 1-NN with a phase search), both relative to the "
        "movement's start; the last two only recognise (their position and duration errors "
        "are n/a, their rows the same for every alpha)",
    )
    parser.add_argument(
        "--baseline-scaling",
        choices=SCALINGS,
        default="modality",
        help="how dtw and prefix-nn put columns of different units on one scale, by their "
        "spread over the training demonstrations: one scale per modality of one unit (its "
        "Euclidean geometry kept) and per column otherwise (modality), every column alone "
        "(column), or none (the raw values)",
    )


def _add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """Which demonstrations are held out, and where the folds run."""
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
        "--choice-blocks",
        type=int,
        default=CHOICE_BLOCKS,
        metavar="N",
        help="ours chooses its settings once per block of 1/N of the set, without the block, "
        "for the folds testing it (default %(default)s); 0: every fold chooses its own",
    )
    parser.add_argument(
        "--jobs", type=int, default=-1, help="processes running the folds (-1: every core)"
    )
    parser.add_argument(
        "--backend",
        choices=("local", "dask"),
        default="local",
        help="run the folds here, or on a Dask cluster (needs --scheduler and the 'cluster' extra)",
    )
    parser.add_argument(
        "--scheduler", default=None, metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786"
    )


def _add_output_arguments(parser: argparse.ArgumentParser) -> None:
    """Where the results are written: JSON, CSV tables, figures, a kept run."""
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    parser.add_argument(
        "--trials-csv",
        type=Path,
        default=None,
        metavar="OUT.csv",
        help="write every trial here (demonstration, percent, recognised primitive, p(true), "
        "alpha, position, goal and duration errors)",
    )
    parser.add_argument(
        "--csv", type=Path, default=None, help="write the result table here (one line per row)"
    )
    parser.add_argument("--plots", type=Path, default=None, help="write PNG figures here")
    parser.add_argument(
        "--run",
        type=Path,
        default=None,
        metavar="DIR",
        help="keep the run in a new folder DIR (it must not exist): run.json (settings, the "
        "demonstrations used and left out, the code version, every row and trial, the "
        "confusion matrices), results.csv, trials.csv, figures/ (promp.evaluate.runs); "
        "compare two with python -m promp.evaluate.compare A B",
    )
    parser.add_argument("--run-name", default=None, help="the run's name (default: DIR's)")


@dataclass(frozen=True, eq=False)
class _Swept:
    """What :func:`_sweep` gives: the demonstrations read, the settings, the methods, the
    leave-one-out sweep, when each method would act (``--decide``) and the grouped sweep
    (``--group-by``)."""

    loaded: Loaded
    settings: Settings
    methods: dict
    result: SweepResult
    decisions: object = None  # promp.evaluate.decisions.Decisions
    grouped: object = None  # promp.evaluate.grouped.GroupedRun


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        swept = _sweep(args)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    loaded, settings, methods, result = swept.loaded, swept.settings, swept.methods, swept.result
    dataset, layout, observe = loaded.dataset, loaded.layout, loaded.observe
    report = results_report(
        result,
        dataset,
        layout,
        source=str(args.dataset),
        data_format=args.format,
        method=list(methods),
        observe=observe,
        percents=args.percent,
        alpha_methods=args.alpha,
        basis=basis_settings(settings),
        subset=args.subset,
        choice_blocks=args.choice_blocks,
        findings=loaded.findings,
        excluded=loaded.excluded,
        decisions=swept.decisions,
        grouped=swept.grouped,
    )
    print_table(result.rows)
    if report["paired"]:
        print()
        print(paired_text(report["paired"]))
    for name, blocks in result.chosen.items():
        counts = Counter(str(b.get("recognition")) for b in blocks)
        print(f"{name}'s recognition, chosen per block: "
              + ", ".join(f"{v} x{n}" for v, n in sorted(counts.items())))
    decide_options.print_decisions(swept.decisions)
    if swept.grouped is not None:
        print()
        print(grouped_text(swept.grouped))
    for failure in result.failures:
        print(
            f"failed ({failure['method']}): {failure['primitive']}/{failure['demo']} at "
            f"{failure['percent']:g} % "
            f"({'+'.join(failure['observed'])}, alpha {failure['alpha_method']}): "
            f"{failure['error']}"
        )
    return _write_outputs(args, swept, report, "+".join(methods))


def _sweep(args: argparse.Namespace) -> _Swept:
    """The demonstrations read and checked, the settings, the methods and their sweep (with
    ``--decide``'s decisions and ``--group-by``'s grouped sweep).

    Raises
    ------
    ValueError
        An argument out of range, a run folder that exists, data that cannot be read.
    """
    if args.run is not None and (args.run.exists() or args.run.is_symlink()):
        raise ValueError(f"--run {args.run} already exists: a run is kept in a new folder, "
                         "nothing is overwritten")  # fmt: skip
    check_viewer_arguments(args)  # said before the sweep, not after
    if args.plots is not None or args.run is not None:  # said before the sweep, not after
        from promp.evaluate.plots import figures_unavailable

        if figures_unavailable():
            raise ValueError(f"--plots and --run draw figures: {figures_unavailable()}")
    loaded = load(args)
    dataset, layout, observe = loaded.dataset, loaded.layout, loaded.observe
    print_findings(loaded, args.include_flagged)
    if any(not 0 < p <= 100 for p in args.percent):
        raise ValueError("--percent values must be in (0, 100]")
    settings = settings_of(args)
    methods = method_factories(args.method, layout, settings, args.baseline_scaling)
    title = "+".join(methods)
    if args.backend == "dask" and not args.scheduler:
        raise ValueError("--backend dask needs --scheduler ADDRESS")
    if args.jobs == 0 or args.jobs < -1:
        raise ValueError(f"--jobs must be a positive number or -1, got {args.jobs}")
    held_out = None if args.subset is None else spread_subset(dataset, args.subset)
    decide_options.check_decide_arguments(args)
    rule = None if args.group_by is None else parse_group_by(args.group_by)
    groups = None if rule is None else plan_groups(dataset, rule)  # refused before a sweep
    result = run_sweep(
        methods,
        dataset,
        layout,
        percents=args.percent,
        alpha_methods=args.alpha,
        observe_sets=observe,
        progress=stderr_progress(f"{title}: leave-one-out", "held-out demonstrations"),
        keep_trials=True,
        jobs=args.jobs,
        scheduler=args.scheduler if args.backend == "dask" else None,
        held_out=held_out,
        decide_percents=decide_options.decide_percents(args),
        choice_blocks=args.choice_blocks,
        choosing=stderr_progress(f"{title}: choosing the settings", "blocks"),
    )
    decisions = decide_options.judge(args, result, list(dataset))
    grouped = None
    if rule is not None:
        grouped = run_grouped(
            methods, dataset, layout, result, rule, groups, percents=args.percent,
            alpha_methods=args.alpha, observe_sets=observe, held_out=held_out,
            jobs=args.jobs, scheduler=args.scheduler if args.backend == "dask" else None,
            progress=lambda what: stderr_progress(f"{title}: {what}", "held-out demonstrations"),
        )  # fmt: skip
    return _Swept(loaded, settings, methods, result, decisions, grouped)


def _write_outputs(args: argparse.Namespace, swept: _Swept, report: dict, title: str) -> int:
    """Write what the arguments ask for (JSON, CSV tables, figures, a kept run, viewer
    files): the exit code (2 when the run or a viewer file cannot be written)."""
    result, decisions = swept.result, swept.decisions
    dataset, layout = swept.loaded.dataset, swept.loaded.layout
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(report_json(report))
    if args.csv is not None:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        args.csv.write_text(results_csv(every_row(report)))
    if args.trials_csv is not None:
        args.trials_csv.parent.mkdir(parents=True, exist_ok=True)
        args.trials_csv.write_text(trials_csv(every_trial(report)))
    decide_options.write_decisions_csv(args, decisions)
    if args.plots is not None or args.run is not None:
        from promp.evaluate.plots import write_figures

        if args.plots is not None:
            write_figures(args.plots, result, dataset, layout, title, decisions)
        if args.run is not None:
            from promp.evaluate.runs import write_run

            try:
                run = write_run(
                    args.run, report, args.run_name or args.run.name,
                    figures=lambda folder: write_figures(folder, result, dataset, layout, title,
                                                         decisions),
                )  # fmt: skip
            except ValueError as exc:
                print(f"error: {exc}", file=sys.stderr)
                return 2
            print(f"run kept in {run.folder} ({run.code_version})")
    if not write_viewer_files(args, result, dataset, layout):
        return 2
    return 0


def print_table(rows: list[dict]) -> None:
    """The result rows, then the methods side by side when there are several
    (:mod:`promp.evaluate.tables`)."""
    print(results_text(rows))
    side = side_by_side_text(rows)
    if side:
        print()
        print(side)
