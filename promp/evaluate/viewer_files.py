"""``--rerun OUT.rrd`` and ``--mcap OUT.mcap``: the sweep's trials for Rerun, and for
Foxglove, PlotJuggler and ROS 2 tools (:mod:`promp.evaluate.viewer_trials`).

Both are checked before the sweep (a new file of the right suffix, the extra installed, whole
percents), so a long run never ends on a refusal; both are new files, never written over one.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence

from promp.data import Demonstration, Layout
from promp.evaluate.sweep import SweepResult
from promp.viewers.formats import write_viewer_file, writer_for
from promp.viewers.new_file import check_new
from promp.viewers.trial import whole_percents

__all__ = ["add_viewer_arguments", "check_viewer_arguments", "write_viewer_files"]


def add_viewer_arguments(parser: argparse.ArgumentParser) -> None:
    """``--rerun`` and ``--mcap``."""
    parser.add_argument(
        "--rerun",
        default=None,
        metavar="OUT.rrd",
        help="write every trial as a Rerun recording (a new file; the 'rerun' extra): each "
        "held-out demonstration at its own path, the observed part, the posterior region, the "
        "predicted path and end, and each primitive's probability, on an observed-percent "
        "timeline; open it with: rerun OUT.rrd",
    )
    parser.add_argument(
        "--mcap",
        default=None,
        metavar="OUT.mcap",
        help="write the same as MCAP with Foxglove's schemas, for Foxglove, PlotJuggler and "
        "ROS 2 tools (a new file; the 'mcap' extra)",
    )


def check_viewer_arguments(args: argparse.Namespace) -> None:
    """ValueError, before any work, for a viewer file that could not be written."""
    if args.rerun is None and args.mcap is None:
        return
    whole_percents(args.percent)
    for path, suffix in ((args.rerun, ".rrd"), (args.mcap, ".mcap")):
        if path is not None:
            check_new(path, suffix)
            writer_for(suffix)


def write_viewer_files(
    args: argparse.Namespace,
    result: SweepResult,
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
) -> bool:
    """Write ``--rerun`` and ``--mcap`` (when asked) and say so; False (the error printed)
    when one could not be written."""
    if args.rerun is None and args.mcap is None:
        return True
    from promp.evaluate.viewer_trials import trials_log

    try:
        log = trials_log(result, dataset, layout, name="promp-evaluate")
        if args.rerun is not None:
            path = write_viewer_file(log, args.rerun, ".rrd")
            print(f"Rerun recording: {path} (open it: rerun {path})")
        if args.mcap is not None:
            path = write_viewer_file(log, args.mcap, ".mcap")
            print(f"MCAP file: {path} (Foxglove, PlotJuggler)")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return False
    return True
