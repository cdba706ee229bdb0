"""The Data tab's "Leave-one-out evaluation" folder: choose what is observed, the alpha method,
the percentages and the methods (ours, or ours beside the toolbox and both baselines), run the
sweep in the background (:class:`EvaluationJob`) with a progress bar and a Cancel button, then
show its results (:mod:`app.panels.data.results`).

Once an evaluation has finished, "Export results" downloads what ``python -m promp.evaluate
--json --csv --plots`` writes for the same run, as one zip (:mod:`app.panels.data.results_zip`),
and "Failed trials" lists the held-out demonstrations it did not recognise
(:mod:`app.panels.data.failed_trials`): "Open in Infer" shows the chosen one in the Infer tab,
held out, at the percentage it failed at (:meth:`app.ui.context.PanelContext.open_in_infer`).

The Run button's callback checks the choices and starts the job; :meth:`EvaluationSection.step`,
on the studio's loop, moves the progress bar and shows the outcome once the job has finished.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import viser

from app.core.snapshot import Snapshot
from app.io.exchange import format_size
from app.panels.data.evaluation import (
    ALPHA_CHOICES,
    METHOD_CHOICES,
    MIN_DEMOS,
    EvaluationJob,
    evaluation_dataset,
    observe_choices,
    parse_percents,
)
from app.panels.data.failed_trials import FailedTrial, failed_trials, trial_choices
from app.panels.data.results import add_results
from app.panels.data.results_zip import results_filename, results_zip
from app.ui.context import PanelContext
from app.ui.display import ALPHA_HINT
from app.ui.text import escape
from promp.evaluate.cli import DEFAULT_PERCENTS

Notify = Callable[[viser.ClientHandle | None, str, str, str], None]
FAILURES_LISTED = 10
TRIALS_LISTED = 200  # the Failed trials dropdown's options at most
NO_TRIAL = "(none)"
IDLE = f"Held out one demonstration at a time (primitives with at least {MIN_DEMOS})."


def running_text(job: EvaluationJob, now: float) -> str:
    """The status while it runs, e.g. "Running on lab: 5 / 12 held-out demonstrations · 0:35
    elapsed · about 0:49 left"."""
    return f"Running on {escape(Path(job.source).name)}: {job.progress_text(now)}."


@dataclass(frozen=True, eq=False)
class EvaluationControls:
    """The handles of the evaluation folder."""

    observe_dropdown: viser.GuiDropdownHandle
    alpha_dropdown: viser.GuiDropdownHandle
    percents_text: viser.GuiTextHandle
    run_button: viser.GuiButtonHandle
    cancel_button: viser.GuiButtonHandle
    progress_bar: viser.GuiProgressBarHandle
    eval_status: viser.GuiMarkdownHandle
    export_button: viser.GuiButtonHandle
    failed_dropdown: viser.GuiDropdownHandle
    open_button: viser.GuiButtonHandle
    results_folder: viser.GuiFolderHandle
    run_name_text: viser.GuiTextHandle  # the name the run is saved under (runs_section)
    methods_dropdown: viser.GuiDropdownHandle


