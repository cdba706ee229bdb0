"""The Data tab's "Leave-one-out evaluation" folder: choose what is observed, the alpha method
and the percentages, run the sweep in the background (:class:`EvaluationJob`) with a progress
bar and a Cancel button, then show its results (:mod:`app.panels.data.results`).

The Run button's callback checks the choices and starts the job; :meth:`EvaluationSection.step`,
on the studio's loop, moves the progress bar and shows the outcome once the job has finished.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import viser

from app.context import PanelContext
from app.display import ALPHA_HINT
from app.gui_text import escape
from app.panels.data.evaluation import (
    ALPHA_CHOICES,
    MIN_DEMOS,
    EvaluationJob,
    evaluation_dataset,
    observe_choices,
    parse_percents,
)
from app.panels.data.results import add_results
from promp.evaluate.cli import DEFAULT_PERCENTS

Notify = Callable[[viser.ClientHandle | None, str, str, str], None]
FAILURES_LISTED = 10


class EvaluationSection:
    """The evaluation folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext, notify: Notify):
        self.ctx = ctx
        self.notify = notify
        self._job: EvaluationJob | None = None
        self._job_shown: EvaluationJob | None = None
        self._shown_done = -1
        self._thread: threading.Thread | None = None
        self._result_handles: list = []
        self._layout = ctx.session.layout
        self._observe_choices = observe_choices(self._layout)
        gui = ctx.gui
        with gui.add_folder("Leave-one-out evaluation"):
            self.observe_dropdown = gui.add_dropdown("Observed", tuple(self._observe_choices))
            self.alpha_dropdown = gui.add_dropdown(
                "Alpha", tuple(ALPHA_CHOICES), initial_value="ML",
                hint=ALPHA_HINT + " Both: one curve for each.",
            )
            self.percents_text = gui.add_text(
                "Percents", " ".join(f"{p:g}" for p in DEFAULT_PERCENTS)
            )
            self.run_button = gui.add_button(
                "Run leave-one-out evaluation", icon=viser.Icon.PLAYER_PLAY
            )
            self.cancel_button = gui.add_button(
                "Cancel evaluation", icon=viser.Icon.X, color="red", visible=False
            )
            self.progress_bar = gui.add_progress_bar(0.0, visible=False, animated=True)
            self.eval_status = gui.add_markdown(
                f"Held out one demonstration at a time (primitives with at least {MIN_DEMOS})."
            )
            self.results_folder = gui.add_folder("Results", visible=False)
        self.run_button.on_click(lambda event: self.start(event.client))
        self.cancel_button.on_click(lambda _: self.cancel())

    def start(self, client: viser.ClientHandle | None) -> EvaluationJob | None:
        """Start the sweep in a background thread with the GUI's options (None if refused)."""
        if self._job is not None and not self._job.finished:
            return None
        try:
            percents = parse_percents(self.percents_text.value)
        except ValueError as exc:
            self.notify(client, "Cannot evaluate", f"{exc}.", "red")
            return None
        session = self.ctx.session
        with session.lock:
            order = [p.name for p in session.primitives]
            dataset, skipped = evaluation_dataset(order, session.demos)
            settings = session.learning_settings()
            layout = session.layout
        observe = self._observe_choices.get(self.observe_dropdown.value)
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
            alpha_methods=list(ALPHA_CHOICES[self.alpha_dropdown.value]),
            settings=settings,
            layout=layout,
            total=sum(len(v) for v in dataset.values()),
        )
        self._job = job
        self.run_button.disabled = True
        self.cancel_button.visible = True
        self.progress_bar.value = 0.0
        self.progress_bar.animated = True
        self.progress_bar.visible = True
        self.eval_status.content = (
            f"Running: {job.total} held-out demonstrations of {', '.join(dataset)}..."
        )
        self._thread = threading.Thread(target=job.run, name="data-evaluation", daemon=True)
        self._thread.start()
        return job

    def cancel(self) -> None:
        if self._job is not None:
            self._job.cancel.set()

    # ------------------------------------------------------------------ the loop

    def step(self) -> None:
        layout = self.ctx.session.layout
        if layout != self._layout:  # another workspace: its modalities
            self._layout, self._observe_choices = layout, observe_choices(layout)
            self.observe_dropdown.options = tuple(self._observe_choices)
        if self._job is not None:
            self._show(self._job)

    def _show(self, job: EvaluationJob) -> None:
        """Progress while it runs; results, status and buttons when it has finished."""
        if job.done != self._shown_done:
            self._shown_done = job.done
            self.progress_bar.value = 100.0 * job.done / max(job.total, 1)
        if not job.finished or self._job_shown is job:
            return
        self._job_shown = job
        self.run_button.disabled = False
        self.cancel_button.visible = False
        self.progress_bar.animated = False
        if job.cancelled:
            self.eval_status.content = "Evaluation cancelled."
            self.progress_bar.visible = False
            return
        if job.error is not None or job.result is None:
            self.eval_status.content = f"Evaluation failed: {escape(str(job.error))}"
            self.progress_bar.visible = False
            self.notify(None, "Evaluation failed", str(job.error), "red")
            return
        self.eval_status.content = self._summary(job)
        for handle in self._result_handles:
            handle.remove()
        with self.results_folder:
            self._result_handles = add_results(self.ctx.gui, job.result.rows)
        self.results_folder.visible = bool(self._result_handles)
        self.notify(
            None, "Evaluation done", f"{job.total} held-out demonstrations, {job.elapsed_s:.1f} s."
        )

    @staticmethod
    def _summary(job: EvaluationJob) -> str:
        skipped = (
            " Skipped (fewer than 3 demonstrations): "
            + ", ".join(f"{n} ({c})" for n, c in job.skipped.items())
            + "."
            if job.skipped
            else ""
        )
        failed = ""
        failures = job.result.failures
        if failures:
            listed = "; ".join(
                f"{f['primitive']}/{f['demo']} at {f['percent']:g} % ({f['error']})"
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
            f"{job.elapsed_s:.1f} s ({how}).{skipped}{failed}"
        )

    def close(self) -> None:
        self.cancel()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
