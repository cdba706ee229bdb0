"""What the automatic settings cost beside the settings given, and what they are worth.

One run, this machine, ratios beside the times:

1. **The sweep**: ``python -m promp.evaluate ../shared/data/lab-records-heights --format records
   --percent 20 40 60 80`` (leave-one-out, ML and model alpha, every core) with the automatic
   settings (the default: the closed-form leave-one-out rule, ``--select loo``) and with the
   settings given (``--basis 7 --width 1 --noise-scale 1.5``); with ``--cv`` also the inner
   cross-validation (``--select cv``). Run through the command line's own ``main``.
2. **The 24 cells**: the three shared sets x 20/40/60/80 % x ML/model alpha with the automatic
   settings: recognition errors summed, the 40 % ML errors summed, and every cell's log-loss;
   with ``--cv`` the same cells of the inner cross-validation beside them (the rule it
   replaces), each cell's log-loss difference, and whether every target holds.
3. **The studio's refit** of its default workspace (``generate_scenario(seed=0, n_demos=20)``,
   2 primitives x 20 demonstrations, hand + head), median of several:

   * *cold*: fresh copies of the demonstrations every time (nothing computed before), the
     automatic settings against the settings given;
   * *one demonstration added*: what the studio does after a take: the previous fit (without
     that demonstration) is known, every demonstration's statistics too, and the refit
     starts from the previous choice (``promp.learn.fit(..., previous=...)``); automatic
     against given, each demonstration in turn the one added.

The sweeps run through the command line's ``main`` in this process, after one untimed run of the
heights sweep with the settings given: the evaluation's worker processes are started (and
their imports done) before anything is timed, so neither side pays for them (the first run
did; it was the automatic one, ~1 s of its 9.5). ``--end-to-end N`` also times the heights
sweep as a user runs it, ``python -m promp.evaluate ...`` in a new process each time (the
interpreter, the imports and the workers' start included), the settings given and the
automatic ones alternated N times (given first in odd rounds, automatic first in even ones):
the medians and their ratio (``e2e_*``).

``--speedup`` also times the sweep with the settings given on one process against every
core (results checked identical). ``--refit-only`` skips 1 and 2.

Run: ``.venv/bin/python bench/evaluate.py [--cv] [--speedup] [--refit-only] [--end-to-end
N]``. The last line is one JSON object (times in s or ms, ratios, the 24-cell error sums).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.faults import evaluate as run_cli  # noqa: E402
from promp.learn import fit  # noqa: E402
from promp.model import Settings  # noqa: E402
from robots.icub.layout import STUDIO_LAYOUT  # noqa: E402
from robots.icub.scenario import generate_scenario  # noqa: E402

SHARED = ROOT.parent / "shared" / "data"
SETS = ("heights", "flt", "flt-shapes")
PERCENTS = ("20", "40", "60", "80")
GIVEN = ["--basis", "7", "--width", "1", "--noise-scale", "1.5", "--duration-temperature", "0.25",
         "--recognition", "promp"]
GIVEN_SETTINGS = {"n_basis": 7, "width": 1.0, "noise_scale": 1.5, "duration_temperature": 0.25,
                  "recognition": "promp"}
# The accuracy targets, against the rule replaced (same run): errors summed no more,
# every cell's log-loss within +0.05, the 40 % ML errors summed no more than 41.
LOG_LOSS_SLACK = 0.05
ML40_LIMIT = 41


def sweep(name: str, extra: list[str], out: Path, jobs: str = "-1") -> tuple[dict, float]:
    """``python -m promp.evaluate`` on a shared set: (its JSON report, seconds)."""
    common = ["--percent", *PERCENTS, "--jobs", jobs]
    return run_cli(SHARED / f"lab-records-{name}", extra, common, out)


def cells(reports: dict[str, dict]) -> dict[str, dict]:
    """{"set alpha percent": {"errors", "log_loss"}} of the sets' reports."""
    out = {}
    for name, report in reports.items():
        for row in report["results"]:
            key = f"{name} {row['alpha_method']} {row['percent']:g}"
            out[key] = {"errors": row["recognition_errors"], "log_loss": row["log_loss"]}
    return out


