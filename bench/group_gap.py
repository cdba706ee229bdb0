"""Grouped against leave-one-out on a handover study recorded in sessions: where the warning of
``python -m promp.evaluate --group-by`` fires, and where it does not.

Two synthetic sets of :func:`tests.synthetic.handover_sessions` (a person's hand and 8 EMG
channels, three handovers, six sessions of five takes, each session recording one handover as
a study recorded in blocks does), written as CSV folders ``<handover>/session<s>/take<i>.csv``:

* **with a session effect**: each session's EMG baseline its own (up to 1 mV a channel, the
  electrodes placed anew), so within a session the baseline says which handover was recorded;
* **without**: the same study, the baselines all zero.

On each, the evaluation's own command line, the hand and the EMG observed, ML alpha, 20-80 %,
ours beside the toolbox and both baselines on the same folds, leave-one-out and grouped by
session (``--group-by folder``)::

    .venv/bin/python bench/group_gap.py [--seed 0] [--jobs 2] [--settings auto|given]

It prints both runs' tables (the grouped rows, both protocols side by side, the warnings); the
last line is one JSON object: each run's warnings, the modality each names, and its seconds.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from promp.datasets import write_csv_dataset  # noqa: E402
from promp.evaluate import cli  # noqa: E402
from tests.synthetic import EMG, HAND, handover_sessions  # noqa: E402

GIVEN = ["--basis", "7", "--width", "1", "--noise-scale", "1.5", "--recognition", "promp"]


def run(folder: Path, jobs: int, given: bool) -> tuple[str, dict, float]:
    """The evaluation's printed tables on ``folder``, its report and its seconds."""
    report = folder.with_suffix(".json")
    args = [str(folder), "--format", "csv", "--json", str(report),
            "--modality", f"hand={','.join(HAND.columns)}",
            "--modality", f"emg={','.join(EMG.columns)}",
            "--observe", "hand,emg", "--alpha", "ml", "--percent", "20", "40", "60", "80",
            "--method", "ours", "seed", "dtw", "prefix-nn", "--group-by", "folder",
            "--jobs", str(jobs), *(GIVEN if given else [])]  # fmt: skip
    out = io.StringIO()
    start = time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = cli.main(args)
    if code != 0:
        raise SystemExit(f"the evaluation failed on {folder} (exit {code})")
    return out.getvalue(), json.loads(report.read_text()), time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--settings", choices=("auto", "given"), default="auto")
    args = parser.parse_args()
    last = {}
    with tempfile.TemporaryDirectory(prefix="handover-sessions-") as tmp:
        for effect in (True, False):
            name = "with-sessions" if effect else "without"
            folder = Path(tmp) / name
            write_csv_dataset(folder, handover_sessions(seed=args.seed, session_effect=effect))
            text, report, seconds = run(folder, args.jobs, args.settings == "given")
            title = "with a session effect" if effect else "without a session effect"
            print(f"=== {title} (seed {args.seed}, {seconds:.0f} s)")
            print(text)
            grouped = report["grouped"]
            last[name] = {
                "warnings": len(grouped["warnings"]),
                "drivers": {d["method"]: d["modality"] for d in grouped["drivers"]},
                "seconds": round(seconds, 1),
            }
    print(json.dumps(last))


if __name__ == "__main__":
    main()
