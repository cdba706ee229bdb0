"""Evaluation runs kept as folders: what was run, on what, by which code, and what came out.

A run folder (the studio keeps them in its workspace's ``runs/``, the command line writes one
with ``--run DIR``)::

    <run>/run.json      format tag and version, the run's name, when it was made, the code
                        version, and the sweep's report (promp.evaluate.report.results_report:
                        settings, the demonstrations used and left out with the reasons, every
                        result row, every trial, the confusion matrices, the findings)
    <run>/results.csv   the result table, one line per (observed, alpha, percent)
    <run>/trials.csv    one line per trial
    <run>/decisions.csv with --decide: when each method would act (the held-out headline, then
                        the in-sample curve; promp.evaluate.decisions)
    <run>/figures/      curves, reliability, confusion matrices, examples (PNG)

A run is written into a folder that does not exist yet, built beside it and renamed into place,
so a run folder is complete or absent. :func:`read_run` refuses anything else with a
clear error; :func:`compare_runs` lays two runs side by side.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from promp.evaluate.decisions import decisions_csv
from promp.evaluate.report import results_csv, trials_csv

__all__ = [
    "code_version",
    "compare_decisions",
    "compare_runs",
    "COMPARED",
    "comparison_text",
    "DECIDED",
    "folder_name",
    "NAME",
    "read_run",
    "Run",
    "RUN_FILE",
    "RUN_FORMAT",
    "run_from_json",
    "RUN_VERSION",
    "write_new_folder",
    "write_run",
]

RUN_FORMAT = "icub-intention-studio/evaluation-run"
RUN_VERSION = 1
RUN_FILE = "run.json"
NAME = re.compile(r"[^A-Za-z0-9_-]+")
# What a comparison lists per row, with how each run's value is read.
COMPARED = (
    ("errors", lambda r: r["recognition_errors"]),
    ("trials", lambda r: r["trials"]),
    ("log_loss", lambda r: r["log_loss"]),
    ("position_error_m", lambda r: r["position_error_m"]),
    ("duration_error_s", lambda r: r["duration_error_s"]),
    ("duration_coverage", lambda r: r.get("duration_coverage", math.nan)),
)
# What a comparison lists of the runs' decisions (``--decide``), per method, observed, alpha.
DECIDED = ("harmonic_mean", "accuracy", "earliness", "never_committed", "threshold")


def code_version() -> str:
    """The package's version and, in a git checkout, the commit (``+dirty`` with changes)."""
    from importlib import metadata

    try:
        version = metadata.version("icub-intention-studio")
    except metadata.PackageNotFoundError:
        version = "unknown"
    root = Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
            capture_output=True, text=True, timeout=5, check=True,
        ).stdout.strip()  # fmt: skip
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True, text=True, timeout=5, check=True,
        ).stdout.strip()  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return version
    return f"{version} ({commit}{'+dirty' if dirty else ''})" if commit else version


def folder_name(name: str, created: _dt.datetime) -> str:
    """``<YYYYmmdd-HHMMSS>-<name>``, the name made safe for a file name."""
    safe = NAME.sub("_", name).strip("_-")[:40] or "run"
    return f"{created.strftime('%Y%m%d-%H%M%S')}-{safe}"


@dataclass(frozen=True)
class Run:
    """A run read back: its folder, name, time (ISO 8601), code version and report."""

    folder: Path
    name: str
    created: str
    code_version: str
    report: Mapping

    @property
    def label(self) -> str:
        return f"{self.name} ({self.created[:16].replace('T', ' ')})"


def write_run(
    folder: Path,
    report: Mapping,
    name: str,
    figures=None,
    created: _dt.datetime | None = None,
) -> Run:
    """Write a run folder at ``folder`` (which must not exist) and return it.

    ``figures``: a function of a folder that writes the run's figures there (e.g.
    :func:`promp.evaluate.plots.write_figures` bound to its sweep), or None.

    Raises
    ------
    ValueError
        ``folder`` exists (nothing is overwritten), or its parent cannot be written.
    """
    created = created or _dt.datetime.now(_dt.UTC).astimezone()
    meta = {
        "format": RUN_FORMAT, "version": RUN_VERSION, "name": name,
        "created": created.isoformat(timespec="seconds"), "code_version": code_version(),
        "report": dict(report),
    }  # fmt: skip

    def fill(staging: Path) -> None:
        (staging / RUN_FILE).write_text(json.dumps(meta, indent=1), encoding="utf-8")
        (staging / "results.csv").write_text(results_csv(report["results"]), encoding="utf-8")
        (staging / "trials.csv").write_text(trials_csv(report.get("trials", [])), "utf-8")
        if report.get("decisions"):  # --decide
            (staging / "decisions.csv").write_text(
                decisions_csv(report["decisions"], report.get("decision_curve", [])), "utf-8"
            )
        if figures is not None:
            figures(staging / "figures")

    write_new_folder(Path(folder), fill)
    return read_run(folder)


