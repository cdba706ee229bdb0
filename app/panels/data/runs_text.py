"""What the Data tab's "Saved runs" writes: the list of runs, the choices of its dropdowns, and
two runs compared (:func:`promp.evaluate.runs.compare_runs`) as markdown. Pure: no viser.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

from app.io.runs_folder import RunListing
from app.ui.display import (
    ALPHA_LABELS,
    LENGTH_SCALE,
    LENGTH_UNIT,
    method_label,
    observed_label,
    series_title,
)
from app.ui.text import escape
from promp.evaluate.runs import Run, compare_decisions
from promp.evaluate.tables import NOT_GIVEN

NO_RUN = "(no saved run)"
LISTED = 15  # runs in the table at most (the dropdown holds them all)


def when(created: str) -> str:
    """``2026-11-26T01:23:45+00:00`` as ``2026-11-26 01:23:45``."""
    return created[:19].replace("T", " ") or "?"


def _cell(text: str) -> str:
    return escape(text).replace("|", "/")


def describe(item: RunListing) -> tuple[str, str, str]:
    """(observed modalities, alpha methods, percentages) of a run, as the tab writes them."""
    observed = "; ".join(observed_label(names) for names in item.observed)
    alpha = ", ".join(ALPHA_LABELS.get(a, a) for a in item.alpha)
    return observed, alpha, " ".join(f"{p:g}" for p in item.percents)


def run_choices(items: Iterable[RunListing]) -> dict[str, str]:
    """The dropdown's labels -> run folders, e.g. ``2026-11-26 01:23:45 · hand+head ML``
    (``(partial)`` for a cancelled run, ``(unreadable)`` for one that cannot be read)."""
    out: dict[str, str] = {}
    for item in items:
        if item.problem:
            label = f"{item.folder} (unreadable)"
        else:
            label = f"{when(item.created)} · {item.name}" + (" (partial)" if item.partial else "")
        if label in out:
            label = f"{label} [{item.folder}]"
        out[label] = item.folder
    return out


def errors_text(item: RunListing) -> str:
    """A run's recognition errors of all its trials, ``12 of 488``; per method when it
    compared several, ``ours 12, DTW 1-NN 30 (of 488 each)``."""
    if len(item.methods) < 2:
        return f"{item.errors} of {item.trials}"
    counts = {trials for _, _, trials in item.methods}
    of = f" (of {counts.pop()} each)" if len(counts) == 1 else ""
    return ", ".join(f"{method_label(m)} {e}" + ("" if of else f" of {t}")
                     for m, e, t in item.methods) + of  # fmt: skip


def runs_table(items: Sequence[RunListing], limit: int = LISTED) -> str:
    """Markdown: the newest ``limit`` runs, one line each (time, name, observed modalities,
    alpha, percentages, recognition errors of all trials, per method when it compared
    several: :func:`errors_text`); unreadable ones with the reason."""
    if not items:
        return ""
    lines = ["| time | name | observed | alpha | % | errors |", "|---|---|---|---|---|---:|"]
    for item in items[:limit]:
        if item.problem:
            lines.append(f"| | {_cell(item.folder)} | cannot be read: {_cell(item.problem)} "
                         "| | | |")  # fmt: skip
            continue
        observed, alpha, percents = describe(item)
        name = _cell(item.name) + (" *(partial)*" if item.partial else "")
        lines.append(
            f"| {when(item.created)} | {name} | {_cell(observed)} | {alpha} | {percents} "
            f"| {_cell(errors_text(item))} |"
        )
    if len(items) > limit:
        lines.append(f"\n{len(items) - limit} older run(s) in the dropdown.")
    return "\n".join(lines)


def _number(value: float, fmt: str) -> str:
    return format(value, fmt) if math.isfinite(value) else NOT_GIVEN


def _change(row: Mapping, name: str, fmt: str, scale: float = 1.0) -> str:
    """``a → b (±diff)`` of one compared value."""
    a, b, diff = (row[f"{name}_{k}"] * scale for k in ("a", "b", "diff"))
    signed = "+" + fmt if not fmt.startswith("+") else fmt
    shown = f"{_number(a, fmt)} → {_number(b, fmt)}"
    change = _number(diff, signed) if math.isfinite(diff) else ""
    if not change or float(change) == 0.0:  # no change at the precision shown: no "(-0.0)"
        return shown
    return f"{shown} ({change})"


def differences(a: Run, b: Run) -> list[str]:
    """What differs in how the two runs were made: their settings, the demonstrations used
    and left out, the code version (markdown lines)."""
    lines = []
    settings_a, settings_b = _settings(a), _settings(b)
    for key in sorted(set(settings_a) | set(settings_b)):
        if settings_a.get(key) != settings_b.get(key):
            shown_a, shown_b = _setting(settings_a.get(key)), _setting(settings_b.get(key))
            lines.append(f"{escape(key)} {escape(shown_a)} → {escape(shown_b)}")
    used_a, used_b = _demos(a.report.get("used")), _demos(b.report.get("used"))
    if used_a - used_b:
        lines.append("only A used: " + escape(", ".join(sorted(used_a - used_b))))
    if used_b - used_a:
        lines.append("only B used: " + escape(", ".join(sorted(used_b - used_a))))
    if a.code_version != b.code_version:
        lines.append(f"code: {escape(a.code_version)} → {escape(b.code_version)}")
    return lines


def _settings(run: Run) -> dict:
    """A run's settings; ``methods`` from ``method`` for a run written before it was kept."""
    settings = dict(run.report.get("settings") or {})
    if "methods" not in settings and "method" in settings:
        settings["methods"] = [settings["method"]]
    return settings


