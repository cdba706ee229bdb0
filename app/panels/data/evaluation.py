"""The Data tab's leave-one-out evaluation: what it runs on, and the job that runs it.

The sweep is the one of ``python -m promp.evaluate`` (:func:`promp.evaluate.sweep.run_sweep`)
on the demonstrations the workspace learns from (primitives with at least :data:`MIN_DEMOS`;
flagged demonstrations that the user did not keep are left out and listed in the report), with
the workspace's learning settings. :class:`EvaluationJob` runs it in a background thread; the tab
reads its progress and result from the studio's loop. The job keeps every trial (the figures
and the list of failed trials need them) and writes the report ``--json`` would
(:meth:`EvaluationJob.report`). It runs our method alone, or beside the 2017 toolbox and the
two early-classification baselines on the same folds (:data:`METHOD_CHOICES`, as
``--method ours seed dtw prefix-nn`` does).
"""

from __future__ import annotations

import re
import threading
import time
import traceback
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.ui.display import ALPHA_LABELS, observed_choices
from app.ui.text import escape
from promp.data import Demonstration, Layout
from promp.evaluate.registry import METHODS, method_factories
from promp.evaluate.report import basis_settings, results_report
from promp.evaluate.sweep import SweepResult, run_sweep
from promp.model import Settings
from promp.progress import progress_text
from promp.quality import Finding

MIN_DEMOS = 3  # leave-one-out needs two demonstrations left to learn from
METHOD = "ours"  # the sweep's method name, as the command line's --method writes it
# The Methods dropdown: ours alone, or beside the toolbox and both baselines (same folds).
METHOD_CHOICES: dict[str, list[str]] = {"ours": [METHOD], "ours + toolbox + baselines":
                                        list(METHODS)}  # fmt: skip
MAX_PERCENTS = 20
COMPARE = "compare each"
ALPHA_CHOICES: dict[str, list[str]] = {
    **{label: [method] for method, label in ALPHA_LABELS.items()},
    "both": list(ALPHA_LABELS),
}


def observe_choices(layout: Layout) -> dict[str, list[list[str]]]:
    """The evaluation's observed-modality choices: those of the Infer tab (all together, each
    alone) and, with several modalities, all of them compared in one sweep."""
    choices = {label: [list(names)] for label, names in observed_choices(layout).items()}
    if len(layout.names) > 1:
        choices[COMPARE] = [[name] for name in layout.names] + [list(layout.names)]
    return choices


def parse_percents(text: str) -> list[float]:
    """Percentages of the movement observed, from ``"10 20 30"`` or ``"10, 20, 30"``.

    Raises
    ------
    ValueError
        Nothing given, a non-number, a value outside (0, 100], or more than 20 values.
    """
    tokens = [t for t in re.split(r"[\s,;]+", text.strip()) if t]
    if not tokens:
        raise ValueError("give at least one percentage, e.g. 10 20 30 40 50 60 70 80 90")
    try:
        values = sorted({float(t) for t in tokens})
    except ValueError:
        raise ValueError(f"percentages must be numbers, got {text.strip()!r}") from None
    if any(not (0.0 < v <= 100.0) or not np.isfinite(v) for v in values):
        raise ValueError(f"percentages must be in (0, 100], got {text.strip()!r}")
    if len(values) > MAX_PERCENTS:
        raise ValueError(f"at most {MAX_PERCENTS} percentages, got {len(values)}")
    return values


def evaluation_dataset(
    order: Sequence[str], demos: Mapping[str, Sequence[Demonstration]]
) -> tuple[dict[str, list[Demonstration]], dict[str, int]]:
    """The primitives with at least :data:`MIN_DEMOS` demonstrations, in ``order``, and the
    demonstration counts of those left out."""
    dataset = {n: list(demos.get(n, [])) for n in order if len(demos.get(n, [])) >= MIN_DEMOS}
    skipped = {n: len(demos.get(n, [])) for n in order if n not in dataset}
    return dataset, skipped


