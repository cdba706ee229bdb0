"""When each method would act, judged as early classification is (``--decide``).

Every held-out demonstration is observed every 2 % (:mod:`promp.evaluate.paths`) and
:class:`promp.decision.CommitRule` runs on each method's probabilities: it commits once the
leading primitive has stayed at or above a threshold for ``window`` seconds of the movement.
A trial is *right* when the rule commits to its true primitive; its *earliness* is the share of
the movement observed at the update that commits. A trial that never commits (not even with
the whole movement seen) counts as wrong, with earliness 1. As in the early-classification
literature (ECTS, Xing et al. 2012; TEASER, Schäfer & Leser 2020), a threshold is judged by the
accuracy, the mean earliness and their harmonic mean ``2 a (1 - e) / (a + 1 - e)``, which
rewards a rule only for being both right and early.

Reported per method, observed modalities and alpha method:

* **the curve** (``curve``): accuracy, earliness, harmonic mean and the share never committed
  at every candidate threshold, over all the trials. It is *in-sample*: picking its best point
  would choose the threshold on the trials it is then scored on.
* **the headline** (``rows``): for each held-out trial, the threshold whose harmonic mean over
  the *other* trials is highest (ties: the middle one of the tied thresholds), applied to that
  trial; the accuracy, earliness and harmonic mean of those decisions, the share of trials
  that never commit, and the median (and range) of the thresholds chosen. The trial's own
  probabilities never enter its threshold (a test changes them and sees the same threshold).
  The other trials' probabilities come from models that learned from it (each is a
  leave-one-out fold), as every leave-one-out figure's do.

The candidate thresholds (:func:`candidate_thresholds`) are the same for every method and
dataset, spaced evenly in the logarithm of the *doubt* ``(1 - p) / (1 - 1/K)`` (1 for a
uniform guess over ``K`` primitives, 0 for certainty): 0, 0.02, ..., 5 decades, so a threshold
means as much with 3 primitives as with 6, and a method whose probabilities reach 1 - 1e-6 is
told apart from one that stops at 0.99; the steps are fine enough near ``1/K`` for the
baselines, whose softmin probabilities seldom pass 0.6.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from promp.decision import WINDOW_S, commit_steps
from promp.evaluate.paths import ProbabilityPath

__all__ = [
    "candidate_thresholds", "DECISION_COLUMNS", "decide", "Decisions", "decisions_csv",
    "decisions_of", "decisions_text", "DOUBT_DECADES", "doubt_decades", "harmonic_mean",
    "nested_choice",
    "Outcomes", "outcomes",
]  # fmt: skip

DOUBT_DECADES = np.round(np.arange(251) / 50.0, 2)  # 0, 0.02, ..., 5
# decisions.csv: the headline rows ("held-out") then the curve ("in-sample").
DECISION_COLUMNS = (
    "method", "alpha_method", "observed", "selection", "threshold", "earliness", "accuracy",
    "harmonic_mean", "never_committed", "trials", "window_s",
)  # fmt: skip


def candidate_thresholds(n_primitives: int) -> np.ndarray:
    """The thresholds tried: ``1 - 10^-x (1 - 1/K)`` for ``x`` in :data:`DOUBT_DECADES`, shape
    (251,), from ``1/K`` (every update passes) up."""
    if n_primitives < 1:
        raise ValueError(f"at least one primitive, got {n_primitives}")
    return 1.0 - 10.0 ** -DOUBT_DECADES * (1.0 - 1.0 / n_primitives)


def doubt_decades(threshold: float | np.ndarray, n_primitives: int) -> np.ndarray:
    """``-log10((1 - p) / (1 - 1/K))``: a threshold ``p`` in decades of doubt (0 for ``1/K``,
    inf for 1)."""
    doubt = (1.0 - np.asarray(threshold, dtype=float)) / (1.0 - 1.0 / max(n_primitives, 2))
    with np.errstate(divide="ignore"):
        return -np.log10(np.clip(doubt, 0.0, None))


def harmonic_mean(accuracy: np.ndarray | float, earliness: np.ndarray | float) -> np.ndarray:
    """The harmonic mean of ``accuracy`` and ``1 - earliness`` (0 where both are 0)."""
    a = np.asarray(accuracy, dtype=float)
    timely = 1.0 - np.asarray(earliness, dtype=float)
    total = a + timely
    return np.where(total > 0, 2.0 * a * timely / np.where(total > 0, total, 1.0), 0.0)


@dataclass(frozen=True, eq=False)
class Outcomes:
    """The rule at every threshold on every trial of one (method, observed, alpha).

    Attributes
    ----------
    thresholds : array, shape (n_thresholds,)
    committed, correct : bool array, shape (n_thresholds, n_trials)
        The rule committed; it committed to the true primitive.
    earliness : array, shape (n_thresholds, n_trials)
        The share of the movement observed when it committed (1 when it never did).
    recognised : int array, shape (n_thresholds, n_trials)
        The primitive committed to (-1: none).
    percent, time : array, shape (n_thresholds, n_trials)
        The observed share (%) and the movement's time (s) at the commitment (NaN: none).
    """

    thresholds: np.ndarray
    committed: np.ndarray
    correct: np.ndarray
    earliness: np.ndarray
    recognised: np.ndarray
    percent: np.ndarray
    time: np.ndarray


def outcomes(paths: Sequence[ProbabilityPath], thresholds: np.ndarray, window: float) -> Outcomes:
    """:class:`promp.decision.CommitRule` at each of ``thresholds`` on each of ``paths``."""
    shape = (len(thresholds), len(paths))
    recognised = np.full(shape, -1)
    percent, time = np.full(shape, np.nan), np.full(shape, np.nan)
    truth = np.array([path.primitive for path in paths], dtype=int)
    for i, path in enumerate(paths):
        steps, primitives = commit_steps(path.times, path.probabilities, thresholds, window)
        hit = steps >= 0
        recognised[:, i] = primitives
        percent[hit, i] = path.percents[steps[hit]]
        time[hit, i] = path.times[steps[hit]]
    committed = recognised >= 0
    return Outcomes(
        thresholds=np.asarray(thresholds, dtype=float),
        committed=committed,
        correct=committed & (recognised == truth[None, :]),
        earliness=np.where(committed, percent / 100.0, 1.0),
        recognised=recognised,
        percent=percent,
        time=time,
    )


def nested_choice(result: Outcomes) -> np.ndarray:
    """For each trial, the index of the threshold whose harmonic mean over the *other* trials
    is highest (ties: the middle one of the tied thresholds, by value); shape (n_trials,).

    Raises
    ------
    ValueError
        Fewer than two trials (nothing to choose from without the one under test).
    """
    n = result.correct.shape[1]
    if n < 2:
        raise ValueError("choosing a threshold without the trial under test needs two trials")
    right = result.correct.sum(axis=1)[:, None] - result.correct  # (n_thresholds, n_trials)
    late = result.earliness.sum(axis=1)[:, None] - result.earliness
    score = harmonic_mean(right / (n - 1), late / (n - 1))
    chosen = np.empty(n, dtype=int)
    for i in range(n):
        tied = np.flatnonzero(score[:, i] >= score[:, i].max() - 1e-12)
        chosen[i] = tied[(tied.size - 1) // 2]
    return chosen


@dataclass(frozen=True, eq=False)
class Decisions:
    """What ``--decide`` reports (module docstring); every list JSON-ready.

    Attributes
    ----------
    window : float
        The rule's confirmation window, seconds of the movement.
    rows : list of dict
        The headline, one per (method, observed, alpha): ``method``, ``observed``,
        ``alpha_method``, ``threshold`` (the median of the thresholds chosen without each
        trial), ``threshold_low`` and ``threshold_high`` (their range), ``earliness`` (mean
        share observed at the commitment, 1 for a trial that never commits), ``accuracy``
        (share committed to the true primitive), ``harmonic_mean`` (of accuracy and 1 -
        earliness), ``never_committed`` (share), ``trials``, ``window_s``, ``selection``
        (``"held-out"``).
    curve : list of dict
        In-sample, per (method, observed, alpha) and candidate threshold: the same values
        over every trial, ``selection`` ``"in-sample"``.
    trials : list of dict
        The headline's decision of every trial: ``method``, ``observed``, ``alpha_method``,
        ``primitive``, ``demo``, ``threshold``, ``committed`` (the primitive, '' for none),
        ``percent`` and ``time_s`` at the commitment (NaN for none), ``correct``.
    """

    window: float
    rows: list[dict]
    curve: list[dict]
    trials: list[dict]


def decisions_of(report: Mapping) -> Decisions | None:
    """The :class:`Decisions` a report holds (``--decide``'s ``decisions``,
    ``decision_curve``, ``decision_trials``), or None when it has none."""
    rows = report.get("decisions")
    if not rows:
        return None
    window = float((report.get("settings") or {}).get("decide", {}).get("window_s", math.nan))
    return Decisions(window, list(rows), list(report.get("decision_curve") or []),
                     list(report.get("decision_trials") or []))  # fmt: skip


def decide(
    paths: Sequence[ProbabilityPath], primitives: Sequence[str], window: float = WINDOW_S
) -> Decisions:
    """Judge :class:`promp.decision.CommitRule` (``window`` seconds) on the sweep's ``paths``
    (:attr:`promp.evaluate.sweep.SweepResult.paths`), per method, observed set and alpha
    method, in the order they first come.

    Raises
    ------
    ValueError
        A negative or infinite window.
    """
    groups: dict[tuple, list[ProbabilityPath]] = {}
    for path in paths:
        groups.setdefault((path.method, path.observed, path.alpha_method), []).append(path)
    thresholds = candidate_thresholds(len(primitives))
    rows, curve, trials = [], [], []
    for (method, observed, alpha_method), group in groups.items():
        result = outcomes(group, thresholds, window)
        head = {"method": method, "observed": list(observed), "alpha_method": alpha_method}
        n = len(group)
        for j, threshold in enumerate(thresholds):
            curve.append(_summary(head, float(threshold), result.correct[j],
                                  result.earliness[j], result.committed[j], window,
                                  "in-sample"))  # fmt: skip
        if n < 2:  # no other trial to choose a threshold from
            rows.append({**_summary(head, math.nan, np.zeros(n, bool), np.ones(n),
                                    np.zeros(n, bool), window, "held-out"),
                         "threshold_low": math.nan, "threshold_high": math.nan})  # fmt: skip
            continue
        chosen = nested_choice(result)
        column = np.arange(n)
        correct = result.correct[chosen, column]
        committed = result.committed[chosen, column]
        earliness = result.earliness[chosen, column]
        used = thresholds[chosen]
        rows.append({**_summary(head, float(np.median(used)), correct, earliness, committed,
                                window, "held-out"),
                     "threshold_low": float(used.min()),
                     "threshold_high": float(used.max())})  # fmt: skip
        for i, path in enumerate(group):
            k = int(result.recognised[chosen[i], i])
            trials.append({**head, "primitive": primitives[path.primitive], "demo": path.demo,
                           "threshold": float(used[i]),
                           "committed": primitives[k] if k >= 0 else "",
                           "percent": float(result.percent[chosen[i], i]),
                           "time_s": float(result.time[chosen[i], i]),
                           "correct": bool(correct[i])})  # fmt: skip
    return Decisions(float(window), rows, curve, trials)


def _summary(
    head: Mapping,
    threshold: float,
    correct: np.ndarray,
    earliness: np.ndarray,
    committed: np.ndarray,
    window: float,
    selection: str,
) -> dict:
    n = correct.shape[0]
    accuracy = float(correct.mean()) if n else math.nan
    mean_earliness = float(earliness.mean()) if n else math.nan
    return {
        **head,
        "threshold": threshold,
        "earliness": mean_earliness,
        "accuracy": accuracy,
        "harmonic_mean": float(harmonic_mean(accuracy, mean_earliness)) if n else math.nan,
        "never_committed": float(1.0 - committed.mean()) if n else math.nan,
        "trials": int(n),
        "window_s": float(window),
        "selection": selection,
    }


def decisions_text(rows: Sequence[Mapping]) -> str:
    """The headline rows as the command line prints them ('' without any)."""
    if not rows:
        return ""
    window = float(rows[0].get("window_s", math.nan))
    lines = [
        f"when the robot acts: commits once the leading primitive's p >= threshold for "
        f"{window:g} s; every 2 % observed; each trial's threshold chosen without it",
        f"{'method':10s} {'observed':14s} {'alpha':5s} {'threshold':>9s} {'earliness':>9s} "
        f"{'accuracy':>8s} {'harmonic mean':>13s} {'never':>6s}",
    ]
    for r in rows:
        lines.append(
            f"{str(r['method']):10s} {'+'.join(r['observed']):14s} {r['alpha_method']:5s} "
            f"{_fmt(r['threshold'], '.4f'):>9s} {_pct(r['earliness']):>9s} "
            f"{_pct(r['accuracy']):>8s} {_fmt(r['harmonic_mean'], '.3f'):>13s} "
            f"{_pct(r['never_committed']):>6s}"
        )
    return "\n".join(lines)


def decisions_csv(rows: Sequence[Mapping], curve: Sequence[Mapping] = ()) -> str:
    """The headline ``rows`` then the in-sample ``curve`` as CSV, columns
    :data:`DECISION_COLUMNS` (observed modalities joined by ``+``)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(DECISION_COLUMNS)
    for row in [*rows, *curve]:
        cells = dict(row, observed="+".join(row["observed"]))
        writer.writerow([cells.get(column, "") for column in DECISION_COLUMNS])
    return out.getvalue()


def _fmt(value: float, fmt: str) -> str:
    value = float(value)
    return format(value, fmt) if math.isfinite(value) else "n/a"


def _pct(value: float) -> str:
    value = float(value)
    return f"{100 * value:.0f} %" if math.isfinite(value) else "n/a"