def write_new_folder(folder: Path, fill: Callable[[Path], None]) -> None:
    """Make the run folder ``folder`` (which must not exist) whole or not at all: ``fill``
    writes its files into a hidden sibling, which is synced, then renamed into place.

    Raises
    ------
    ValueError
        ``folder`` exists or appears meanwhile (nothing is overwritten), or its parent cannot
        be written.
    """
    if folder.exists() or folder.is_symlink():
        raise ValueError(f"{folder} already exists: a run is written to a new folder, nothing "
                         "is overwritten")  # fmt: skip
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f".{folder.name}."))
    except OSError as exc:
        raise ValueError(f"cannot write a run next to {folder}: {exc}") from exc
    try:
        fill(staging)
        for path in staging.rglob("*"):
            if path.is_file():
                with open(path, "rb") as handle:
                    os.fsync(handle.fileno())
        if folder.exists() or folder.is_symlink():  # made meanwhile: theirs, left alone
            raise ValueError(f"{folder} appeared while the run was written; nothing was "
                             "written there")  # fmt: skip
        os.rename(staging, folder)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)  # our own staging folder only
        raise


def read_run(folder: Path) -> Run:
    """Read a run folder.

    Raises
    ------
    ValueError
        No ``run.json``, not JSON, another format or version, or a report without results.
    """
    folder = Path(folder)
    path = folder / RUN_FILE
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ValueError(f"{folder} is not an evaluation run: it has no {RUN_FILE}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: cannot read as JSON ({exc})") from exc
    return run_from_json(text, folder, str(path))