@dataclass
class EvaluationJob:
    """A leave-one-out sweep running in a background thread; the loop reads it."""

    dataset: dict[str, list[Demonstration]]
    skipped: dict[str, int]
    percents: list[float]
    observe_sets: list[list[str]]
    alpha_methods: list[str]
    settings: Settings
    layout: Layout
    source: str = ""  # where the demonstrations come from (the workspace folder)
    findings: tuple[Finding, ...] = ()  # what the checks found in the workspace
    left_out: dict[tuple[str, str], list[Finding]] = field(default_factory=dict)  # not swept
    methods: list[str] = field(default_factory=lambda: [METHOD])  # promp.evaluate.registry
    total: int = 0
    done: int = 0
    result: SweepResult | None = None
    error: str | None = None
    cancelled: bool = False
    finished: bool = False
    elapsed_s: float = 0.0
    started: float = 0.0  # time.monotonic() when it started (0: not yet)
    finished_at: float = 0.0  # time.time() when it finished
    cancel: threading.Event = field(default_factory=threading.Event)

    def run(self) -> None:
        """The sweep (blocking); sets ``result`` (partial, and ``cancelled``, when cancelled
        after some held-out demonstrations), ``error`` or ``cancelled``, then ``finished``."""
        self.started = time.monotonic()

        def progress(done: int, total: int) -> None:
            self.done, self.total = done, total

        try:
            self.result = run_sweep(
                method_factories(self.methods, self.layout, self.settings),
                self.dataset,
                self.layout,
                percents=self.percents,
                alpha_methods=self.alpha_methods,
                observe_sets=self.observe_sets,
                progress=progress,
                keep_trials=True,
                stop=self.cancel.is_set,
            )
            if self.result.partial:  # the folds done are what it holds
                self.cancelled = True
                self.done = len({(t.primitive, t.demo) for t in self.result.trials})
        except ValueError as exc:
            self.error = str(exc)
        except Exception as exc:  # a bug must end the job visibly, not hang the progress bar
            traceback.print_exc()
            self.error = f"{type(exc).__name__}: {exc}"
        finally:
            self.elapsed_s = time.monotonic() - self.started
            self.finished_at = time.time()
            self.finished = True

    def progress_text(self, now: float) -> str:
        """``"5 / 12 held-out demonstrations · 0:35 elapsed · about 0:49 left"``."""
        elapsed = now - self.started if self.started else 0.0
        total = max(self.total, self.done)
        return progress_text(self.done, total, elapsed, "held-out demonstrations")

    def title(self) -> str:
        """What the results show (markdown): the workspace, when, what was observed; said
        partial when the evaluation was cancelled."""
        observed = "; ".join(" + ".join(names) for names in self.observe_sets)
        alphas = ", ".join(ALPHA_LABELS.get(m, m) for m in self.alpha_methods)
        counted = (
            f"**partial**: cancelled after {self.done} of {self.total} held-out demonstrations"
            if self.cancelled
            else f"{self.total} held-out demonstrations"
        )
        methods = f"methods {', '.join(self.methods)}; " if self.methods != [METHOD] else ""
        return (
            f"**Results of {escape(Path(self.source).name or self.source)}** "
            f"({time.strftime('%H:%M', time.localtime(self.finished_at))}): {counted}; "
            f"{methods}observed {escape(observed)}, alpha {alphas}, "
            f"{', '.join(f'{p:g}' for p in self.percents)} %."
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
        if self.result is None:
            raise ValueError("the evaluation has no results (it has not finished, or failed)")
        report = results_report(
            self.result,
            self.dataset,
            self.layout,
            source=self.source,
            data_format="workspace",
            method=self.methods,
            observe=self.observe_sets,
            percents=self.percents,
            alpha_methods=self.alpha_methods,
            basis=basis_settings(self.settings),
            findings=self.findings,
            excluded=self.left_out,
        )
        if self.result.partial:  # cancelled: what was done, said so
            report["partial"] = {"held_out": self.done, "of": self.total}
        return report
