"""``python -m promp.evaluate.compare RUN_A RUN_B``: two kept runs side by side.

Prints, per observed modalities, alpha method and percentage, the errors, the log-loss (and its
difference), the position error (cm) and the duration error of A then B; ``--csv OUT`` writes
every compared value (:func:`promp.evaluate.runs.compare_runs`). Exit 2 with a message when a
folder is not a run.
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Sequence
from pathlib import Path

from promp.evaluate.runs import compare_runs, comparison_text, read_run

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_a", type=Path, help="a run folder (--run DIR, or the studio's)")
    parser.add_argument("run_b", type=Path)
    parser.add_argument("--csv", type=Path, default=None, help="write the comparison here")
    args = parser.parse_args(argv)
    try:
        a, b = read_run(args.run_a), read_run(args.run_b)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    rows = compare_runs(a, b)
    print(comparison_text(a, b, rows))
    if args.csv is not None:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        with open(args.csv, "w", newline="", encoding="utf-8") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]) if rows else ["observed"])
            writer.writeheader()
            writer.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
