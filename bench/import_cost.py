"""What ``import promp`` costs, beside numpy and SciPy alone and beside the whole API loaded.

``import promp`` limits the BLAS threads (which loads numpy and ``scipy.linalg``) and loads the
public API on first use (``promp/__init__.py``). Each statement runs in a fresh process, in
turns (so a busy moment of the machine falls on all of them alike), best of ``--repeats``:

* ``baseline``: ``import numpy, scipy.linalg, threadpoolctl``, what promp cannot avoid;
* ``promp``: ``import promp``;
* ``eager``: ``import promp`` and every public name touched (what an ``__init__`` importing
  the API at once would cost: the learning, inference, file, dataset and evaluation modules).

The goal: ``import promp`` costs about the baseline (``promp_over_baseline`` near 1), and the
whole API is not loaded by it (``eager_over_promp`` well above 1).

Run: ``.venv/bin/python bench/import_cost.py [--repeats N]``. The last line is one JSON object
(milliseconds, ratios).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STATEMENTS = {
    "baseline": "import numpy, scipy.linalg, threadpoolctl",
    "promp": "import promp",
    "eager": "import promp\nfor name in promp.__all__:\n    getattr(promp, name)",
}


def seconds(statement: str) -> float:
    """Seconds the statement takes in a fresh interpreter (its start-up excluded)."""
    code = (
        "import time\nstart = time.perf_counter()\n"
        + statement
        + "\nprint(time.perf_counter() - start)"
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    )
    return float(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    best = {name: float("inf") for name in STATEMENTS}
    for _ in range(args.repeats):
        for name, statement in STATEMENTS.items():
            best[name] = min(best[name], seconds(statement))
    out = {f"{name}_ms": round(1e3 * value, 1) for name, value in best.items()}
    out["promp_over_baseline"] = round(best["promp"] / best["baseline"], 3)
    out["eager_over_promp"] = round(best["eager"] / best["promp"], 3)
    out["load_average"] = [round(x, 2) for x in os.getloadavg()]
    for name, value in out.items():
        print(f"{name}: {value}")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
