"""The command line's ``--decide``, ``--decide-window`` and ``--decisions-csv``: when each
method would act (:mod:`promp.evaluate.decisions`), judged on the sweep's trials observed
every 2 % (:data:`promp.evaluate.paths.DECISION_PERCENTS`)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path

from promp.decision import WINDOW_S
from promp.evaluate.decisions import Decisions, decide, decisions_csv, decisions_text
from promp.evaluate.paths import DECISION_PERCENTS
from promp.evaluate.sweep import SweepResult

__all__ = ["add_decide_arguments", "check_decide_arguments", "decide_percents", "judge",
           "print_decisions", "write_decisions_csv"]  # fmt: skip


def add_decide_arguments(parser: argparse.ArgumentParser) -> None:
    """``--decide``, ``--decide-window`` and ``--decisions-csv``."""
    parser.add_argument(
        "--decide",
        action="store_true",
        help="also judge when each method would act: every held-out demonstration observed "
        "every 2 %% by its fold's model, a rule committing once the leading primitive's "
        "probability has stayed above a threshold for --decide-window s; its earliness/"
        "accuracy curve over thresholds (in-sample) and the harmonic mean of accuracy and "
        "1 - earliness at the threshold chosen without the trial under test",
    )
    parser.add_argument(
        "--decide-window",
        type=float,
        default=WINDOW_S,
        metavar="S",
        help="the rule's confirmation window, seconds of the movement (with --decide)",
    )
    parser.add_argument(
        "--decisions-csv",
        type=Path,
        default=None,
        metavar="OUT.csv",
        help="write the decisions (held-out headline, then the in-sample curve) here "
        "(with --decide)",
    )


def check_decide_arguments(args: argparse.Namespace) -> None:
    """Refuse ``--decisions-csv`` without ``--decide`` and a window that is not seconds.

    Raises
    ------
    ValueError
        Saying which.
    """
    if not args.decide and args.decisions_csv is not None:
        raise ValueError("--decisions-csv needs --decide")
    if not (math.isfinite(args.decide_window) and args.decide_window >= 0):
        raise ValueError(f"--decide-window is seconds, at least 0, got {args.decide_window}")


def decide_percents(args: argparse.Namespace) -> tuple[float, ...]:
    """The sweep's ``decide_percents``: every 2 % with ``--decide``, none without."""
    return DECISION_PERCENTS if args.decide else ()


def judge(
    args: argparse.Namespace, result: SweepResult, primitives: Sequence[str]
) -> Decisions | None:
    """The decisions of the sweep (``--decide``), or None."""
    return decide(result.paths, list(primitives), args.decide_window) if args.decide else None


def print_decisions(decisions: Decisions | None) -> None:
    """The headline after the tables (nothing without ``--decide``)."""
    if decisions is not None:
        print()
        print(decisions_text(decisions.rows))


def write_decisions_csv(args: argparse.Namespace, decisions: Decisions | None) -> None:
    """``--decisions-csv``: the headline rows, then the in-sample curve."""
    if args.decisions_csv is not None and decisions is not None:
        args.decisions_csv.parent.mkdir(parents=True, exist_ok=True)
        args.decisions_csv.write_text(decisions_csv(decisions.rows, decisions.curve))