def _setting(value: object) -> str:
    """A setting as the tab writes it: ``hand + head; hand``, ``30 60``, ``n_basis 7``."""
    if isinstance(value, list):
        if any(isinstance(v, list) for v in value):
            return "; ".join(_setting(v) for v in value)
        joiner = " + " if all(isinstance(v, str) for v in value) else " "
        return joiner.join(_setting(v) for v in value)
    if isinstance(value, dict):
        return ", ".join(f"{k} {_setting(v)}" for k, v in value.items())
    if isinstance(value, float):
        return f"{value:g}"
    return "none" if value is None else str(value)


def _demos(used: object) -> set[str]:
    if not isinstance(used, Mapping):
        return set()
    return {f"{p}/{d}" for p, demos in used.items() if isinstance(demos, list) for d in demos}


def comparison_markdown(a: Run, b: Run, rows: Sequence[Mapping]) -> str:
    """Two runs compared (``rows``: :func:`promp.evaluate.runs.compare_runs`): what differs in
    how they were made, then per series (method, observed modalities, alpha; the method named
    when either run compared several or they differ in it) a table per percentage of the
    recognition errors, the position error of the remainder and the duration error,
    A → B (B − A); ``n/a`` where a method gives no value or a run has no such row."""
    lines = [f"**A:** {escape(a.label)}  \n**B:** {escape(b.label)}", ""]
    made = differences(a, b)
    lines += ["Made differently: " + "; ".join(made) if made else "Made alike (settings, "
              "demonstrations, code).", ""]  # fmt: skip
    series: dict[tuple[str, ...], list[Mapping]] = {}
    for row in rows:
        key = (row.get("method", ""), row["observed"], row["alpha"],
               row.get("method_b", ""), row["observed_b"], row["alpha_b"])  # fmt: skip
        series.setdefault(key, []).append(row)
    named = len({k[0] for k in series} | {k[3] for k in series}) > 1

    def name(method: str, observed: str, alpha: str) -> str:
        title = series_title(observed.split("+"), alpha)
        return f"{method_label(method)}: {title}" if named else title

    for (method, observed, alpha, method_b, observed_b, alpha_b), group in series.items():
        title = name(method, observed, alpha)
        if (method_b, observed_b, alpha_b) != (method, observed, alpha):  # A's beside B's twin
            title += " → " + name(method_b, observed_b, alpha_b)
        lines += [
            f"**{escape(title)}**", "",
            f"| % | errors | position ({LENGTH_UNIT}) | duration (s) |", "|---:|---:|---:|---:|",
        ]  # fmt: skip
        for row in group:
            lines.append(
                f"| {row['percent']:g} | {_change(row, 'errors', '.0f')} "
                f"| {_change(row, 'position_error_m', '.1f', LENGTH_SCALE)} "
                f"| {_change(row, 'duration_error_s', '.2f')} |"
            )
        lines.append("")
    if not rows:
        lines.append("Neither run has result rows.")
    lines += decisions_comparison(a, b, named)
    return "\n".join(lines).rstrip()


def decisions_comparison(a: Run, b: Run, named: bool) -> list[str]:
    """When each method would act in the two runs (``--decide``,
    :func:`promp.evaluate.runs.compare_decisions`), A → B (B − A), as markdown lines; none
    when neither run judged it."""
    rows = compare_decisions(a, b)
    if not rows:
        return []
    lines = [
        "", "**When it acts** (each trial's threshold chosen without it)", "",
        "| series | harmonic mean | accuracy (%) | earliness (%) | never committed (%) |",
        "|---|---:|---:|---:|---:|",
    ]  # fmt: skip
    for row in rows:
        title = series_title(row["observed"].split("+"), row["alpha"])
        title = f"{method_label(row['method'])}: {title}" if named else title
        lines.append(
            f"| {escape(title)} | {_change(row, 'harmonic_mean', '.3f')} "
            f"| {_change(row, 'accuracy', '.0f', 100.0)} "
            f"| {_change(row, 'earliness', '.0f', 100.0)} "
            f"| {_change(row, 'never_committed', '.0f', 100.0)} |"
        )
    return lines