def run_from_json(text: str, folder: Path, label: str) -> Run:
    """The run of ``folder`` whose ``run.json`` holds ``text`` (``label`` names it in errors);
    :func:`read_run` reads the file, a workspace archive its member.

    Raises
    ------
    ValueError
        Not JSON, another format or version, or a report without results.
    """
    try:
        data = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise ValueError(f"{label}: cannot read as JSON ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != RUN_FORMAT:
        raise ValueError(f"{label}: not an evaluation run (format {RUN_FORMAT!r} expected)")
    if data.get("version") != RUN_VERSION:
        raise ValueError(f"{label}: run version {data.get('version')!r}, expected {RUN_VERSION}")
    report = data.get("report")
    if not isinstance(report, dict) or not isinstance(report.get("results"), list):
        raise ValueError(f"{label}: the run has no result rows")
    return Run(folder, str(data.get("name", folder.name)), str(data.get("created", "")),
               str(data.get("code_version", "")), report)  # fmt: skip


def _key(row: Mapping) -> tuple:
    return (str(row.get("method", "")), "+".join(row["observed"]), row["alpha_method"],
            float(row["percent"]))  # fmt: skip


def compare_runs(a: Run, b: Run) -> list[dict]:
    """The two runs side by side, one row per (method, observed, alpha, percent) of either:
    every value of :data:`COMPARED` for ``a`` and ``b`` and ``b - a`` (NaN where a run lacks
    the row), ordered like the runs' tables (the methods in the order the runs hold them).

    A row of one run without its twin in the other is paired with the other's row at the same
    percentage that differs only in the alpha method, or else only in the observed modalities,
    or else only in the method, when exactly one does (two runs made with ML and with the
    model alpha compare row by row, as do a run of ``ours`` and one of ``dtw``);
    ``method_b``, ``observed_b`` and ``alpha_b`` name the row of ``b``."""
    rows_a = {_key(r): r for r in a.report["results"]}
    rows_b = {_key(r): r for r in b.report["results"]}
    pairs = [(k, k) for k in sorted(set(rows_a) & set(rows_b))]
    alone_a = sorted(set(rows_a) - set(rows_b))
    alone_b = sorted(set(rows_b) - set(rows_a))
    # the same method, modalities and %; else the same method, alpha and %; else all but the
    # method
    for same in ((0, 1, 3), (0, 2, 3), (1, 2, 3)):
        for ka in list(alone_a):
            twins = [kb for kb in alone_b if all(kb[i] == ka[i] for i in same)]
            mates = [k for k in alone_a if all(k[i] == ka[i] for i in same)]
            if len(twins) == 1 and len(mates) == 1:
                pairs.append((ka, twins[0]))
                alone_a.remove(ka)
                alone_b.remove(twins[0])
    pairs += [(k, None) for k in alone_a] + [(None, k) for k in alone_b]
    order = {m: i for i, m in enumerate(dict.fromkeys(k[0] for k in [*rows_a, *rows_b]))}
    out = []
    for ka, kb in sorted(pairs, key=lambda p: (order[(p[0] or p[1])[0]], (p[0] or p[1])[1:])):
        key = ka or kb
        row: dict = {"method": key[0], "observed": key[1], "alpha": key[2], "percent": key[3],
                     "method_b": (kb or key)[0], "observed_b": (kb or key)[1],
                     "alpha_b": (kb or key)[2]}  # fmt: skip
        for name, read in COMPARED:
            va = float(read(rows_a[ka])) if ka is not None else math.nan
            vb = float(read(rows_b[kb])) if kb is not None else math.nan
            row[f"{name}_a"], row[f"{name}_b"], row[f"{name}_diff"] = va, vb, vb - va
        out.append(row)
    return out


def compare_decisions(a: Run, b: Run) -> list[dict]:
    """The two runs' decisions (``--decide``, the report's ``decisions``) side by side: one
    row per (method, observed, alpha) of either, every value of :data:`DECIDED` for ``a``,
    ``b`` and ``b - a`` (NaN where a run has no such row, or no decisions at all), in the
    order of ``a``'s rows then ``b``'s."""

    def keyed(run: Run) -> dict[tuple, Mapping]:
        rows = run.report.get("decisions") or []
        return {(str(r["method"]), "+".join(r["observed"]), r["alpha_method"]): r for r in rows}

    rows_a, rows_b = keyed(a), keyed(b)
    out = []
    for key in dict.fromkeys([*rows_a, *rows_b]):
        row: dict = {"method": key[0], "observed": key[1], "alpha": key[2]}
        for name in DECIDED:
            va = float(rows_a[key][name]) if key in rows_a else math.nan
            vb = float(rows_b[key][name]) if key in rows_b else math.nan
            row[f"{name}_a"], row[f"{name}_b"], row[f"{name}_diff"] = va, vb, vb - va
        out.append(row)
    return out


def comparison_text(a: Run, b: Run, rows: Sequence[Mapping]) -> str:
    """:func:`compare_runs` as a table to read: errors, log-loss, position error (cm) and
    duration error of ``a`` -> ``b`` and the difference (``n/a`` for a value a method does
    not give, or a row a run does not have)."""
    lines = [f"A: {a.label}, {a.code_version}", f"B: {b.label}, {b.code_version}",
             f"{'method':10s} {'observed':14s} {'alpha':5s} {'%':>4s}  {'errors A->B':>13s}  "
             f"{'log-loss A->B (diff)':>24s}  {'pos cm A->B':>13s}  "
             f"{'dur s A->B':>12s}"]  # fmt: skip

    def pair(row, name, fmt, scale=1.0):
        va, vb = row[f"{name}_a"] * scale, row[f"{name}_b"] * scale
        return f"{_fmt(va, fmt)}->{_fmt(vb, fmt)}"

    for r in rows:
        method, observed, alpha = (
            r[k] if r[k] == r[f"{k}_b"] else f"{r[k]}>{r[f'{k}_b']}"
            for k in ("method", "observed", "alpha")
        )
        lines.append(
            f"{method:10s} {observed:14s} {alpha:5s} {r['percent']:4.0f}  "
            f"{pair(r, 'errors', 'd'):>13s}  "
            f"{pair(r, 'log_loss', '.3f'):>15s} ({_fmt(r['log_loss_diff'], '+.3f'):>6s})  "
            f"{pair(r, 'position_error_m', '.2f', 100.0):>13s}  "
            f"{pair(r, 'duration_error_s', '.2f'):>12s}"
        )
    decided = compare_decisions(a, b)
    if decided:
        lines += [
            "", "when the robot acts (--decide; each trial's threshold chosen without it)",
            f"{'method':10s} {'observed':14s} {'alpha':5s}  {'harmonic mean A->B':>18s}  "
            f"{'accuracy A->B':>13s}  {'earliness A->B':>14s}  {'never A->B':>11s}",
        ]  # fmt: skip
        for r in decided:
            lines.append(
                f"{r['method']:10s} {r['observed']:14s} {r['alpha']:5s}  "
                f"{pair(r, 'harmonic_mean', '.3f'):>18s}  "
                f"{pair(r, 'accuracy', '.0f', 100.0):>13s}  "
                f"{pair(r, 'earliness', '.0f', 100.0):>14s}  "
                f"{pair(r, 'never_committed', '.0f', 100.0):>11s}"
            )
    return "\n".join(lines)


def _fmt(value: float, fmt: str) -> str:
    if not math.isfinite(value):
        return "n/a"
    return format(int(round(value)), fmt) if fmt == "d" else format(value, fmt)
