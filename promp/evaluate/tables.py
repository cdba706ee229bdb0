"""The tables ``python -m promp.evaluate`` prints: every result row, then, when the sweep
compared several methods, the methods side by side (one column each) per observed modalities,
alpha method and percentage; with ``--group-by``, the grouped sweep's rows and both protocols
side by side (:func:`grouped_text`); and the first method against each other one on the same
trials (:func:`paired_text`). A value a method does not give (the baselines predict no
trajectory) is written ``n/a``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from promp.evaluate.plots import methods_of
from promp.evaluate.sweep import LEAVE_ONE_OUT

if TYPE_CHECKING:
    from promp.evaluate.grouped import GroupedRun

__all__ = [
    "grouped_text", "NOT_GIVEN", "number", "paired_text", "results_text", "SIDE_BY_SIDE",
    "side_by_side_text",
]  # fmt: skip

NOT_GIVEN = "n/a"


def number(value: float, fmt: str, scale: float = 1.0) -> str:
    """``value * scale`` formatted, or ``n/a`` when it is NaN or infinite."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        return NOT_GIVEN
    return format(value * scale, fmt) if math.isfinite(value) else NOT_GIVEN


def _share(value: float) -> str:
    return "-" if not math.isfinite(float(value)) else f"{100 * float(value):.0f}%"


def _signed(value: float) -> str:
    """A number of errors with its sign and one decimal (a band's end is not whole), 0
    without a sign."""
    return f"{float(value):+.1f}" if round(float(value), 1) else "0"


def results_text(rows: Sequence[Mapping]) -> str:
    """Every row: recognition errors, position, goal and duration errors, the duration's
    coverage, NRMSE of the prior and the posterior, log-loss, confident mistakes and the
    worst log-loss; the method first when the rows hold several."""
    named = len(methods_of(rows)) > 1
    method = f"{'method':10s} " if named else ""
    lines = [
        f"{method}{'observed':14s} {'alpha':5s} {'%':>4s} {'errors':>9s} {'pos cm':>7s} "
        f"{'goal cm':>7s} {'dur s':>6s} {'cover':>5s} {'nrmse prior':>11s} {'post':>6s} "
        f"{'log-loss':>8s} {'p<0.01':>6s} {'worst':>6s}"
    ]
    for r in rows:
        method = f"{str(r.get('method', '')):10s} " if named else ""
        lines.append(
            f"{method}{','.join(r['observed']):14s} {r['alpha_method']:5s} {r['percent']:4.0f} "
            f"{r['recognition_errors']:>4d}/{r['trials']:<4d} "
            f"{number(r['position_error_m'], '7.2f', 100.0):>7s} "
            f"{number(r['goal_error_m'], '7.2f', 100.0):>7s} "
            f"{number(r['duration_error_s'], '6.2f'):>6s} "
            f"{_share(r.get('duration_coverage', math.nan)):>5s} "
            f"{number(r['nrmse_prior'], '11.3f'):>11s} {number(r['nrmse_posterior'], '6.3f'):>6s} "
            f"{r['log_loss']:8.3f} {r['confident_mistakes']:6d} {r['worst_log_loss']:6.1f}"
        )
    return "\n".join(lines)


# The side-by-side blocks: (title, the row's value, format, scale).
SIDE_BY_SIDE = (
    ("recognition errors", "recognition_errors", ".0f", 1.0),
    ("log-loss", "log_loss", ".3f", 1.0),
    ("position error of the remainder, cm", "position_error_m", ".2f", 100.0),
)


