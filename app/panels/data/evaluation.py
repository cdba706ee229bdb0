"""The Data tab's leave-one-out evaluation running: the job that runs a plan
(:mod:`app.panels.data.evaluation_plan`), how far it is, and how it ended.

The sweep is the one of ``python -m promp.evaluate`` (:func:`promp.evaluate.sweep.run_sweep`).
:class:`EvaluationJob` runs it in a background thread and publishes what the tab reads from the
studio's loop as immutable values: its :class:`EvaluationProgress` while it runs, then its
:class:`EvaluationOutcome`. The job keeps every trial (the figures and the list of failed
trials need them) and writes the report ``--json`` would (:meth:`EvaluationJob.report`).
"""

from __future__ import annotations

import threading
import time
import traceback
from dataclasses import dataclass, replace
from pathlib import Path

from app.panels.data.evaluation_plan import METHOD, EvaluationPlan
from app.ui.display import ALPHA_LABELS
from app.ui.text import escape
from promp.evaluate.decisions import Decisions, decide
from promp.evaluate.paths import DECISION_PERCENTS
from promp.evaluate.registry import method_factories
from promp.evaluate.report import basis_settings, results_report
from promp.evaluate.sweep import SweepResult, run_sweep
from promp.progress import progress_text


@dataclass(frozen=True)
class EvaluationProgress:
    """How far a running evaluation is.

    Attributes
    ----------
    done, total : int
        Held-out demonstrations done, of how many.
    started : float
        ``time.monotonic()`` when it started (0: not yet).
    """

    done: int
    total: int
    started: float = 0.0

    def text(self, now: float) -> str:
        """``"5 / 12 held-out demonstrations · 0:35 elapsed · about 0:49 left"`` at ``now``
        (``time.monotonic()``)."""
        elapsed = now - self.started if self.started else 0.0
        return progress_text(self.done, max(self.total, self.done), elapsed,
                             "held-out demonstrations")  # fmt: skip


@dataclass(frozen=True)
class EvaluationOutcome:
    """How an evaluation ended.

    Attributes
    ----------
    result : SweepResult or None
        The sweep's rows and trials (partial when cancelled after some held-out
        demonstrations); None when it failed.
    error : str or None
        Why it failed.
    cancelled : bool
        Cancelled before every demonstration was held out.
    elapsed_s : float
        How long it ran, seconds.
    finished_at : float
        ``time.time()`` when it ended.
    decisions : Decisions or None
        When each method would act (the plan's ``decide``), judged on the folds done.
    """

    result: SweepResult | None = None
    error: str | None = None
    cancelled: bool = False
    elapsed_s: float = 0.0
    finished_at: float = 0.0
    decisions: Decisions | None = None


