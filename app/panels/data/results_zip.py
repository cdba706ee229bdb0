"""The evaluation's results as one zip (the Data tab's "Export results"): what
``python -m promp.evaluate --json results.json --csv results.csv --plots figures`` writes for
the same run, built in memory by the command line's own writers
(:mod:`promp.evaluate.report`, :func:`promp.evaluate.plots.write_figures`). Pure: no viser.

::

    results.json        the report: settings, primitives, result rows, failures, every trial,
                        the checks' findings and what was left out
    results.csv         the result table, one line per row
    trials.csv          one line per trial (as --trials-csv writes it)
    decisions.csv       when each method would act, if the evaluation judged it (as
                        --decisions-csv writes it: the held-out headline, the in-sample curve)
    figures/*.png       curves, reliability diagram, the confusion matrices (one figure per
                        observed modality set and alpha method, a panel per percentage; the
                        counts are results.json's "confusion"), one example per modality set
"""

from __future__ import annotations

import io
import re
import tempfile
import zipfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from app.io.exchange import export_filename
from promp.data import Demonstration, Layout
from promp.evaluate.decisions import decisions_csv, decisions_of
from promp.evaluate.plots import figures_unavailable, write_figures
from promp.evaluate.report import every_row, every_trial, report_json, results_csv, trials_csv
from promp.evaluate.sweep import SweepResult

JSON_NAME, CSV_NAME, TRIALS_NAME, FIGURES = "results.json", "results.csv", "trials.csv", "figures"
DECISIONS_NAME = "decisions.csv"


def results_zip(
    report: Mapping,
    result: SweepResult,
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    figures: Callable[[], Mapping[str, bytes]] | None = None,
) -> bytes:
    """The zip of one finished sweep (see the module docstring).

    Parameters
    ----------
    report : mapping
        The sweep's report (:func:`promp.evaluate.report.results_report`); its rows make the
        CSV and its ``settings.method`` names the figures.
    result : SweepResult
        The sweep, with its trials kept (the figures need them).
    dataset : mapping of str to list of Demonstration
        What was swept (the example figures draw the true demonstration).
    layout : Layout
    figures : callable, optional
        The sweep's figures, drawn once for all who want them
        (:meth:`app.panels.data.evaluation.EvaluationJob.figures`: PNG bytes by file name);
        by default drawn here (:func:`drawn_figures`).
    """
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr(JSON_NAME, report_json(report))
        archive.writestr(CSV_NAME, results_csv(every_row(report)))
        archive.writestr(TRIALS_NAME, trials_csv(every_trial(report)))
        decisions = decisions_of(report)
        if decisions is not None:
            archive.writestr(DECISIONS_NAME, decisions_csv(decisions.rows, decisions.curve))
        if not figures_unavailable():  # else the tables go alone: the export says why
            drawn = figures() if figures is not None else drawn_figures(report, result, dataset,
                                                                        layout)  # fmt: skip
            for name, png in drawn.items():
                archive.writestr(f"{FIGURES}/{name}", png, compress_type=zipfile.ZIP_STORED)
    return buffer.getvalue()


def drawn_figures(
    report: Mapping,
    result: SweepResult,
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
) -> dict[str, bytes]:
    """:func:`draw_figures` in a temporary folder: the PNGs' bytes by file name, in the order
    drawn."""
    with tempfile.TemporaryDirectory(prefix="evaluation-figures-") as folder:
        paths = draw_figures(Path(folder), report, result, dataset, layout)
        return {path.name: path.read_bytes() for path in paths}


def draw_figures(
    folder: Path,
    report: Mapping,
    result: SweepResult,
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
) -> list[Path]:
    """The figures of ``python -m promp.evaluate --plots`` in ``folder`` (curves, reliability,
    a confusion matrix per percentage for each series, examples, and when each method would
    act if the report judged it); their paths. Drawings run at once, none waits for another
    (an export while a run is kept): each figure is its drawer's own, not pyplot's."""
    return write_figures(Path(folder), result, dataset, layout, report["settings"]["method"],
                         decisions_of(report))  # fmt: skip


def results_filename(workspace: str, when: float | None = None) -> str:
    """``evaluation-<workspace>-YYYYmmdd-HHMMSS.zip``, the workspace's folder name reduced to
    letters, digits, ``_``, ``-`` and ``.`` (at most 40)."""
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", workspace).strip("._-")[:40] or "workspace"
    return export_filename(f"evaluation-{slug}", "zip", when)