def side_by_side_text(rows: Sequence[Mapping]) -> str:
    """The methods of ``rows`` side by side, one block per value of :data:`SIDE_BY_SIDE`: a
    line per (observed, alpha, percent), a column per method. Empty with one method."""
    methods = methods_of(rows)
    if len(methods) < 2:
        return ""
    cells: dict[tuple, dict[str, Mapping]] = {}
    for r in rows:
        key = ("+".join(r["observed"]), r["alpha_method"], float(r["percent"]))
        cells.setdefault(key, {})[str(r.get("method", ""))] = r
    width = max(9, *(len(m) for m in methods))
    trials = max(int(r["trials"]) for r in rows)
    out = []
    for title, key, fmt, scale in SIDE_BY_SIDE:
        heading = f"{title} (of {trials} trials)" if key == "recognition_errors" else title
        out += [heading, f"{'observed':14s} {'alpha':5s} {'%':>4s} "
                + " ".join(f"{m:>{width}s}" for m in methods)]  # fmt: skip
        for (observed, alpha, percent), by_method in cells.items():
            values = [
                number(by_method[m][key], fmt, scale) if m in by_method else "-" for m in methods
            ]
            out.append(f"{observed:14s} {alpha:5s} {percent:4.0f} "
                       + " ".join(f"{v:>{width}s}" for v in values))  # fmt: skip
        out.append("")
    return "\n".join(out).rstrip()


def grouped_text(run: GroupedRun) -> str:
    """The grouped rows, then each shared row of leave-one-out and grouped side by side (the
    error counts, the difference's band, McNemar's p, the log-loss of each), then the
    warnings."""
    title = f"{run.rule.describe()}: {len(run.groups)} groups ({', '.join(run.groups)})"
    lines = [title, results_text(run.result.rows), ""]
    if run.comparisons:
        lines.append(f"{LEAVE_ONE_OUT} against {run.rule.describe()} (the same trials; "
                     "errors, their difference's band, McNemar's p, log-loss)")  # fmt: skip
        lines.append(f"{'method':10s} {'observed':14s} {'alpha':5s} {'%':>4s} {'LOO':>5s} "
                     f"{'grouped':>7s} {'difference band':>19s} {'p':>7s} {'log-loss LOO':>12s} "
                     f"{'grouped':>7s}")  # fmt: skip
        for c in run.comparisons:
            low, high = (_signed(v) for v in c["difference_interval"])
            band = f"[{low}, {high}]" + (" *" if c["differs"] else "  ")
            lines.append(
                f"{c['method']:10s} {'+'.join(c['observed']):14s} {c['alpha_method']:5s} "
                f"{c['percent']:4.0f} {c['errors_leave_one_out']:5d} {c['errors_grouped']:7d} "
                f"{band:>19s} {c['p_value']:7.2g} "
                f"{number(c['log_loss_leave_one_out'], '.3f'):>12s} "
                f"{number(c['log_loss_grouped'], '.3f'):>7s}"
            )
        lines.append("(* the band, at 1 - 0.05 / rows of the method, excludes 0: the protocols "
                     "differ beyond the noise)")  # fmt: skip
    for warning in run.warnings:
        lines.append(f"warning: {warning}")
    if not run.warnings and run.comparisons:
        lines.append("no row differs beyond the noise between leave-one-out and the grouped "
                     "sweep")  # fmt: skip
    return "\n".join(lines)


def paired_text(comparisons: Sequence[Mapping]) -> str:
    """The first method against each other one on the same trials
    (:func:`promp.evaluate.paired.compare_methods`): both error counts, the band of their
    difference, McNemar's p and the verdict; empty without a comparison."""
    if not comparisons:
        return ""
    first = comparisons[0]["method"]
    width = max(9, *(len(str(c["against"])) for c in comparisons))
    lines = [
        f"{first} against each other method, on the same trials (errors; the band of their "
        "difference at 1 - 0.05 / rows; McNemar's p)",
        f"{'against':{width}s} {'observed':14s} {'alpha':5s} {'%':>4s} {first:>7s} "
        f"{'other':>7s} {'difference band':>17s} {'p':>7s}  verdict",
    ]
    for c in comparisons:
        low, high = (_signed(v) for v in c["difference_interval"])
        verdict = {"fewer": f"{first} fewer", "more": f"{first} more"}.get(c["verdict"], "level")
        lines.append(
            f"{c['against']:{width}s} {'+'.join(c['observed']):14s} {c['alpha_method']:5s} "
            f"{c['percent']:4.0f} {c['errors']:7d} {c['errors_against']:7d} "
            f"{'[' + low + ', ' + high + ']':>17s} {c['p_value']:7.2g}  {verdict}"
        )
    lines.append("(level: the band holds 0, the two counts do not differ beyond the noise)")
    return "\n".join(lines)