def end_to_end(rounds: int) -> dict:
    """The heights sweep as a user runs it, each run a new process: median seconds of the
    automatic and the given settings, alternated, and their ratio."""
    times: dict[str, list[float]] = {"auto": [], "given": []}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(rounds):
            order = ("given", "auto") if r % 2 == 0 else ("auto", "given")
            for side in order:
                args = [sys.executable, "-m", "promp.evaluate",
                        str(SHARED / "lab-records-heights"), "--format", "records",
                        "--percent", *PERCENTS, "--jobs", "-1",
                        "--json", str(Path(tmp) / f"{side}.json"),
                        *(GIVEN if side == "given" else [])]  # fmt: skip
                start = time.perf_counter()
                subprocess.run(args, cwd=ROOT, check=True, capture_output=True)
                times[side].append(time.perf_counter() - start)
                print(f"heights {side:5s} end to end {times[side][-1]:6.1f} s", flush=True)
    auto, given = statistics.median(times["auto"]), statistics.median(times["given"])
    return {"e2e_auto_s": [round(t, 2) for t in times["auto"]],
            "e2e_given_s": [round(t, 2) for t in times["given"]],
            "e2e_ratio": round(auto / given, 3)}  # fmt: skip


def totals(table: dict[str, dict]) -> tuple[int, int]:
    """(errors summed, 40 % ML errors summed)."""
    return (
        sum(c["errors"] for c in table.values()),
        sum(c["errors"] for k, c in table.items() if k.endswith(" ml 40")),
    )


def copies(data: dict) -> dict:
    """The same demonstrations as new objects: nothing computed for them is reused."""
    return {name: [dataclasses.replace(d) for d in demos] for name, demos in data.items()}


def refit_cold(settings: dict | None, repeats: int = 7) -> tuple[float, dict]:
    """Median ms of a fit of fresh copies of the default workspace, and what it chose."""
    data = generate_scenario(seed=0, n_demos=20)
    times = []
    for _ in range(repeats):
        fresh = copies(data)
        start = time.perf_counter()
        model = fit(fresh, STUDIO_LAYOUT, Settings(**(settings or {})))
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times), model.report["settings"]


