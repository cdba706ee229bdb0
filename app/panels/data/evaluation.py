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
from app.panels.data.results_zip import drawn_figures
from app.ui.display import ALPHA_LABELS
from app.ui.text import escape
from promp.evaluate.decisions import Decisions, decide
from promp.evaluate.folds import CHOICE_BLOCKS
from promp.evaluate.grouped import GroupedRun, run_grouped
from promp.evaluate.groups import parse_group_by
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
        Held-out demonstrations done, of how many (while ``choosing``: blocks).
    started : float
        ``time.monotonic()`` when it started (0: not yet).
    choosing : bool
        The settings are being chosen, once per block of the set, before any demonstration
        is held out (:func:`promp.evaluate.folds.block_choices`).
    since : float
        ``time.monotonic()`` when this stage began (0: when it started): the time left is
        estimated from this stage's pace alone.
    """

    done: int
    total: int
    started: float = 0.0
    choosing: bool = False
    since: float = 0.0

    def text(self, now: float) -> str:
        """``"5 / 12 held-out demonstrations · 0:35 elapsed · about 0:49 left"`` at ``now``
        (``time.monotonic()``); while choosing, ``"choosing the settings: 3 / 10 blocks ·
        ..."``."""
        elapsed = now - self.started if self.started else 0.0
        pace = now - self.since if self.since else None  # this stage's, for the time left
        text = progress_text(self.done, max(self.total, self.done), elapsed,
                             "blocks" if self.choosing else "held-out demonstrations", pace)
        return f"choosing the settings: {text}" if self.choosing else text


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
    grouped : GroupedRun or None
        The grouped sweep and its comparison with leave-one-out (a plan with ``group_by``).
    """

    result: SweepResult | None = None
    error: str | None = None
    cancelled: bool = False
    elapsed_s: float = 0.0
    finished_at: float = 0.0
    decisions: Decisions | None = None
    grouped: GroupedRun | None = None


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
        self._figures: dict[str, bytes] | None = None
        self._drawing = threading.Lock()  # one drawing, for its run kept and its export

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

        since = [0.0]  # when the folds began, once the settings were chosen

        def choosing(done: int, total: int) -> None:
            self.progress = EvaluationProgress(done, total, started, choosing=True)
            if done == total:  # the folds begin
                since[0] = time.monotonic()
                self.progress = EvaluationProgress(0, plan.n_held_out, started, since=since[0])

        def progress(done: int, total: int) -> None:  # (the grouped sweep's count too)
            self.progress = EvaluationProgress(done, max(total, plan.n_held_out), started,
                                               since=since[0])  # fmt: skip

        result, error, decisions, grouped = None, None, None, None
        methods = method_factories(plan.methods, plan.layout, plan.settings)
        try:
            result = run_sweep(
                methods,
                plan.dataset,
                plan.layout,
                percents=plan.percents,
                alpha_methods=plan.alpha_methods,
                observe_sets=plan.observe_sets,
                progress=progress,
                choosing=choosing,
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
            elif plan.group_by is not None:
                grouped = self._grouped(methods, result, started)
        except ValueError as exc:
            error = str(exc)
        except Exception as exc:  # a bug must end the job visibly, not hang the progress bar
            traceback.print_exc()
            error = f"{type(exc).__name__}: {exc}"
        finally:
            self.outcome = EvaluationOutcome(
                result=result,
                error=error,
                cancelled=result is not None and (result.partial or (
                    grouped is not None and grouped.result.partial)),
                elapsed_s=time.monotonic() - started,
                finished_at=time.time(),
                decisions=decisions,
                grouped=grouped,
            )

    def _grouped(self, methods: dict, loo: SweepResult, started: float) -> GroupedRun:
        """The grouped sweep after ``loo``, on the progress bar's second half; a modality
        diagnosis (:func:`promp.evaluate.grouped.run_grouped`) adds its own demonstrations to
        the count as it starts."""
        plan = self.plan
        tally = {"done": self.progress.done, "total": self.progress.total}

        def sweep_progress(_title: str):
            started_here = [False]

            def progress(done: int, total: int) -> None:
                if not started_here[0] and tally["done"] >= tally["total"]:
                    tally["total"] += total  # beyond the plan: a diagnosis sweep
                started_here[0] = True
                self.progress = EvaluationProgress(tally["done"] + done, tally["total"], started)
                if done == total:
                    tally["done"] += total

            return progress

        return run_grouped(
            methods, plan.dataset, plan.layout, loo, parse_group_by(plan.group_by), plan.groups,
            percents=plan.percents, alpha_methods=plan.alpha_methods,
            observe_sets=plan.observe_sets, held_out=plan.held_out,
            progress=sweep_progress, stop=self.cancel.is_set,
        )  # fmt: skip

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
        once = plan.n_held_out // (1 if plan.group_by is None else 2)
        counted = (
            f"**partial**: cancelled after {progress.done} of {progress.total} held-out "
            "demonstrations"
            if outcome.cancelled
            else f"{once} held-out demonstrations"
            + ("" if plan.subset is None else f" ({plan.subset} per primitive)")
            + ("" if outcome.grouped is None else
               f", one at a time and {outcome.grouped.rule.describe()}")  # fmt: skip
        )
        methods = f"methods {', '.join(plan.methods)}; " if plan.methods != [METHOD] else ""
        acts = "; when it acts: every 2 %" if plan.decide else ""
        return (
            f"**Results of {escape(Path(plan.source).name or plan.source)}** "
            f"({time.strftime('%H:%M', time.localtime(outcome.finished_at))}): {counted}; "
            f"{methods}observed {escape(observed)}, alpha {alphas}, "
            f"{', '.join(f'{p:g}' for p in plan.percents)} %{acts}."
        )

    def figures(self) -> dict[str, bytes]:
        """The finished sweep's figures (PNG bytes by file name, as ``--plots`` names them),
        drawn once: the first to ask (the run being kept, or Export results) draws them, a
        second waits for that drawing and takes it.

        Raises
        ------
        ValueError
            As :meth:`report`, or when matplotlib is missing
            (:func:`promp.evaluate.plots.figures_unavailable`).
        """
        with self._drawing:
            if self._figures is None:
                self._figures = drawn_figures(self.report(), self.outcome.result,
                                              self.plan.dataset, self.plan.layout)  # fmt: skip
            return self._figures

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
            choice_blocks=CHOICE_BLOCKS,
            findings=plan.findings,
            excluded=plan.left_out,
            decisions=self.outcome.decisions,
            grouped=self.outcome.grouped,
        )
        if result.partial:  # cancelled: what was done, said so
            report["partial"] = {"held_out": self.progress.done, "of": self.progress.total}
        return report
