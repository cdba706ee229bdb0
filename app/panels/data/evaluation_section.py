"""The Data tab's "Leave-one-out evaluation" folder: choose what is observed, the alpha method,
the percentages, the methods (ours, or ours beside the toolbox and both baselines) and whether
whole groups are held out too (Group by: a subject's or a session's folder), run the
sweep in the background (:class:`EvaluationJob`) with a progress bar and a Cancel button, then
show its results.

The section holds the choices and the run; once an evaluation has finished, its
:class:`~app.panels.data.results_area.ResultsArea` shows the results ("Export results"
downloads them as one zip) and its :class:`~app.panels.data.failed_trial_picker.FailedTrialPicker`
lists the held-out demonstrations it did not recognise ("Open in Infer" shows the chosen one in
the Infer tab).

The Run button's callback checks the choices and starts the job; :meth:`EvaluationSection.step`,
on the studio's loop, moves the progress bar and shows the outcome once the job has finished.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import viser

from app.core.snapshot import Snapshot
from app.panels.data.evaluation import EvaluationJob
from app.panels.data.evaluation_plan import (
    ALPHA_CHOICES,
    GROUP_HINT,
    METHOD_CHOICES,
    MIN_DEMOS,
    NO_GROUPS,
    SUBSET_CHOICES,
    SUBSET_HINT,
    group_choices,
    observe_choices,
    plan_evaluation,
)
from app.panels.data.failed_trial_picker import NO_TRIAL, FailedTrialPicker
from app.panels.data.results_area import ResultsArea
from app.ui.context import PanelContext
from app.ui.display import ALPHA_HINT
from app.ui.text import escape
from promp.decision import WINDOW_S
from promp.evaluate.cli import DEFAULT_PERCENTS

Notify = Callable[[viser.ClientHandle | None, str, str, str], None]
FAILURES_LISTED = 10
IDLE = f"Held out one demonstration at a time (primitives with at least {MIN_DEMOS})."
DECIDE_HINT = (
    "Also judge when each method would act, as python -m promp.evaluate --decide: every "
    "held-out demonstration observed every 2 %, a rule committing once the leading "
    f"primitive's probability stays above a threshold for {WINDOW_S:g} s; the threshold chosen "
    "on the "
    "other trials; earliness, accuracy and their harmonic mean (slower: 50 steps a trial)"
)


def running_text(job: EvaluationJob, now: float) -> str:
    """The status while it runs, e.g. "Running on lab: 5 / 12 held-out demonstrations · 0:35
    elapsed · about 0:49 left"."""
    return f"Running on {escape(Path(job.plan.source).name)}: {job.progress.text(now)}."


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
    subset_dropdown: viser.GuiDropdownHandle
    decide_checkbox: viser.GuiCheckboxHandle
    group_dropdown: viser.GuiDropdownHandle


