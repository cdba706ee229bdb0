"""What a leave-one-out sweep writes: the JSON report and the CSV of its result table.

One implementation for every writer: ``python -m promp.evaluate --json/--csv`` and the
studio's "Export results" (Data tab) both build the report with :func:`results_report` and
serialise it with :func:`report_json` and :func:`results_csv`; the figures are
:func:`promp.evaluate.plots.write_figures`.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Mapping, Sequence

import numpy as np

from promp.data import Demonstration, Layout
from promp.evaluate.decisions import Decisions
from promp.evaluate.grouped import GroupedRun, grouped_json
from promp.evaluate.paired import compare_methods
from promp.evaluate.sweep import LEAVE_ONE_OUT, SweepResult
from promp.model import Settings
from promp.quality import Finding

__all__ = [
    "basis_settings",
    "confusion_matrices",
    "CSV_COLUMNS",
    "every_row",
    "every_trial",
    "report_json",
    "results_csv",
    "results_report",
    "TRIAL_COLUMNS",
    "trial_rows",
    "trials_csv",
]

# One CSV row per trial (``--trials-csv``, the JSON's ``trials``): which demonstration, at which
# setting, what the method said and how far off it was.
TRIAL_COLUMNS = (
    "method", "primitive", "demo", "percent", "alpha_method", "observed", "recognised", "p_true",
    "alpha", "duration_s", "duration_low_s", "duration_high_s", "position_error_m",
    "goal_error_m", "duration_error_s", "nrmse_prior", "nrmse_posterior", "error", "protocol",
    "group",
)  # fmt: skip
# One CSV row per result row: what it is, then every metric of the JSON's ``results``.
CSV_COLUMNS = (
    "method", "alpha_method", "observed", "percent", "recognition_errors", "trials",
    "log_loss", "confident_mistakes", "worst_log_loss", "position_error_m", "goal_error_m",
    "duration_error_s", "duration_coverage", "nrmse_prior", "nrmse_posterior", "failed",
    "protocol",
)  # fmt: skip


def basis_settings(settings: Settings) -> dict:
    """The learning settings as the report writes them: a number, or ``"auto"`` for one chosen
    from the training demonstrations by every fit."""

    def value(v):
        return "auto" if v is None else v

    return {
        "n_basis": value(settings.n_basis),
        "width": value(settings.width),
        "shrinkage": value(settings.shrinkage),
        "noise_scale": value(settings.noise_scale),
        "duration_temperature": value(settings.duration_temperature),
        "recognition": value(settings.recognition),
    }


def results_report(
    result: SweepResult,
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    *,
    source: str,
    data_format: str,
    method: str | Sequence[str],
    observe: Sequence[Sequence[str]],
    percents: Sequence[float],
    alpha_methods: Sequence[str],
    basis: Mapping,
    subset: int | None = None,
    choice_blocks: int | None = None,
    findings: Sequence[Finding] = (),
    excluded: Mapping[tuple[str, str], Sequence[Finding]] | None = None,
    decisions: Decisions | None = None,
    grouped: GroupedRun | None = None,
) -> dict:
    """The report of one sweep (what ``--json`` writes), and of its grouped sweep.

    Parameters
    ----------
    result : SweepResult
    dataset : mapping of str to list of Demonstration
        What was swept, by primitive (in the sweep's order).
    layout : Layout
    source : str
        Where the demonstrations came from (a dataset folder, a workspace).
    data_format : str
        How they were read (``records``, ``csv``; the studio writes ``workspace``).
    method : str or sequence of str
        The method, or the methods the sweep compared (in its order): ``settings.methods``
        lists them, ``settings.method`` names them joined by ``+`` (one method: its name).
    observe, percents, alpha_methods
        The sweep's arguments.
    basis : mapping
        The learning settings, as :func:`basis_settings` writes them.
    subset : int or None
        Demonstrations held out per primitive (None: every one).
    choice_blocks : int or None
        The blocks the automatic settings were chosen in (0: a choice per fold;
        :func:`promp.evaluate.sweep.run_sweep`).
    findings : sequence of Finding
        What the checks found in the demonstrations (:mod:`promp.quality`).
    excluded : mapping of (primitive, demo) to findings
        The demonstrations left out of the sweep (neither learned from nor tested), and why.
    decisions : Decisions, optional
        ``--decide``'s judgement of when each method would act
        (:func:`promp.evaluate.decisions.decide`): ``decisions`` (one row per method and
        observed set), ``decision_curve`` (in-sample) and ``decision_trials``, and
        ``settings.decide`` (the window and the observed steps).
    grouped : GroupedRun, optional
        The grouped sweep beside it (:func:`promp.evaluate.grouped.run_grouped`).

    Returns
    -------
    dict
        ``dataset``, ``settings``, ``primitives``, ``results`` (the rows), ``failures``,
        ``trials`` (one row per trial, :func:`trial_rows`; empty unless the sweep kept its
        trials), ``confusion`` (:func:`confusion_matrices`), ``paired`` (the first method
        against each other one on the same trials,
        :func:`promp.evaluate.paired.compare_methods`; empty with one method), ``used`` (the
        demonstrations swept, by primitive), ``findings`` and ``excluded``; with ``grouped``,
        ``grouped`` (:func:`promp.evaluate.grouped.grouped_json`, with its own ``trials``) and
        the settings' ``group_by``. Every trial names its group then.
    """
    excluded = excluded or {}
    methods = [method] if isinstance(method, str) else list(method)
    part = None if grouped is None else grouped_json(grouped, dataset)
    groups = None if part is None else part["groups"]
    trials = trial_rows(result, list(dataset), groups=groups)
    report = {
        "dataset": str(source),
        "settings": {
            "format": data_format,
            "method": "+".join(methods),
            "methods": methods,
            "modalities": {m.name: list(m.columns) for m in layout.modalities},
            "observe": [list(names) for names in observe],
            "percents": [float(p) for p in percents],
            "alpha": list(alpha_methods),
            "basis": dict(basis),
            "demonstrations": {name: len(demos) for name, demos in dataset.items()},
            "subset": subset,
            "choice_blocks": choice_blocks,
        },
        "primitives": list(dataset),
        "results": result.rows,
        "failures": result.failures,
        "trials": trials,
        "confusion": confusion_matrices(trials, list(dataset)),
        "paired": compare_methods(result.trials),
        "used": {name: [d.name for d in demos] for name, demos in dataset.items()},
        "chosen": result.chosen,
        "findings": [f.to_json() for f in findings],
        "excluded": [
            {
                "primitive": primitive,
                "demo": demo,
                "file": reasons[0].file if reasons else "",
                "reasons": [f.message for f in reasons],
            }
            for (primitive, demo), reasons in excluded.items()
        ],
    }
    if decisions is not None:
        steps = sorted({float(p) for path in result.paths for p in path.percents})
        report["settings"]["decide"] = {"window_s": decisions.window, "percents": steps}
        report["decisions"] = decisions.rows
        report["decision_curve"] = decisions.curve
        report["decision_trials"] = decisions.trials
    if part is not None:
        part["trials"] = trial_rows(grouped.result, list(dataset), part["protocol"], groups)
        report["settings"]["group_by"] = part["group_by"]
        report["grouped"] = part
    return report


def every_row(report: Mapping) -> list[dict]:
    """The report's result rows, then its grouped sweep's (each saying its ``protocol``):
    what the result CSV holds."""
    return list(report["results"]) + list(report.get("grouped", {}).get("results", []))


def every_trial(report: Mapping) -> list[dict]:
    """The report's trials, then its grouped sweep's: what the trials CSV holds."""
    return list(report.get("trials", [])) + list(report.get("grouped", {}).get("trials", []))


def trial_rows(
    result: SweepResult,
    primitives: Sequence[str],
    protocol: str = LEAVE_ONE_OUT,
    groups: Mapping[str, Sequence[str]] | None = None,
) -> list[dict]:
    """One row per kept trial of ``result`` (the columns of :data:`TRIAL_COLUMNS`), in the
    sweep's order: the method, the demonstration, the setting, the recognised primitive, the
    probability of the true one, alpha, the predicted duration and every error (NaN where the
    method failed, with ``error`` saying why), the sweep's ``protocol`` and the
    demonstration's group (``groups``: {group: its ``primitive/demo`` names}; "" without)."""
    group_of = {member: g for g, members in (groups or {}).items() for member in members}
    rows = []
    for t in result.trials:
        inferred = t.inferred
        rows.append(
            {
                "method": t.method,
                "primitive": primitives[t.primitive],
                "demo": t.demo,
                "percent": t.percent,
                "alpha_method": t.alpha_method,
                "observed": list(t.observed),
                "recognised": "" if inferred is None else primitives[inferred.index],
                "p_true": math.nan
                if inferred is None
                else float(inferred.probabilities[t.primitive]),
                "alpha": math.nan if inferred is None else float(inferred.alpha),
                "duration_s": math.nan if inferred is None else float(inferred.duration),
                "duration_low_s": math.nan if inferred is None else inferred.duration_low,
                "duration_high_s": math.nan if inferred is None else inferred.duration_high,
                "position_error_m": t.position_error_m,
                "goal_error_m": t.goal_error_m,
                "duration_error_s": t.duration_error_s,
                "nrmse_prior": t.nrmse_prior,
                "nrmse_posterior": t.nrmse_posterior,
                "error": t.error,
                "protocol": protocol,
                "group": group_of.get(f"{primitives[t.primitive]}/{t.demo}", ""),
            }
        )
    return rows


def confusion_matrices(trials: Sequence[Mapping], primitives: Sequence[str]) -> list[dict]:
    """The confusion matrix of every (method, observed modalities, alpha method, percent) of
    a report's ``trials`` (:func:`trial_rows`): ``counts[i][j]`` trials of primitive ``i``
    recognised as ``j``, and in a last column those the method failed on. JSON-ready, in the
    order of the methods (as the trials come), observed sets, alpha methods, then percents."""
    index = {name: i for i, name in enumerate(primitives)}
    groups: dict[tuple, np.ndarray] = {}
    order: dict[str, int] = {}
    for t in trials:
        method = str(t.get("method", ""))  # runs written before several methods: none
        order.setdefault(method, len(order))
        key = (method, tuple(t["observed"]), t["alpha_method"], float(t["percent"]))
        counts = groups.setdefault(key, np.zeros((len(primitives), len(primitives) + 1), int))
        recognised = index.get(t["recognised"], len(primitives))  # "" when it failed
        counts[index[t["primitive"]], recognised] += 1
    return [
        {
            "method": method, "observed": list(observed), "alpha": alpha, "percent": percent,
            "primitives": list(primitives), "counts": counts.tolist(),
        }
        for (method, observed, alpha, percent), counts in sorted(
            groups.items(), key=lambda item: (order[item[0][0]], len(item[0][1]), item[0][1:])
        )
    ]  # fmt: skip


def trials_csv(rows: Sequence[Mapping]) -> str:
    """The per-trial table as CSV: a header of :data:`TRIAL_COLUMNS`, one line per trial
    (observed modalities joined by ``+``)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(TRIAL_COLUMNS)
    for row in rows:
        cells = {"method": "", "protocol": LEAVE_ONE_OUT, "group": "", **row,
                 "observed": "+".join(row["observed"])}  # fmt: skip
        writer.writerow([cells[column] for column in TRIAL_COLUMNS])
    return out.getvalue()


def report_json(report: Mapping) -> str:
    """The report as the ``--json`` file holds it."""
    return json.dumps(report, indent=1)


def results_csv(rows: Sequence[Mapping]) -> str:
    """The result table as CSV: a header of :data:`CSV_COLUMNS`, then one line per row
    (observed modalities joined by ``+``, the failed trials' ``primitive/demo`` by ``;``; the
    protocol ``leave-one-out`` unless the row says otherwise)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for row in rows:
        cells = {"protocol": LEAVE_ONE_OUT, **row, "observed": "+".join(row["observed"]),
                 "failed": ";".join(row["failed"])}  # fmt: skip
        writer.writerow([cells[column] for column in CSV_COLUMNS])
    return out.getvalue()