class EvaluationSection:
    """The evaluation folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext, notify: Notify):
        self.ctx = ctx
        self.notify = notify
        self._job: EvaluationJob | None = None
        self._job_shown: EvaluationJob | None = None
        self._shown = (-1, 0.0)  # the count shown, and when the status was written
        self._root = ctx.store.state.workspace.root  # the workspace the results are of
        self._thread: threading.Thread | None = None
        self._result_handles: list = []
        self._results_job: EvaluationJob | None = None  # the latest evaluation with results
        self._failed: dict[str, FailedTrial] = {}
        self._layout = ctx.store.state.layout
        self._observe_choices = observe_choices(self._layout)
        gui = ctx.gui
        with gui.add_folder("Leave-one-out evaluation"):
            observe_dropdown = gui.add_dropdown("Observed", tuple(self._observe_choices))
            alpha_dropdown = gui.add_dropdown(
                "Alpha", tuple(ALPHA_CHOICES), initial_value="ML",
                hint=ALPHA_HINT + " Both: one curve for each.",
            )
            percents_text = gui.add_text(
                "Percents", " ".join(f"{p:g}" for p in DEFAULT_PERCENTS)
            )
            methods_dropdown = gui.add_dropdown(
                "Methods", tuple(METHOD_CHOICES), hint="ours alone, or beside the 2017 toolbox "
                "(seed) and two baselines on the same trials: open-end DTW and prefix nearest "
                "neighbour (dtw, prefix-nn), which only recognise (their position errors n/a)",
            )  # fmt: skip
            run_name_text = gui.add_text(
                "Run name", "", hint="The name the evaluation is kept under in the workspace's "
                "runs/ (Saved runs); empty: the observed modalities and the alpha method",
            )  # fmt: skip
            run_button = gui.add_button(
                "Run leave-one-out evaluation", icon=viser.Icon.PLAYER_PLAY
            )
            cancel_button = gui.add_button(
                "Cancel evaluation", icon=viser.Icon.X, color="red", visible=False
            )
            progress_bar = gui.add_progress_bar(0.0, visible=False, animated=True)
            eval_status = gui.add_markdown(IDLE)
            export_button = gui.add_button(
                "Export results", icon=viser.Icon.FILE_ZIP, disabled=True,
                hint="Download the finished evaluation as a zip: results.json, results.csv and "
                "the figures, as python -m promp.evaluate --json --csv --plots writes them",
            )  # fmt: skip
            failed_dropdown = gui.add_dropdown(
                "Failed trials", (NO_TRIAL,), visible=False,
                hint="Held-out demonstrations the evaluation did not recognise: demonstration "
                "· primitive · % observed → what it was recognised as",
            )  # fmt: skip
            open_button = gui.add_button(
                "Open in Infer", icon=viser.Icon.EYE, visible=False,
                hint="Show the chosen trial in the Infer tab: that demonstration held out, at "
                "that observed percentage, modalities and alpha method",
            )  # fmt: skip
            results_folder = gui.add_folder("Results", visible=False)
        self.controls = EvaluationControls(
            observe_dropdown, alpha_dropdown, percents_text, run_button, cancel_button,
            progress_bar, eval_status, export_button, failed_dropdown, open_button, results_folder,
            run_name_text, methods_dropdown,
        )  # fmt: skip
        self.controls.run_button.on_click(lambda event: self.start(event.client))
        self.controls.cancel_button.on_click(lambda _: self.cancel())
        self.controls.export_button.on_click(lambda event: self.export(event.client))
        self.controls.open_button.on_click(lambda event: self.open_in_infer(event.client))

    def start(self, client: viser.ClientHandle | None) -> EvaluationJob | None:
        """Start the sweep in a background thread with the GUI's options (None if refused)."""
        if self._job is not None and not self._job.finished:
            return None
        try:
            percents = parse_percents(self.controls.percents_text.value)
        except ValueError as exc:
            self.notify(client, "Cannot evaluate", f"{exc}.", "red")
            return None
        store = self.ctx.store.state
        dataset, skipped = evaluation_dataset(store.names, store.learned)
        findings, left_out = store.findings, store.left_out
        settings, layout = store.learning_settings(), store.layout
        observe = self._observe_choices.get(self.controls.observe_dropdown.value)
        if observe is None or any(n not in layout.names for names in observe for n in names):
            self.notify(client, "Cannot evaluate", "choose the observed modalities.", "red")
            return None
        if not dataset:
            counts = ", ".join(f"{n}: {c}" for n, c in skipped.items()) or "no primitives"
            self.notify(
                client,
                "Cannot evaluate",
                f"leave-one-out needs a primitive with at least {MIN_DEMOS} demonstrations "
                f"({counts}).",
                "red",
            )
            return None
        job = EvaluationJob(
            dataset=dataset,
            skipped=skipped,
            percents=percents,
            observe_sets=[list(s) for s in observe],
            alpha_methods=list(ALPHA_CHOICES[self.controls.alpha_dropdown.value]),
            settings=settings,
            layout=layout,
            source=str(store.workspace.root),
            total=sum(len(v) for v in dataset.values()),
            findings=findings,
            left_out=left_out,
            methods=list(METHOD_CHOICES.get(self.controls.methods_dropdown.value, ["ours"])),
        )
        self._job = job
        self.controls.run_button.disabled = True
        self.controls.cancel_button.visible = True
        self.controls.progress_bar.value = 0.0
        self.controls.progress_bar.animated = True
        self.controls.progress_bar.visible = True
        self.controls.eval_status.content = running_text(job, time.monotonic())
        self._thread = threading.Thread(target=job.run, name="data-evaluation", daemon=True)
        self._thread.start()
        return job

    def cancel(self) -> None:
        if self._job is not None:
            self._job.cancel.set()

    @property
    def job(self) -> EvaluationJob | None:
        """The latest evaluation started (running or finished)."""
        return self._job

    def show_results(self, rows, title: str) -> None:
        """Show a saved run's result ``rows`` in the results area, under ``title`` (markdown)."""
        for handle in self._result_handles:
            handle.remove()
        with self.controls.results_folder:
            self._result_handles = [self.ctx.gui.add_markdown(title),
                                    *add_results(self.ctx.gui, rows)]  # fmt: skip
        self.controls.results_folder.visible = True

    # ------------------------------------------------------------------ the loop

    def step(self, snapshot: Snapshot) -> None:
        layout = snapshot.store.layout
        if layout != self._layout:  # another workspace: its modalities
            self._layout, self._observe_choices = layout, observe_choices(layout)
            self.controls.observe_dropdown.options = tuple(self._observe_choices)
        root = snapshot.store.workspace.root
        if root != self._root:  # another workspace: nothing of the previous one's stays
            self._root = root
            self.cancel()
            self._clear_results()
        if self._job is not None:
            self._show(self._job)

    def _show(self, job: EvaluationJob) -> None:
        """Progress while it runs; results, status and buttons when it has finished."""
        now = time.monotonic()
        if job.done != self._shown[0] or (not job.finished and now - self._shown[1] >= 1.0):
            self._shown = (job.done, now)
            self.controls.progress_bar.value = 100.0 * job.done / max(job.total, 1)
            if not job.finished:  # the counts, and the clock every second
                self.controls.eval_status.content = running_text(job, now)
        if not job.finished or self._job_shown is job:
            return
        self._job_shown = job
        self.controls.run_button.disabled = False
        self.controls.cancel_button.visible = False
        self.controls.progress_bar.animated = False
        if job.source != str(self._root):  # it ended after the workspace changed
            self.controls.eval_status.content = "Evaluation cancelled: the workspace changed."
            self.controls.progress_bar.visible = False
            return
        if job.cancelled and (job.result is None or not job.result.rows):
            self.controls.eval_status.content = "Evaluation cancelled."
            self.controls.progress_bar.visible = False
            return
        if job.error is not None or job.result is None:
            self.controls.eval_status.content = f"Evaluation failed: {escape(str(job.error))}"
            self.controls.progress_bar.visible = False
            self.notify(None, "Evaluation failed", str(job.error), "red")
            return
        self.controls.eval_status.content = (
            f"**Cancelled** after {job.done} of {job.total} held-out demonstrations "
            f"({job.elapsed_s:.1f} s): the results below are partial."
            if job.cancelled
            else summary(job)
        )
        for handle in self._result_handles:
            handle.remove()
        with self.controls.results_folder:
            self._result_handles = [self.ctx.gui.add_markdown(job.title()),
                                    *add_results(self.ctx.gui, job.result.rows)]  # fmt: skip
        self.controls.results_folder.visible = bool(self._result_handles)
        self._results_job = job
        self.controls.export_button.disabled = False
        self._list_failed(job)
        done = "Evaluation cancelled: partial results" if job.cancelled else "Evaluation done"
        self.notify(None, done, f"{job.done} of {job.total} held-out demonstrations, "
                    f"{job.elapsed_s:.1f} s.")  # fmt: skip

    def _clear_results(self) -> None:
        """Nothing of an evaluation stays shown: its results, failed trials and export."""
        for handle in self._result_handles:
            handle.remove()
        self._result_handles, self._results_job, self._failed = [], None, {}
        c = self.controls
        c.results_folder.visible = c.failed_dropdown.visible = c.open_button.visible = False
        c.progress_bar.visible = False
        c.export_button.disabled = True
        c.eval_status.content = IDLE

    def _list_failed(self, job: EvaluationJob) -> None:
        trials = failed_trials(job.result, job.dataset)
        self._failed = trial_choices(trials[:TRIALS_LISTED])
        shown = f"first {TRIALS_LISTED} of " if len(trials) > TRIALS_LISTED else ""
        self.controls.failed_dropdown.label = f"Failed trials ({shown}{len(trials)})"
        self.controls.failed_dropdown.options = tuple(self._failed) or (NO_TRIAL,)
        self.controls.failed_dropdown.visible = True
        self.controls.open_button.visible = True
        self.controls.open_button.disabled = not self._failed

    # ------------------------------------------------------------------ the results

    def export(self, client: viser.ClientHandle | None) -> bytes | None:
        """Send the latest finished evaluation to ``client`` as
        ``evaluation-<workspace>-<time>.zip`` (:mod:`app.panels.data.results_zip`); returns
        the bytes, or None when no evaluation has finished."""
        job = self._results_job
        if job is None:
            self.notify(
                client,
                "No results to export",
                "Run a leave-one-out evaluation first; once it has finished, its results can "
                "be exported.",
                "yellow",
            )
            return None
        content = results_zip(job.report(), job.result, job.dataset, job.layout)
        filename = results_filename(Path(job.source).name)
        if client is not None:
            client.send_file_download(filename, content, save_immediately=True)
        self.notify(
            client,
            "Results exported",
            f"{filename} ({format_size(len(content))}): results.json, results.csv and the "
            "figures.",
            "blue",
        )
        return content

    def open_in_infer(self, client: viser.ClientHandle | None) -> FailedTrial | None:
        """Ask the studio to show the chosen failed trial in the Infer tab."""
        trial = self._failed.get(self.controls.failed_dropdown.value)
        if trial is None:
            self.notify(
                client, "No failed trial", "The evaluation recognised every trial.", "yellow"
            )
            return None
        self.ctx.open_in_infer(trial.request, client)
        return trial

    def close(self) -> None:
        self.cancel()
        if self._thread is not None:
            self._thread.join(timeout=10.0)


