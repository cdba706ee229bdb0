"""The leave-one-out evaluation's results as the Data tab shows them: two charts (recognition
errors, and the position error of the remainder, against the percentage observed) and a table.

The series are the evaluation's own (:func:`promp.evaluate.plots.group_series`: one per
method, observed modalities and alpha method), so the tab and ``python -m promp.evaluate
--plots`` group and order them alike; positions are in the display unit of
:mod:`app.ui.display`. When several methods were compared, each series is named after its
method (``DTW 1-NN: hand, ML``) and coloured by it, so the table lays them side by side; a value
a method does not give (the baselines predict no trajectory) is ``n/a``. An evaluation that
also held out a whole group at a time adds the two protocols' errors side by side, and its
warnings (:func:`grouped_markdown`); one that compared several methods, the first against each
other one on the same trials (:func:`paired_markdown`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import viser

from app.ui.display import LENGTH_SCALE, LENGTH_UNIT, method_label, series_title
from app.ui.text import escape
from promp.evaluate.grouped import GroupedRun
from promp.evaluate.plots import group_series, methods_of
from promp.evaluate.tables import NOT_GIVEN
from robots.icub.layout import HAND, HEAD

SERIES_COLORS = {
    HAND.name: "#e4572e", HEAD.name: "#2980b9", f"{HAND.name}+{HEAD.name}": "#27ae60"
}
METHOD_COLORS = {"ours": "#e4572e", "seed": "#2980b9", "dtw": "#27ae60", "prefix-nn": "#8e44ad"}
OTHER_COLOR = "#555555"


def curves(rows: Sequence[Mapping]) -> dict[str, dict]:
    """Per (method, observed, alpha) series, named as the studio writes it (``hand + head,
    ML``, :func:`app.ui.display.series_title`; after the method when the rows hold several,
    ``DTW 1-NN: hand, ML``): ``method``, ``observed`` and ``alpha_method`` (the engine's
    names), then ``percent``, ``recognition_errors``, ``trials``, ``position_cm``,
    ``duration_s``, arrays of shape (n_percents,), sorted by percent."""
    out = {}
    named = len(methods_of(rows)) > 1
    for group in group_series(rows).values():
        observed, alpha_method = list(group[0]["observed"]), group[0]["alpha_method"]
        method = str(group[0].get("method", ""))
        title = series_title(observed, alpha_method)
        out[f"{method_label(method)}: {title}" if named else title] = {
            "method": method,
            "observed": observed,
            "alpha_method": alpha_method,
            "percent": np.array([r["percent"] for r in group], dtype=float),
            "recognition_errors": np.array([r["recognition_errors"] for r in group], dtype=float),
            "trials": np.array([r["trials"] for r in group], dtype=float),
            "position_cm": LENGTH_SCALE
            * np.array([r["position_error_m"] for r in group], dtype=float),
            "duration_s": np.array([r["duration_error_s"] for r in group], dtype=float),
        }
    return out


def results_table(rows: Sequence[Mapping]) -> str:
    """Markdown: one row per percentage, one column per (observed, alpha) series, the
    recognition errors then the position error of the remainder (cm)."""
    series = curves(rows)
    if not series:
        return ""
    labels = list(series)
    header = " | ".join(labels)
    trials = int(next(iter(series.values()))["trials"][0])
    percents = sorted({float(p) for s in series.values() for p in s["percent"]})

    def table(key: str, title: str, fmt: str) -> list[str]:
        lines = [f"| {title} | {header} |", "|---:|" + "---:|" * len(labels)]
        for p in percents:
            cells = []
            for label in labels:
                i = np.flatnonzero(series[label]["percent"] == p)
                value = float(series[label][key][i[0]]) if i.size else math.nan
                cells.append("" if not i.size else format(value, fmt)
                             if math.isfinite(value) else NOT_GIVEN)  # fmt: skip
            lines.append(f"| {p:g} % | " + " | ".join(cells) + " |")
        return lines

    return "\n".join(
        [
            *table("recognition_errors", f"errors (of {trials})", ".0f"),
            "",
            *table("position_cm", f"position ({LENGTH_UNIT})", ".1f"),
        ]
    )


def add_results(gui: viser.GuiApi, rows: Sequence[Mapping]) -> list:
    """The two charts and the table of ``rows`` in the current container; their handles."""
    series = curves(rows)
    if not series:
        return []
    trials = int(next(iter(series.values()))["trials"][0])
    labels = list(series)
    x = next(iter(series.values()))["percent"]  # one sweep: every series has the same percents
    by_method = len({s["method"] for s in series.values()}) > 1
    styles = []
    for label in labels:
        observed = "+".join(series[label]["observed"])
        colors, key = (METHOD_COLORS, series[label]["method"]) if by_method else (
            SERIES_COLORS, observed)  # fmt: skip
        style: dict = {
            "label": label,
            "stroke": colors.get(key, OTHER_COLOR),
            "width": 2,
            "points": {"show": True, "size": 6},
        }
        if series[label]["alpha_method"] == "model":
            style["dash"] = [6, 4]
        styles.append(style)

    def chart(title: str, key: str, y_label: str):
        # A method that gives no value here (the baselines' position errors: NaN throughout)
        # is left out of the chart: uPlot draws nothing at all when a series is only NaN.
        shown = [i for i, label in enumerate(labels) if np.isfinite(series[label][key]).any()]
        return gui.add_uplot(
            data=(x, *(series[labels[i]][key] for i in shown)),
            series=({"label": "observed (%)"}, *(styles[i] for i in shown)),
            title=title,
            scales={"x": {"time": False}, "y": {"auto": True}},
            axes=({"label": "observed (% of the movement)"}, {"label": y_label}),
            legend={"live": False},
            height=240,
        )

    return [
        chart(f"Recognition errors (of {trials})", "recognition_errors", f"errors (of {trials})"),
        chart("Position error of the remainder", "position_cm", f"error ({LENGTH_UNIT})"),
        gui.add_markdown(results_table(rows)),
    ]


def grouped_markdown(run: GroupedRun) -> str:
    """Markdown: each row's recognition errors held out one at a time and by group, the band
    of their difference and McNemar's p (:mod:`promp.evaluate.group_gap`), then the warnings
    (or that none differs beyond the noise)."""
    lines = [
        f"**{escape(run.rule.describe().capitalize())}**: {len(run.groups)} groups "
        f"({escape(', '.join(run.groups))}), errors of the same trials:",
        "",
        "| method | observed | alpha | % | one at a time | by group | band | p |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    for c in run.comparisons:
        low, high = c["difference_interval"]
        mark = " **\\***" if c["differs"] else ""
        lines.append(
            f"| {method_label(c['method'])} | {escape(' + '.join(c['observed']))} | "
            f"{c['alpha_method']} | {c['percent']:g} | {c['errors_leave_one_out']} | "
            f"{c['errors_grouped']} | {low:+.1f} to {high:+.1f}{mark} | {c['p_value']:.2g} |"
        )
    lines.append("")
    if run.result.partial:
        lines.append("The grouped sweep was cancelled: its rows are partial, not compared.")
    elif run.warnings:
        lines += [f"**Warning**: {escape(w)}" for w in run.warnings]
    else:
        lines.append("No row differs beyond the noise (the band of the difference, at 1 - 0.05 "
                     "/ the method's rows, holds 0).")
    return "\n".join(lines)


def paired_markdown(comparisons: Sequence[Mapping]) -> str:
    """Markdown: the first method against each other one on the same trials
    (:func:`promp.evaluate.paired.compare_methods`): both error counts, the band of their
    difference, McNemar's p and the verdict; empty without a comparison."""
    if not comparisons:
        return ""
    first = method_label(comparisons[0]["method"])
    lines = [
        f"**{escape(first)} against each other method, on the same trials**: the errors, the "
        "band of their difference and McNemar's p; only the trials one gets right and the "
        "other wrong tell them apart.",
        "",
        f"| against | observed, alpha | % | errors, {escape(first)}\u00a0/\u00a0other | band "
        "| verdict |",
        "|---|---|---:|:---:|:---:|---|",
    ]
    verdicts = {"fewer": f"**{escape(first)} fewer**", "more": f"**{escape(first)} more**"}
    for c in comparisons:
        low, high = c["difference_interval"]
        lines.append(
            f"| {method_label(c['against'])} | "
            f"{escape(series_title(c['observed'], c['alpha_method']))} | {c['percent']:g} | "
            f"{c['errors']}\u00a0/\u00a0{c['errors_against']} | "
            f"{low:+.1f}\u00a0to\u00a0{high:+.1f} | "  # each cell kept on one line
            f"{verdicts.get(c['verdict'], 'level')} (p\u00a0{c['p_value']:.2g}) |"
        )
    lines += ["", "Level: the band (at 1 - 0.05 / the rows of each pair) holds 0, so the two "
              "counts do not differ beyond the noise."]  # fmt: skip
    return "\n".join(lines)

