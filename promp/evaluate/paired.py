"""Two error counts on the same trials, and whether they differ beyond the noise.

Two methods of one sweep (or one method under two protocols) test the same demonstrations at
the same settings, so every trial is paired. Only the **discordant** trials say which is
better: ``worse`` counts those the first got wrong and the second right, ``better`` the
reverse, and the difference of the error counts is ``worse - better``. If the two were equally
good, each discordant trial would fall either way with probability 1/2, so ``worse`` is
binomial with ``p = 1/2`` over the ``worse + better`` discordant trials (McNemar's exact test).
Its Clopper-Pearson interval, mapped to the difference of the error counts, is the **band**;
the counts differ when it excludes zero. A family of ``m`` comparisons is judged at
``1 - 0.05 / m`` (Bonferroni: a method compared at four percentages is not four chances of a
false alarm).

:func:`compare_methods` compares the first method of a sweep with each other one, row by row:
the evaluation prints it under the methods' table and writes it to its JSON (``paired``), so a
one-error gap between two methods of 122 trials is read as what it is.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from scipy.stats import beta

from promp.evaluate.sweep import Trial

__all__ = ["ALPHA", "compare_methods", "count_band", "mcnemar_p"]

ALPHA = 0.05  # the family-wise false-alarm rate of one family of comparisons


def count_band(worse: int, better: int, confidence: float) -> tuple[float, float]:
    """The Clopper-Pearson interval of ``P(worse)`` among the ``worse + better`` discordant
    trials at ``confidence``, as an interval of the difference of the error counts,
    ``worse - better``; ``(0, 0)`` without a discordant trial."""
    n = worse + better
    if n == 0:
        return 0.0, 0.0
    tail = (1.0 - confidence) / 2.0
    low = 0.0 if worse == 0 else float(beta.ppf(tail, worse, better + 1))
    high = 1.0 if better == 0 else float(beta.ppf(1.0 - tail, worse + 1, better))
    return n * (2.0 * low - 1.0), n * (2.0 * high - 1.0)


def mcnemar_p(worse: int, better: int) -> float:
    """McNemar's exact two-sided p-value of ``worse`` against ``better`` discordant trials."""
    n = worse + better
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(max(worse, better), n + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


def compare_methods(trials: Sequence[Trial]) -> list[dict]:
    """The first method of ``trials`` (in the sweep's order: the first named) against each
    other one, one comparison per row (observed set, alpha method, percent) both hold, on the
    trials both kept. Each (first, other) pair is one family: its band is at
    ``1 - ALPHA / rows``. Empty with fewer than two methods.

    Returns
    -------
    list of dict
        ``method`` (the first), ``against``, ``observed``, ``alpha_method``, ``percent``,
        ``trials`` (paired), ``errors`` and ``errors_against``, ``worse`` (the first wrong,
        the other right) and ``better`` (the reverse), ``confidence``,
        ``difference_interval`` (of ``errors - errors_against``), ``p_value`` (McNemar's
        exact test) and ``verdict``: ``"fewer"`` or ``"more"`` errors when the band excludes
        zero, ``"level"`` when it does not. A trial a method failed on counts as wrong.
    """
    methods: list[str] = []
    rows: dict[str, dict[tuple, dict[tuple[int, str], bool]]] = {}
    for t in trials:
        if t.method not in rows:
            methods.append(t.method)
        key = (t.observed, t.alpha_method, float(t.percent))
        rows.setdefault(t.method, {}).setdefault(key, {})[(t.primitive, t.demo)] = t.correct
    if len(methods) < 2:
        return []
    first, mine = methods[0], rows[methods[0]]
    out = []
    for other in methods[1:]:
        theirs = rows[other]
        shared = [key for key in mine if key in theirs]
        confidence = 1.0 - ALPHA / max(len(shared), 1)
        for key in shared:
            pairs = [(right, theirs[key][t]) for t, right in mine[key].items() if t in theirs[key]]
            worse = sum(b and not a for a, b in pairs)
            better = sum(a and not b for a, b in pairs)
            low, high = count_band(worse, better, confidence)
            observed, alpha_method, percent = key
            out.append(
                {
                    "method": first,
                    "against": other,
                    "observed": list(observed),
                    "alpha_method": alpha_method,
                    "percent": percent,
                    "trials": len(pairs),
                    "errors": sum(not a for a, _ in pairs),
                    "errors_against": sum(not b for _, b in pairs),
                    "worse": worse,
                    "better": better,
                    "confidence": confidence,
                    "difference_interval": [low, high],
                    "p_value": mcnemar_p(worse, better),
                    "verdict": "fewer" if high < 0.0 else "more" if low > 0.0 else "level",
                }
            )
    return out
