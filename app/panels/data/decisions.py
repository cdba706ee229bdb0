"""When each method would act, as the Data tab shows it (an evaluation made with "When it
acts", or a run made with ``python -m promp.evaluate --decide``): a table of the headline (each
trial's threshold chosen without it: the harmonic mean of accuracy and 1 - earliness, the
accuracy, the earliness, the share never committed, the threshold) and a chart of the
harmonic mean against the threshold (in-sample), one series per method, observed modalities
and alpha method, named and coloured as the results' (:mod:`app.panels.data.results`). The
numbers are :mod:`promp.evaluate.decisions`'.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import viser

from app.panels.data.results import METHOD_COLORS, OTHER_COLOR
from app.ui.display import method_label, series_title
from app.ui.text import escape
from promp.evaluate.decisions import Decisions, doubt_decades
from promp.evaluate.tables import NOT_GIVEN

HEADING = "When it acts"


def series_name(row: Mapping, named: bool) -> str:
    """``ours: hand, ML`` (``hand, ML`` when one method was evaluated)."""
    title = series_title(row["observed"], row["alpha_method"])
    return f"{method_label(str(row['method']))}: {title}" if named else title


def _share(value: float) -> str:
    return f"{100 * value:.0f} %" if math.isfinite(value) else NOT_GIVEN


def decisions_table(decisions: Decisions) -> str:
    """Markdown: a column per method, observed modalities and alpha method (as the results'
    table), a line per value: the harmonic mean (the highest in bold), accuracy, earliness,
    the share never committed, the threshold (the median of those chosen)."""
    rows = decisions.rows
    if not rows:
        return ""
    named = len({str(r["method"]) for r in rows}) > 1
    best = max((r["harmonic_mean"] for r in rows if math.isfinite(r["harmonic_mean"])),
               default=math.nan)  # fmt: skip

    def harmonic(value: float) -> str:
        shown = f"{value:.3f}" if math.isfinite(value) else NOT_GIVEN
        return f"**{shown}**" if math.isfinite(value) and value == best else shown

    def threshold(value: float) -> str:
        return f"{value:.3f}" if math.isfinite(value) else NOT_GIVEN

    lines = [
        f"**{HEADING}**: commits once the leading primitive's probability has stayed at or above "
        f"a threshold for {decisions.window:g} s; each trial observed every 2 %, its threshold "
        "chosen on the other trials; a trial that never commits counts as wrong, earliness "
        "100 %.",
        "",
        "| | " + " | ".join(escape(series_name(r, named)) for r in rows) + " |",
        "|---|" + "---:|" * len(rows),
    ]
    for title, key, shown in (
        ("harmonic mean", "harmonic_mean", harmonic),
        ("accuracy", "accuracy", _share),
        ("earliness", "earliness", _share),
        ("never committed", "never_committed", _share),
        ("threshold", "threshold", threshold),
    ):
        lines.append(f"| {title} | " + " | ".join(shown(r[key]) for r in rows) + " |")
    return "\n".join(lines)


def curve_series(decisions: Decisions) -> tuple[np.ndarray, dict[str, dict]]:
    """The in-sample harmonic mean of every series against the threshold: (x, the thresholds
    in decades of doubt, shape (n_thresholds,); by series name: ``method``, ``harmonic_mean``
    of shape (n_thresholds,))."""
    rows, curve = decisions.rows, decisions.curve
    named = len({str(r["method"]) for r in rows}) > 1
    out: dict[str, dict] = {}
    x = np.zeros(0)
    for row in rows:
        key = (row["method"], tuple(row["observed"]), row["alpha_method"])
        points = [c for c in curve
                  if (c["method"], tuple(c["observed"]), c["alpha_method"]) == key]  # fmt: skip
        if not points:
            continue
        thresholds = np.array([c["threshold"] for c in points], dtype=float)
        n_primitives = max(2, int(round(1.0 / thresholds.min())))  # the first is 1 / K
        x = doubt_decades(thresholds, n_primitives)
        out[series_name(row, named)] = {
            "method": str(row["method"]),
            "harmonic_mean": np.array([c["harmonic_mean"] for c in points], dtype=float),
        }
    return x, out


def add_decisions(gui: viser.GuiApi, decisions: Decisions | None) -> list:
    """The chart and the table of ``decisions`` in the current container; their handles
    (none without decisions)."""
    if decisions is None or not decisions.rows:
        return []
    x, series = curve_series(decisions)
    handles = []
    if series and x.size:
        styles = [{"label": label, "stroke": METHOD_COLORS.get(s["method"], OTHER_COLOR),
                   "width": 2} for label, s in series.items()]  # fmt: skip
        handles.append(gui.add_uplot(
            data=(x, *(s["harmonic_mean"] for s in series.values())),
            series=({"label": "threshold (decades of doubt)"}, *styles),
            title="When it acts: harmonic mean of accuracy and 1 - earliness (in-sample)",
            scales={"x": {"time": False}, "y": {"auto": False, "range": [0, 1]}},
            axes=({"label": "threshold: -log10((1 - p) / (1 - 1/K))"},
                  {"label": "harmonic mean"}),
            legend={"live": False},
            height=240,
        ))  # fmt: skip
    handles.append(gui.add_markdown(decisions_table(decisions)))
    return handles
