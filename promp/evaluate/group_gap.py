"""Grouped against leave-one-out: where holding out a whole group (a subject, a session) costs a
method more than its noise, and which observed modality makes it so.

The two sweeps test the same demonstrations, each once per setting, so every trial is paired:
``worse`` counts the trials leave-one-out recognised and the grouped sweep did not, ``better``
the reverse, and the difference of the error counts is ``worse - better``. Without a group
effect each discordant trial is as likely to fall either way, so ``worse`` is binomial with
``p = 1/2`` over the ``worse + better`` discordant trials (McNemar's exact test,
:mod:`promp.evaluate.paired`). Its Clopper-Pearson interval, mapped to the difference of the
error counts, is the noise band; the grouped and leave-one-out rows **differ** when that band
excludes zero. The band's confidence is ``1 - 0.05 / m`` for the ``m`` rows of one method
(Bonferroni: a method compared at four percentages is not four chances of a false alarm). The
paired difference of the mean log-loss and its standard error are reported beside it, not
tested.

Which modality drives a gap: the comparison is run again with each observed modality alone
(:func:`modality_gaps`); the modality whose grouped rows lose the most recognitions against
leave-one-out, summed over the rows that differ, is named. A modality whose values carry the
group (a session's EMG baseline, a subject's posture) lets leave-one-out find the held-out
take's near-twins and makes the largest gap when observed alone.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from promp.evaluate.paired import ALPHA, count_band, mcnemar_p
from promp.evaluate.sweep import SweepResult, Trial

__all__ = ["ALPHA", "compare_protocols", "gap_warnings", "modality_gaps"]


def _key(trial: Trial) -> tuple:
    return (trial.method, trial.observed, trial.alpha_method, trial.percent)


def _by_row(result: SweepResult) -> dict[tuple, dict[tuple[int, str], Trial]]:
    rows: dict[tuple, dict[tuple[int, str], Trial]] = {}
    for trial in result.trials:
        rows.setdefault(_key(trial), {})[(trial.primitive, trial.demo)] = trial
    return rows


def compare_protocols(
    loo: SweepResult, grouped: SweepResult, n_primitives: int
) -> list[dict]:
    """One comparison per row the two sweeps share (both kept their trials), in the
    leave-one-out rows' order.

    Returns
    -------
    list of dict
        ``method``, ``observed``, ``alpha_method``, ``percent``, ``trials`` (paired),
        ``errors_leave_one_out``, ``errors_grouped``, ``worse`` and ``better`` (the discordant
        trials), ``difference_interval`` (of ``errors_grouped - errors_leave_one_out``, at
        ``confidence``), ``p_value`` (McNemar's exact test), ``differs`` (the interval
        excludes 0), ``log_loss_leave_one_out``, ``log_loss_grouped``,
        ``log_loss_difference`` and its standard error ``log_loss_difference_se``.
    """
    mine, theirs = _by_row(loo), _by_row(grouped)
    shared = [key for key in mine if key in theirs]
    per_method: dict[str, int] = {}
    for method, *_ in shared:
        per_method[method] = per_method.get(method, 0) + 1
    out = []
    for key in shared:
        method, observed, alpha_method, percent = key
        pairs = [(mine[key][t], theirs[key][t]) for t in mine[key] if t in theirs[key]]
        worse = sum(a.correct and not b.correct for a, b in pairs)
        better = sum(b.correct and not a.correct for a, b in pairs)
        confidence = 1.0 - ALPHA / per_method[method]
        low, high = count_band(worse, better, confidence)
        gaps = [b.log_loss(n_primitives) - a.log_loss(n_primitives) for a, b in pairs]
        mean_gap = math.fsum(gaps) / len(gaps)
        spread = math.fsum((g - mean_gap) ** 2 for g in gaps) / max(len(gaps) - 1, 1)
        out.append(
            {
                "method": method,
                "observed": list(observed),
                "alpha_method": alpha_method,
                "percent": percent,
                "trials": len(pairs),
                "errors_leave_one_out": sum(not a.correct for a, _ in pairs),
                "errors_grouped": sum(not b.correct for _, b in pairs),
                "worse": worse,
                "better": better,
                "confidence": confidence,
                "difference_interval": [low, high],
                "p_value": mcnemar_p(worse, better),
                "differs": low > 0.0 or high < 0.0,
                "log_loss_leave_one_out": math.fsum(a.log_loss(n_primitives) for a, _ in pairs)
                / len(pairs),
                "log_loss_grouped": math.fsum(b.log_loss(n_primitives) for _, b in pairs)
                / len(pairs),
                "log_loss_difference": mean_gap,
                "log_loss_difference_se": math.sqrt(spread / len(gaps)),
            }
        )
    return out


def modality_gaps(
    comparisons: Sequence[Mapping], single: Sequence[Mapping]
) -> dict[tuple[str, tuple[str, ...], str], dict]:
    """For every (method, observed set, alpha method) with rows that differ
    (``comparisons``), the modality of the set that drives the gap, from ``single``: the
    comparisons of the same sweeps with each modality of the set observed alone, at the
    percentages that differ.

    Returns
    -------
    dict
        ``{(method, observed, alpha): {"modality": the driver, "by_modality": {name: {"extra
        errors": sum of errors_grouped - errors_leave_one_out, "differs": any row of it
        differs}}, "percents": the percentages compared}}``. A set of one modality names it
        without comparing.
    """
    # a set of one modality is its own comparison
    alone = {(c["method"], tuple(c["observed"]), c["alpha_method"], float(c["percent"])): c
             for c in (*single, *(c for c in comparisons if len(c["observed"]) == 1))}  # fmt: skip
    flagged: dict[tuple[str, tuple[str, ...], str], list[float]] = {}
    for c in comparisons:
        if c["differs"]:
            key = (c["method"], tuple(c["observed"]), c["alpha_method"])
            flagged.setdefault(key, []).append(float(c["percent"]))
    out = {}
    for (method, observed, alpha), percents in flagged.items():
        by_modality = {}
        for name in observed:
            rows = [alone[key] for p in percents if (key := (method, (name,), alpha, p)) in alone]
            by_modality[name] = {
                "extra_errors": sum(r["errors_grouped"] - r["errors_leave_one_out"] for r in rows),
                "log_loss_gap": math.fsum(r["log_loss_difference"] for r in rows),
                "differs": any(r["differs"] for r in rows),
                "compared": bool(rows),
            }
        driver = max(observed, key=lambda n: (by_modality[n]["extra_errors"],
                                              by_modality[n]["log_loss_gap"]))  # fmt: skip
        out[(method, observed, alpha)] = {"modality": driver, "by_modality": by_modality,
                                          "percents": percents}  # fmt: skip
    return out


def gap_warnings(comparisons: Sequence[Mapping], drivers: Mapping) -> list[str]:
    """One sentence per (method, observed set, alpha method) whose grouped rows differ from
    leave-one-out beyond the noise, naming the rows, the band and the modality that drives
    it (:func:`modality_gaps`)."""
    rows: dict[tuple[str, tuple[str, ...], str], list[Mapping]] = {}
    for c in comparisons:
        if c["differs"]:
            rows.setdefault((c["method"], tuple(c["observed"]), c["alpha_method"]), []).append(c)
    out = []
    for (method, observed, alpha), differing in rows.items():
        cells = "; ".join(
            f"{c['percent']:g} %: {c['errors_grouped']} against {c['errors_leave_one_out']} of "
            f"{c['trials']} (the difference's band {c['difference_interval'][0]:+.1f} to "
            f"{c['difference_interval'][1]:+.1f} at {100 * c['confidence']:.1f} %)"
            for c in differing
        )
        worse = all(c["errors_grouped"] > c["errors_leave_one_out"] for c in differing)
        what = (
            "more errors held out by group than leave-one-out: leave-one-out within a group "
            "likely flatters it (a held-out take has near-twins from its own group among the "
            "training takes)"
            if worse
            else "a different number of errors held out by group than leave-one-out"
        )
        sentence = f"{method} ({'+'.join(observed)} observed, alpha {alpha}) makes {what}: {cells}."
        driver = drivers.get((method, observed, alpha))
        if driver is not None:
            name = driver["modality"]
            if len(observed) == 1:
                sentence += f" The modality: {name}, the only one observed."
            else:
                alone = ", ".join(
                    f"{m} {v['extra_errors']:+d}" + (" (beyond the noise)" if v["differs"] else "")
                    for m, v in driver["by_modality"].items()
                )
                sentence += (f" Driven by {name}: with each modality observed alone, the "
                             f"grouped rows' extra errors are {alone}.")  # fmt: skip
        out.append(sentence)
    return out
