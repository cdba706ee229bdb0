"""Wall time of the leave-one-out sweep on the heights recordings with 1 process and with every
core, and the speed-up; also the studio's refit of the default workspace (the settings chosen
from its demonstrations, timed against its 1 s budget; the choice alone,
``promp.selection.choose_settings``; and the fit with the settings given).

The sweep is ``python -m promp.evaluate ../shared/data/lab-records-heights --format records
--percent 20 40 60 80 --alpha ml``, run in-process through :func:`promp.evaluate.sweep.run_sweep`
with ``jobs=1`` then ``jobs=-1``; the two results are checked identical. Both runs are measured
in this one process, so their ratio does not depend on how fast this machine is.

The default workspace is the studio's: ``generate_scenario(seed=0, n_demos=20)`` (2 primitives x
20 demonstrations, hand + head). ``--refit-only`` skips the sweeps.

Run: ``.venv/bin/python bench/evaluate.py [--data DIR] [--refit-only]``. The last line is one
JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from promp.datasets import read_dataset  # noqa: E402
from promp.evaluate.methods import ProMPEngine  # noqa: E402
from promp.evaluate.sweep import run_sweep  # noqa: E402
from promp.learn import fit  # noqa: E402
from promp.model import Settings, sample_period_of  # noqa: E402
from promp.selection import choose_settings  # noqa: E402
from robots.icub.layout import STUDIO_LAYOUT  # noqa: E402
from robots.icub.scenario import generate_scenario  # noqa: E402


def sweep_seconds(dataset, layout, jobs: int) -> tuple[float, list[dict]]:
    start = time.perf_counter()
    result = run_sweep(
        lambda: ProMPEngine(layout, Settings()), dataset, layout, [20, 40, 60, 80], ["ml"],
        [["hand"]], "ours", jobs=jobs,
    )  # fmt: skip
    return time.perf_counter() - start, result.rows


def refit_ms(settings: dict | None = None, repeats: int = 7) -> tuple[float, dict]:
    """Median time of the studio's refit of its default workspace (automatic settings, or
    ``settings``), and what the fit chose."""
    data = generate_scenario(seed=0, n_demos=20)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        model = fit(data, STUDIO_LAYOUT, Settings(**(settings or {})))
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times), model.report["settings"]


def choice_ms(repeats: int = 7) -> float:
    """Median time of the choice of settings alone on the default workspace (what the studio
    can run in the background, refitting at once with its previous choice)."""
    data = generate_scenario(seed=0, n_demos=20)
    dt = sample_period_of([d for demos in data.values() for d in demos])
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        choose_settings(data, STUDIO_LAYOUT, Settings(), dt)
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--data", type=Path, default=ROOT.parent / "shared/data/lab-records-heights"
    )
    parser.add_argument("--refit-only", action="store_true", help="skip the sweeps")
    args = parser.parse_args()
    cores = os.cpu_count() or 1
    out: dict = {"cores": cores}
    if not args.refit_only:
        read = read_dataset(args.data, "records")
        dataset, layout = read.dataset, read.layout
        one, rows_one = sweep_seconds(dataset, layout, 1)
        print(f"heights sweep, 1 process: {one:6.1f} s", flush=True)
        every, rows_all = sweep_seconds(dataset, layout, -1)
        print(f"heights sweep, {cores} processes: {every:6.1f} s", flush=True)
        identical = json.dumps(rows_one) == json.dumps(rows_all)
        print(f"speed-up {one / every:.2f}x on {cores} cores; identical results: {identical}")
        out.update(
            sweep_1_job_s=round(one, 2),
            sweep_all_jobs_s=round(every, 2),
            speedup=round(one / every, 3),
            identical=identical,
        )
    refit, choice = refit_ms()
    print(f"refit of the default workspace (automatic settings): {refit:.0f} ms "
          f"({refit / 1000:.2f} of the 1 s budget); chose {choice['chosen']}")  # fmt: skip
    chosen = choice_ms()
    print(f"the choice of settings alone (choose_settings): {chosen:.0f} ms")
    fixed, _ = refit_ms({"n_basis": 7, "width": 1.0, "noise_scale": 1.5})
    print(f"refit with the settings given (M = 7, width 1, noise x1.5): {fixed:.0f} ms")
    out.update(
        refit_default_workspace_ms=round(refit, 1),
        choose_settings_ms=round(chosen, 1),
        refit_given_settings_ms=round(fixed, 1),
        refit_budget_fraction=round(refit / 1000, 3),
        blas_threads=os.environ.get("OPENBLAS_NUM_THREADS", "default"),
    )
    print(json.dumps(out))


if __name__ == "__main__":
    main()
