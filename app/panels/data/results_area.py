"""The evaluation folder's results area: the rows of the evaluation that has just finished, or
of a saved run, as charts and a table under a title (:mod:`app.panels.data.results`); and
"Export results", which downloads the latest finished evaluation as the zip ``python -m
promp.evaluate --json --csv --plots`` would write (:mod:`app.panels.data.results_zip`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import viser

from app.io.exchange import format_size
from app.panels.data.decisions import add_decisions
from app.panels.data.evaluation import EvaluationJob
from app.panels.data.results import add_results, grouped_markdown, paired_markdown
from app.panels.data.results_zip import results_filename, results_zip
from promp.evaluate.decisions import Decisions
from promp.evaluate.paired import compare_methods
from promp.evaluate.plots import figures_unavailable

Notify = Callable[[viser.ClientHandle | None, str, str, str], None]


class ResultsArea:
    """The results shown, and the export of the evaluation they came from.

    Parameters
    ----------
    gui : viser.GuiApi
    folder : viser.GuiFolderHandle
        Where the results are shown (hidden while there are none).
    export_button : viser.GuiButtonHandle
        "Export results": enabled once an evaluation has finished with results.
    notify : callable
        ``notify(client, title, body, color)``.

    Attributes
    ----------
    handles : list
        What is shown, in order: the title (markdown), then the charts and the table.
    evaluation : EvaluationJob or None
        The latest finished evaluation shown: what Export sends.
    """

    def __init__(
        self,
        gui: viser.GuiApi,
        folder: viser.GuiFolderHandle,
        export_button: viser.GuiButtonHandle,
        notify: Notify,
    ) -> None:
        self.gui, self.folder, self.export_button, self.notify = gui, folder, export_button, notify
        self.handles: list = []
        self.evaluation: EvaluationJob | None = None
        export_button.on_click(lambda event: self.export(event.client))

    def show(
        self,
        title: str,
        rows: Sequence[Mapping],
        decisions: Decisions | None = None,
        paired: Sequence[Mapping] = (),
    ) -> None:
        """Show result ``rows`` (the sweep's, or a saved run's) under ``title`` (markdown), the
        first method against each other one on the same trials (``paired``:
        :func:`promp.evaluate.paired.compare_methods`), and when each method would act when it
        was judged (:mod:`app.panels.data.decisions`), in place of what was shown."""
        for handle in self.handles:
            handle.remove()
        with self.folder:
            self.handles = [self.gui.add_markdown(title), *add_results(self.gui, rows)]
            if paired:
                self.handles.append(self.gui.add_markdown(paired_markdown(paired)))
            self.handles += add_decisions(self.gui, decisions)
        self.folder.visible = True

    def show_evaluation(self, job: EvaluationJob) -> None:
        """Show the finished ``job``'s results (partial ones when it was cancelled), and its
        grouped comparison when it has one; Export sends them from now on."""
        result = job.outcome.result
        self.show(job.title(), result.rows, job.outcome.decisions, compare_methods(result.trials))
        if job.outcome.grouped is not None:
            with self.folder:
                self.handles.append(self.gui.add_markdown(grouped_markdown(job.outcome.grouped)))
        self.evaluation = job
        self.export_button.disabled = False

    def clear(self) -> None:
        """Nothing shown, nothing to export."""
        for handle in self.handles:
            handle.remove()
        self.handles, self.evaluation = [], None
        self.folder.visible = False
        self.export_button.disabled = True

    def export(self, client: viser.ClientHandle | None) -> bytes | None:
        """Send the latest finished evaluation to ``client`` as
        ``evaluation-<workspace>-<time>.zip`` (:mod:`app.panels.data.results_zip`); returns
        the bytes, or None when no evaluation has finished."""
        job = self.evaluation
        if job is None:
            self.notify(
                client,
                "No results to export",
                "Run a leave-one-out evaluation first; once it has finished, its results can "
                "be exported.",
                "yellow",
            )
            return None
        content = results_zip(job.report(), job.outcome.result, job.plan.dataset, job.plan.layout,
                              job.figures)  # drawn once, for its run kept and here  # fmt: skip
        filename = results_filename(Path(job.plan.source).name)
        if client is not None:
            client.send_file_download(filename, content, save_immediately=True)
        missing = figures_unavailable()
        self.notify(
            client,
            "Results exported",
            f"{filename} ({format_size(len(content))}): results.json, results.csv and "
            + (f"no figures: {missing}." if missing else "the figures."),
            "yellow" if missing else "blue",
        )
        return content