def refit_added(settings: dict | None, repeats: int = 10) -> tuple[float, list[str]]:
    """Median ms of the studio's refit after one demonstration is added: the previous fit,
    without it, known (so is everything computed for the demonstrations it learned from), and
    the one added is a new object (a take: nothing is known about it); the rules the refits
    reported (kept or searched)."""
    data = copies(generate_scenario(seed=0, n_demos=20))
    names = list(data)
    times, rules = [], []
    for r in range(repeats):
        name = names[r % len(names)]
        j = (r // len(names)) % len(data[name])
        before = {k: [d for i, d in enumerate(v) if not (k == name and i == j)]
                  for k, v in data.items()}  # fmt: skip
        previous = fit(before, STUDIO_LAYOUT, Settings(**(settings or {}))).report["settings"]
        take = dataclasses.replace(data[name][j])
        after = {k: v + [take] if k == name else v for k, v in before.items()}
        start = time.perf_counter()
        model = fit(after, STUDIO_LAYOUT, Settings(**(settings or {})), previous=previous)
        times.append(time.perf_counter() - start)
        rules.append("kept" if model.report["settings"]["rule"].startswith("kept") else "searched")
    return 1e3 * statistics.median(times), rules


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cv", action="store_true", help="also the inner cross-validation")
    parser.add_argument("--speedup", action="store_true", help="also 1 process vs every core")
    parser.add_argument("--refit-only", action="store_true", help="skip the sweeps")
    parser.add_argument("--end-to-end", type=int, default=0, metavar="N",
                        help="also the heights sweep in new processes, N alternated rounds")
    args = parser.parse_args()
    out: dict = {"cores": os.cpu_count() or 1}
    if not args.refit_only:
        with tempfile.TemporaryDirectory() as tmp:
            reports: dict[str, dict[str, dict]] = {"loo": {}, "cv": {}}
            seconds: dict[str, dict[str, float]] = {"loo": {}, "cv": {}, "given": {}}
            sweep("heights", GIVEN, Path(tmp) / "warm.json")  # the workers started, untimed
            for name in SETS:
                rules = (("loo", []), ("cv", ["--select", "cv"])) if args.cv else (("loo", []),)
                for rule, extra in rules:
                    path = Path(tmp) / f"{name}-{rule}.json"
                    reports[rule][name], seconds[rule][name] = sweep(name, extra, path)
                    print(f"{name:10s} {rule:5s} {seconds[rule][name]:6.1f} s", flush=True)
                if name == "heights":
                    _, seconds["given"][name] = sweep(name, GIVEN, Path(tmp) / "given.json")
                    print(f"{name:10s} given {seconds['given'][name]:6.1f} s", flush=True)
            if args.speedup:
                one_report, one = sweep("heights", GIVEN, Path(tmp) / "one.json", jobs="1")
                every_report, every = sweep("heights", GIVEN, Path(tmp) / "all.json")
                same = json.dumps(one_report["results"]) == json.dumps(every_report["results"])
                print(f"heights given, 1 process {one:.1f} s, every core {every:.1f} s: "
                      f"{one / every:.2f}x, identical results: {same}")  # fmt: skip
                out.update(sweep_1_job_s=round(one, 2), sweep_all_jobs_s=round(every, 2),
                           speedup=round(one / every, 3), identical=same)  # fmt: skip
        if args.end_to_end:
            out.update(end_to_end(args.end_to_end))
            print(f"heights sweep end to end, medians of {args.end_to_end}: "
                  f"{out['e2e_ratio']:.2f}x (target <= 2x)")  # fmt: skip
        auto, given = seconds["loo"]["heights"], seconds["given"]["heights"]
        print(f"\nheights sweep (20-80 %, ML + model): automatic {auto:.1f} s, given "
              f"{given:.1f} s: {auto / given:.2f}x (target <= 2x)")  # fmt: skip
        out.update(sweep_auto_s=round(auto, 2), sweep_given_s=round(given, 2),
                   sweep_ratio=round(auto / given, 3))  # fmt: skip
        loo = cells(reports["loo"])
        errors, ml40 = totals(loo)
        out.update(errors_24=errors, errors_40_ml=ml40,
                   log_loss={k: round(c["log_loss"], 4) for k, c in loo.items()})  # fmt: skip
        print(f"24 cells, automatic (loo): {errors} errors, 40 % ML {ml40}")
        if args.cv:
            cv = cells(reports["cv"])
            errors_cv, ml40_cv = totals(cv)
            worst = max(loo[k]["log_loss"] - cv[k]["log_loss"] for k in loo)
            out.update(errors_24_cv=errors_cv, errors_40_ml_cv=ml40_cv,
                       sweep_cv_s=round(seconds["cv"]["heights"], 2),
                       worst_log_loss_increase=round(worst, 4))  # fmt: skip
            print(f"24 cells, inner cross-validation (cv): {errors_cv} errors, 40 % ML {ml40_cv};"
                  f" heights sweep {seconds['cv']['heights']:.1f} s")  # fmt: skip
            for key in loo:
                print(
                    f"  {key:22s} errors {loo[key]['errors']:3d} (cv {cv[key]['errors']:3d})"
                    f"  log-loss {loo[key]['log_loss']:.3f} (cv {cv[key]['log_loss']:.3f})"
                )
            verdicts = {
                "errors summed <= cv": errors <= errors_cv,
                f"every cell's log-loss <= cv + {LOG_LOSS_SLACK}": worst <= LOG_LOSS_SLACK,
                f"40 % ML errors summed <= {ML40_LIMIT}": ml40 <= ML40_LIMIT,
            }
            for what, ok in verdicts.items():
                print(f"  {'PASS' if ok else 'FAIL'}  {what}")
    cold, choice = refit_cold(None)
    cold_given, _ = refit_cold(GIVEN_SETTINGS)
    print(
        f"\nrefit of the default workspace, cold: automatic {cold:.0f} ms (chose "
        f"{choice['chosen']}), given {cold_given:.0f} ms: {cold / cold_given:.2f}x"
    )
    added, rules = refit_added(None)
    added_given, _ = refit_added(GIVEN_SETTINGS)
    kept = rules.count("kept")
    print(f"refit after one demonstration is added: automatic {added:.0f} ms ({kept} of "
          f"{len(rules)} kept the previous choice), given {added_given:.0f} ms: "
          f"{added / added_given:.2f}x (targets <= 150 ms, <= 3x)")  # fmt: skip
    out.update(
        refit_cold_ms=round(cold, 1),
        refit_cold_given_ms=round(cold_given, 1),
        refit_cold_ratio=round(cold / cold_given, 3),
        refit_added_ms=round(added, 1),
        refit_added_given_ms=round(added_given, 1),
        refit_added_ratio=round(added / added_given, 3),
        refits_kept=kept,
        blas_threads=os.environ.get("OPENBLAS_NUM_THREADS", "default"),
    )
    print(json.dumps(out))


if __name__ == "__main__":
    main()