class EvaluationSection:
    """The evaluation folder: its choices and the run (see the module docstring).

    Attributes
    ----------
    controls : EvaluationControls
    results : ResultsArea
        The results shown, and their export.
    failed_trials : FailedTrialPicker
        The trials the latest evaluation did not recognise, each one opened in Infer.
    """

    def __init__(self, ctx: PanelContext, notify: Notify):
        self.ctx = ctx
        self.notify = notify
        self._job: EvaluationJob | None = None
        self._job_shown: EvaluationJob | None = None
        self._shown: tuple[object, float] = (None, 0.0)  # the progress shown, and when written
        self._root = ctx.store.state.workspace.root  # the workspace the results are of
        self._layout = ctx.store.state.layout  # whose modalities the Observed choices are
        gui = ctx.gui
        with gui.add_folder("Leave-one-out evaluation"):
            observe_dropdown = gui.add_dropdown("Observed", tuple(observe_choices(self._layout)))
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
            subset_dropdown = gui.add_dropdown("Held out", tuple(SUBSET_CHOICES),
                                               hint=SUBSET_HINT)  # fmt: skip
            decide_checkbox = gui.add_checkbox("When it acts", False, hint=DECIDE_HINT)
            group_dropdown = gui.add_dropdown(
                "Group by", tuple(group_choices(ctx.store.state)), initial_value=NO_GROUPS,
                hint=GROUP_HINT,
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
            run_name_text, methods_dropdown, subset_dropdown, decide_checkbox, group_dropdown,
        )  # fmt: skip
        self.results = ResultsArea(gui, results_folder, export_button, notify)
        self.failed_trials = FailedTrialPicker(
            failed_dropdown, open_button, ctx.open_in_infer, notify
        )
        self.controls.run_button.on_click(lambda event: self.start(event.client))
        self.controls.cancel_button.on_click(lambda _: self.cancel())

    def start(self, client: viser.ClientHandle | None) -> EvaluationJob | None:
        """Start the sweep in a background thread with the GUI's options (None if refused)."""
        if self._job is not None and not self._job.finished:
            return None
        c = self.controls
        try:
            plan = plan_evaluation(
                self.ctx.store.state,
                observe_choices(self._layout).get(c.observe_dropdown.value),
                c.alpha_dropdown.value,
                c.percents_text.value,
                c.methods_dropdown.value,
                c.subset_dropdown.value,
                c.decide_checkbox.value,
                c.group_dropdown.value,
            )
        except ValueError as exc:
            self.notify(client, "Cannot evaluate", f"{exc}.", "red")
            return None
        self._job = job = EvaluationJob(plan)
        c.run_button.disabled = True
        c.cancel_button.visible = True
        c.progress_bar.value = 0.0
        c.progress_bar.animated = True
        c.progress_bar.visible = True
        c.eval_status.content = running_text(job, time.monotonic())
        job.start()
        return job

    def cancel(self) -> None:
        if self._job is not None:
            self._job.cancel.set()

    @property
    def job(self) -> EvaluationJob | None:
        """The latest evaluation started (running or finished)."""
        return self._job

    # ------------------------------------------------------------------ the loop

    def step(self, snapshot: Snapshot) -> None:
        layout = snapshot.store.layout
        if layout != self._layout:  # another workspace: its modalities
            self._layout = layout
            self.controls.observe_dropdown.options = tuple(observe_choices(layout))
        groups = tuple(group_choices(snapshot.store))
        if tuple(self.controls.group_dropdown.options) != groups:  # its sources' folders
            self.controls.group_dropdown.options = groups
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
        outcome, progress = job.outcome, job.progress  # the outcome first: then progress is final
        c = self.controls
        if progress != self._shown[0] or (outcome is None and now - self._shown[1] >= 1.0):
            self._shown = (progress, now)
            c.progress_bar.value = 100.0 * progress.done / max(progress.total, 1)
            if outcome is None:  # the counts, and the clock every second
                c.eval_status.content = running_text(job, now)
        if outcome is None or self._job_shown is job:
            return
        self._job_shown = job
        c.run_button.disabled = False
        c.cancel_button.visible = False
        c.progress_bar.animated = False
        if job.plan.source != str(self._root):  # it ended after the workspace changed
            c.eval_status.content = "Evaluation cancelled: the workspace changed."
            c.progress_bar.visible = False
            return
        if outcome.cancelled and (outcome.result is None or not outcome.result.rows):
            c.eval_status.content = "Evaluation cancelled."
            c.progress_bar.visible = False
            return
        if outcome.error is not None or outcome.result is None:
            c.eval_status.content = f"Evaluation failed: {escape(str(outcome.error))}"
            c.progress_bar.visible = False
            self.notify(None, "Evaluation failed", str(outcome.error), "red")
            return
        c.eval_status.content = (
            f"**Cancelled** after {progress.done} of {progress.total} held-out demonstrations "
            f"({outcome.elapsed_s:.1f} s): the results below are partial."
            if outcome.cancelled
            else summary(job)
        )
        self.results.show_evaluation(job)
        self.failed_trials.show(outcome.result, job.plan.dataset)
        done = "Evaluation cancelled: partial results" if outcome.cancelled else "Evaluation done"
        grouped = "" if outcome.grouped is None else " (one at a time, then by group)"
        self.notify(None, done, f"{progress.done} of {progress.total} held-out demonstrations"
                    f"{grouped}, {outcome.elapsed_s:.1f} s.")  # fmt: skip

    def _clear_results(self) -> None:
        """Nothing of an evaluation stays shown: its results, failed trials and export."""
        self.results.clear()
        self.failed_trials.clear()
        self.controls.progress_bar.visible = False
        self.controls.eval_status.content = IDLE

    def close(self) -> None:
        self.cancel()
        if self._job is not None:
            self._job.join(timeout=10.0)


def summary(job: EvaluationJob) -> str:
    """What a finished evaluation did (markdown): how many were held out, in how long, what
    was skipped, left out, or failed."""
    plan, outcome = job.plan, job.outcome
    skipped = (
        " Skipped (fewer than 3 demonstrations): "
        + ", ".join(f"{n} ({c})" for n, c in plan.skipped.items())
        + "."
        if plan.skipped
        else ""
    )
    left_out = (
        f" Left out (flagged, not kept in Teach): {len(plan.left_out)} demonstration(s): "
        + escape(", ".join(f"{p}/{d}" for p, d in plan.left_out))
        + "."
        if plan.left_out
        else ""
    )
    failed = ""
    failures = outcome.result.failures
    if failures:
        named = len(plan.methods) > 1  # which method failed
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
    settings = plan.settings
    how = (
        "settings chosen without the held-out demonstration (once per tenth of the set)"
        if settings.automatic
        else f"n_basis {settings.n_basis}, width {settings.width:g}"
    )
    held = ("each of" if plan.subset is None
            else f"{plan.subset} per primitive, evenly spread:")  # fmt: skip
    once = plan.n_held_out // (1 if plan.group_by is None else 2)
    grouped = ("" if outcome.grouped is None else
               f" Then each of {len(outcome.grouped.groups)} groups held out whole "
               f"({outcome.grouped.rule.describe()}): {len(outcome.grouped.warnings)} "
               "warning(s), below.")  # fmt: skip
    return (
        f"Held out {held} {once} demonstrations of {', '.join(plan.dataset)} in "
        f"{outcome.elapsed_s:.1f} s ({how}).{grouped}{skipped}{left_out}{failed}"
    )
