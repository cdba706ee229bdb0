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
from collections.abc import Mapping, Sequence

from promp.data import Demonstration, Layout
from promp.evaluate.sweep import SweepResult
from promp.model import Settings

# One CSV row per result row: what it is, then every metric of the JSON's ``results``.
CSV_COLUMNS = (
    "method", "alpha_method", "observed", "percent", "recognition_errors", "trials",
    "log_loss", "confident_mistakes", "worst_log_loss", "position_error_m", "goal_error_m",
    "duration_error_s", "nrmse_prior", "nrmse_posterior", "failed",
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
    }


def results_report(
    result: SweepResult,
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    *,
    source: str,
    data_format: str,
    method: str,
    observe: Sequence[Sequence[str]],
    percents: Sequence[float],
    alpha_methods: Sequence[str],
    basis: Mapping,
    subset: int | None = None,
) -> dict:
    """The report of one sweep (what ``--json`` writes).

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
    method, observe, percents, alpha_methods
        The sweep's arguments.
    basis : mapping
        The learning settings, as :func:`basis_settings` writes them.
    subset : int or None
        Demonstrations held out per primitive (None: every one).

    Returns
    -------
    dict
        ``dataset``, ``settings``, ``primitives``, ``results`` (the rows) and ``failures``.
    """
    return {
        "dataset": str(source),
        "settings": {
            "format": data_format,
            "method": method,
            "modalities": {m.name: list(m.columns) for m in layout.modalities},
            "observe": [list(names) for names in observe],
            "percents": [float(p) for p in percents],
            "alpha": list(alpha_methods),
            "basis": dict(basis),
            "demonstrations": {name: len(demos) for name, demos in dataset.items()},
            "subset": subset,
        },
        "primitives": list(dataset),
        "results": result.rows,
        "failures": result.failures,
    }


def report_json(report: Mapping) -> str:
    """The report as the ``--json`` file holds it."""
    return json.dumps(report, indent=1)


def results_csv(rows: Sequence[Mapping]) -> str:
    """The result table as CSV: a header of :data:`CSV_COLUMNS`, then one line per row
    (observed modalities joined by ``+``, the failed trials' ``primitive/demo`` by ``;``)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for row in rows:
        cells = dict(row, observed="+".join(row["observed"]), failed=";".join(row["failed"]))
        writer.writerow([cells[column] for column in CSV_COLUMNS])
    return out.getvalue()
