"""The grouped evaluation beside leave-one-out: what ``python -m promp.evaluate --group-by`` and
the studio's Group by run once the leave-one-out sweep has.

The same methods, settings, percentages and held-out demonstrations, with a whole group held
out at a time (:mod:`promp.evaluate.groups`); then the paired comparison of the two sweeps
(:mod:`promp.evaluate.group_gap`), and, where a row of several observed modalities differs
beyond the noise, both sweeps again with each of its modalities observed alone to name the one
that drives the gap (only for the methods and percentages that differ).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from promp.data import Demonstration, Layout
from promp.evaluate.group_gap import compare_protocols, gap_warnings, modality_gaps
from promp.evaluate.groups import GroupBy, group_pairs
from promp.evaluate.sweep import (
    Factory,
    Pair,
    Progress,
    SweepResult,
    check_groups,
    run_sweep,
)

__all__ = ["GroupedRun", "grouped_json", "plan_groups", "run_grouped"]


@dataclass
class GroupedRun:
    """A grouped sweep and its comparison with leave-one-out.

    Attributes
    ----------
    rule : GroupBy
    groups : dict of str to list of (int, int)
        Every group's (primitive index, demonstration index) pairs.
    result : SweepResult
        The grouped sweep (its rows carry ``protocol``: ``rule.describe()``).
    comparisons : list of dict
        :func:`promp.evaluate.group_gap.compare_protocols`, one per shared row.
    single : list of dict
        The same with each modality observed alone, where a row of several differs.
    drivers : dict
        :func:`promp.evaluate.group_gap.modality_gaps`.
    warnings : list of str
        One sentence per method and observed set whose grouped rows differ.
    """

    rule: GroupBy
    groups: dict[str, list[Pair]]
    result: SweepResult
    comparisons: list[dict] = field(default_factory=list)
    single: list[dict] = field(default_factory=list)
    drivers: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def plan_groups(
    dataset: Mapping[str, Sequence[Demonstration]],
    rule: GroupBy,
    path: Callable[[str, Demonstration], str] | None = None,
) -> dict[str, list[Pair]]:
    """The groups of ``dataset`` under ``rule``, checked before any sweep: ValueError when a
    demonstration has no group, there is only one, or holding one out leaves a primitive too
    few demonstrations to learn from (:func:`promp.evaluate.sweep.check_groups`)."""
    groups = group_pairs(dataset, rule, path)
    check_groups(dataset, groups)
    return groups


def run_grouped(
    methods: Mapping[str, Factory],
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    loo: SweepResult,
    rule: GroupBy,
    groups: Mapping[str, Sequence[Pair]],
    *,
    percents: Sequence[float],
    alpha_methods: Sequence[str],
    observe_sets: Sequence[Sequence[str]],
    held_out: Sequence[Pair] | None = None,
    jobs: int = 1,
    scheduler: str | None = None,
    progress: Callable[[str], Progress | None] = lambda _title: None,
    stop: Callable[[], bool] | None = None,
) -> GroupedRun:
    """The grouped sweep of ``methods`` (as ``loo`` was run: it must have kept its trials),
    the comparison, and the modality diagnosis where a row of several modalities differs.

    ``progress(title)`` gives the progress callback of each sweep (titled "grouped", and
    "<method>: each modality alone, leave-one-out" / "... grouped" for the diagnosis).
    """
    common = dict(jobs=jobs, scheduler=scheduler, held_out=held_out, keep_trials=True,
                  stop=stop)  # fmt: skip
    result = run_sweep(methods, dataset, layout, percents, alpha_methods, observe_sets,
                       progress=progress(rule.describe()), groups=groups, **common)  # fmt: skip
    for row in result.rows:
        row["protocol"] = rule.describe()
    run = GroupedRun(rule, {g: list(p) for g, p in groups.items()}, result)
    if result.partial or loo.partial:
        return run
    k = len(dataset)
    run.comparisons = compare_protocols(loo, result, k)
    wanted: dict[str, tuple[set[str], set[float], set[str]]] = {}
    for c in run.comparisons:
        if c["differs"] and len(c["observed"]) > 1:
            names, pcts, alphas = wanted.setdefault(c["method"], (set(), set(), set()))
            names.update(c["observed"])
            pcts.add(float(c["percent"]))
            alphas.add(c["alpha_method"])
    for method, (names, pcts, alphas) in wanted.items():
        sets = [[n] for n in layout.names if n in names]
        args = (dataset, layout, sorted(pcts), sorted(alphas), sets)
        alone_loo = run_sweep({method: methods[method]}, *args,
                              progress=progress(f"{method}: each modality alone, leave-one-out"),
                              **common)  # fmt: skip
        alone_grouped = run_sweep({method: methods[method]}, *args, groups=groups,
                                  progress=progress(f"{method}: each modality alone, "
                                                    f"{rule.describe()}"), **common)  # fmt: skip
        if alone_loo.partial or alone_grouped.partial:
            return run
        run.single += compare_protocols(alone_loo, alone_grouped, k)
    run.drivers = modality_gaps(run.comparisons, run.single)
    run.warnings = gap_warnings(run.comparisons, run.drivers)
    return run


def grouped_json(run: GroupedRun, dataset: Mapping[str, Sequence[Demonstration]]) -> dict:
    """What the report keeps of ``run`` (``report["grouped"]``): the rule, the groups (their
    demonstrations as ``primitive/demo``), the grouped rows, the comparisons, the drivers and
    the warnings. The trials are the report's, with their protocol
    (:func:`promp.evaluate.report.trial_rows`)."""
    names = list(dataset)
    return {
        "group_by": run.rule.text,
        "protocol": run.rule.describe(),
        "groups": {g: [f"{names[k]}/{dataset[names[k]][j].name}" for k, j in pairs]
                   for g, pairs in run.groups.items()},  # fmt: skip
        "results": run.result.rows,
        "failures": run.result.failures,
        "partial": run.result.partial,
        "comparisons": run.comparisons,
        "single_modality": run.single,
        "drivers": [{"method": m, "observed": list(o), "alpha_method": a, **d}
                    for (m, o, a), d in run.drivers.items()],  # fmt: skip
        "warnings": run.warnings,
    }