def summary(job: EvaluationJob) -> str:
    """What a finished evaluation did (markdown): how many were held out, in how long, what
    was skipped, left out, or failed."""
    skipped = (
        " Skipped (fewer than 3 demonstrations): "
        + ", ".join(f"{n} ({c})" for n, c in job.skipped.items())
        + "."
        if job.skipped
        else ""
    )
    left_out = (
        f" Left out (flagged, not kept in Teach): {len(job.left_out)} demonstration(s): "
        + escape(", ".join(f"{p}/{d}" for p, d in job.left_out))
        + "."
        if job.left_out
        else ""
    )
    failed = ""
    failures = job.result.failures
    if failures:
        named = len(job.methods) > 1  # which method failed
        listed = "; ".join(
            (f"{f['method']}: " if named else "")
            + f"{f['primitive']}/{f['demo']} at {f['percent']:g} % ({f['error']})"
            for f in failures[:FAILURES_LISTED]
        )
        more = len(failures) - FAILURES_LISTED
        failed = (
            f"  \n**{len(failures)} trial(s) failed** (counted as recognition "
            f"errors): {escape(listed)}" + (f"; and {more} more" if more > 0 else "")
        )
    settings = job.settings
    how = (
        "settings chosen from the training demonstrations in every fold"
        if settings.automatic
        else f"n_basis {settings.n_basis}, width {settings.width:g}"
    )
    return (
        f"Held out each of {job.total} demonstrations of {', '.join(job.dataset)} in "
        f"{job.elapsed_s:.1f} s ({how}).{skipped}{left_out}{failed}"
    )