class EvaluationJob:
    """A leave-one-out sweep of ``plan`` running in a background thread; the loop reads it.

    Attributes
    ----------
    plan : EvaluationPlan
        What it runs on.
    progress : EvaluationProgress
        How far it is (replaced as the sweep goes).
    outcome : EvaluationOutcome or None
        How it ended; None while it runs.
    cancel : threading.Event
        Set to stop the sweep after the held-out demonstration it is at.
    """

    def __init__(self, plan: EvaluationPlan) -> None:
        self.plan = plan
        self.progress = EvaluationProgress(done=0, total=plan.n_held_out)
        self.outcome: EvaluationOutcome | None = None
        self.cancel = threading.Event()
        self._thread = threading.Thread(target=self.run, name="data-evaluation", daemon=True)

    def start(self) -> None:
        """Run the sweep in the job's background thread."""
        self._thread.start()

    def join(self, timeout: float) -> None:
        """Wait at most ``timeout`` seconds for the background thread to end (if started)."""
        if self._thread.is_alive():
            self._thread.join(timeout)

    @property
    def finished(self) -> bool:
        """True once the sweep has ended (done, cancelled or failed)."""
        return self.outcome is not None

    def run(self) -> None:
        """The sweep (blocking); publishes the progress as it goes, then the outcome: its
        result (partial, and ``cancelled``, when cancelled after some held-out
        demonstrations), or its error."""
        plan = self.plan
        started = time.monotonic()
        self.progress = replace(self.progress, started=started)

        def progress(done: int, total: int) -> None:
            self.progress = EvaluationProgress(done, total, started)

        result, error, decisions = None, None, None
        try:
            result = run_sweep(
                method_factories(plan.methods, plan.layout, plan.settings),
                plan.dataset,
                plan.layout,
                percents=plan.percents,
                alpha_methods=plan.alpha_methods,
                observe_sets=plan.observe_sets,
                progress=progress,
                keep_trials=True,
                stop=self.cancel.is_set,
                held_out=plan.held_out,
                decide_percents=DECISION_PERCENTS if plan.decide else (),
            )
            if plan.decide:
                decisions = decide(result.paths, list(plan.dataset))
            if result.partial:  # the folds done are what it holds
                done = len({(t.primitive, t.demo) for t in result.trials})
                self.progress = replace(self.progress, done=done)
        except ValueError as exc:
            error = str(exc)
        except Exception as exc:  # a bug must end the job visibly, not hang the progress bar
            traceback.print_exc()
            error = f"{type(exc).__name__}: {exc}"
        finally:
            self.outcome = EvaluationOutcome(
                result=result,
                error=error,
                cancelled=result is not None and result.partial,
                elapsed_s=time.monotonic() - started,
                finished_at=time.time(),
                decisions=decisions,
            )

    def title(self) -> str:
        """What the finished evaluation's results show (markdown): the workspace, when, what
        was observed; said partial when the evaluation was cancelled.

        Raises
        ------
        ValueError
            If the evaluation has not finished.
        """
        outcome, plan, progress = self.outcome, self.plan, self.progress
        if outcome is None:
            raise ValueError("the evaluation has not finished")
        observed = "; ".join(" + ".join(names) for names in plan.observe_sets)
        alphas = ", ".join(ALPHA_LABELS.get(m, m) for m in plan.alpha_methods)
        counted = (
            f"**partial**: cancelled after {progress.done} of {progress.total} held-out "
            "demonstrations"
            if outcome.cancelled
            else f"{progress.total} held-out demonstrations"
            + ("" if plan.subset is None else f" ({plan.subset} per primitive)")
        )
        methods = f"methods {', '.join(plan.methods)}; " if plan.methods != [METHOD] else ""
        acts = "; when it acts: every 2 %" if plan.decide else ""
        return (
            f"**Results of {escape(Path(plan.source).name or plan.source)}** "
            f"({time.strftime('%H:%M', time.localtime(outcome.finished_at))}): {counted}; "
            f"{methods}observed {escape(observed)}, alpha {alphas}, "
            f"{', '.join(f'{p:g}' for p in plan.percents)} %{acts}."
        )

    def report(self) -> dict:
        """The finished sweep's report, as ``python -m promp.evaluate --json`` writes it
        (:func:`promp.evaluate.report.results_report`; ``format`` is ``workspace``).

        Raises
        ------
        ValueError
            If the sweep has not finished with a result. A cancelled sweep's report holds
            the held-out demonstrations done, and says it is ``partial``.
        """
        result = None if self.outcome is None else self.outcome.result
        if result is None:
            raise ValueError("the evaluation has no results (it has not finished, or failed)")
        plan = self.plan
        report = results_report(
            result,
            plan.dataset,
            plan.layout,
            source=plan.source,
            data_format="workspace",
            method=plan.methods,
            observe=plan.observe_sets,
            percents=plan.percents,
            alpha_methods=plan.alpha_methods,
            basis=basis_settings(plan.settings),
            subset=plan.subset,
            findings=plan.findings,
            excluded=plan.left_out,
            decisions=self.outcome.decisions,
        )
        if result.partial:  # cancelled: what was done, said so
            report["partial"] = {"held_out": self.progress.done, "of": self.progress.total}
        return report
