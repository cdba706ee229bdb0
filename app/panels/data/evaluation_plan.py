"""What a leave-one-out evaluation of the Data tab runs on: the choices its folder offers, and
the :class:`EvaluationPlan` they make with the workspace.

The demonstrations are those the workspace learns from (primitives with at least
:data:`MIN_DEMOS`; flagged demonstrations that the user did not keep are left out and listed in
the report), with the workspace's learning settings. It evaluates our method alone, or beside
the 2017 toolbox and the two early-classification baselines on the same folds
(:data:`METHOD_CHOICES`, as ``--method ours seed dtw prefix-nn`` does).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from app.ui.display import ALPHA_LABELS, observed_choices
from promp.data import Demonstration, Layout
from promp.evaluate.registry import METHODS
from promp.evaluate.sweep import spread_subset
from promp.model import Settings
from promp.quality import Finding

if TYPE_CHECKING:
    from app.core.store_state import StoreState

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
# The Held out dropdown: every demonstration, or a few per primitive evenly spread over its
# list (``--subset N``); each still tested by a model fitted on every other demonstration.
SUBSET_CHOICES: dict[str, int | None] = {"every demonstration": None, "10 per primitive": 10,
                                         "5 per primitive": 5, "3 per primitive": 3}  # fmt: skip
SUBSET_HINT = (
    "A quick run: only this many demonstrations of each primitive are held out (the first, the "
    "last and evenly between, as python -m promp.evaluate --subset N), each still tested by a "
    "model fitted on every other demonstration; the same trials for every method"
)


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


@dataclass(frozen=True)
class EvaluationPlan:
    """What one leave-one-out evaluation runs on, and how: fixed before it starts.

    Attributes
    ----------
    dataset : dict of str to list of Demonstration
        The demonstrations held out one at a time, by primitive.
    skipped : dict of str to int
        The primitives with too few demonstrations (fewer than :data:`MIN_DEMOS`), and their
        counts.
    percents : list of float
        The percentages of each movement observed.
    observe_sets : list of list of str
        The observed modalities, one sweep series per set.
    alpha_methods : list of str
        ``ml`` and/or ``model``.
    settings : Settings
        The workspace's learning settings.
    layout : Layout
    source : str
        Where the demonstrations come from (the workspace folder).
    findings : tuple of Finding
        What the checks found in the workspace.
    left_out : dict of (str, str) to list of Finding
        The flagged demonstrations not swept, by (primitive, demonstration).
    methods : list of str
        The methods compared (:mod:`promp.evaluate.registry`).
    subset : int or None
        Held out per primitive (:func:`promp.evaluate.sweep.spread_subset`); None: all.
    decide : bool
        Also judge when each method would act (``--decide``: every held-out demonstration
        observed every 2 %, :mod:`promp.evaluate.decisions`).
    """

    dataset: dict[str, list[Demonstration]]
    skipped: dict[str, int]
    percents: list[float]
    observe_sets: list[list[str]]
    alpha_methods: list[str]
    settings: Settings
    layout: Layout
    source: str = ""
    findings: tuple[Finding, ...] = ()
    left_out: dict[tuple[str, str], list[Finding]] = field(default_factory=dict)
    methods: list[str] = field(default_factory=lambda: [METHOD])
    subset: int | None = None
    decide: bool = False

    @property
    def held_out(self) -> list[tuple[int, int]] | None:
        """The (primitive, demonstration) indices held out; None: every demonstration."""
        return None if self.subset is None else spread_subset(self.dataset, self.subset)

    @property
    def n_held_out(self) -> int:
        """How many demonstrations are held out, one at a time."""
        held_out = self.held_out
        return sum(map(len, self.dataset.values())) if held_out is None else len(held_out)


def plan_evaluation(
    store: StoreState,
    observe: Sequence[Sequence[str]] | None,
    alpha: str,
    percents: str,
    methods: str,
    subset: str = "every demonstration",
    decide: bool = False,
) -> EvaluationPlan:
    """The plan of the choices of the evaluation's folder on the workspace ``store``.

    Parameters
    ----------
    store : StoreState
        The workspace: its demonstrations learned from, checks, settings and layout.
    observe : sequence of sequence of str, or None
        The observed modality sets chosen (:func:`observe_choices`); None: none chosen.
    alpha : str
        A key of :data:`ALPHA_CHOICES`.
    percents : str
        The percentages as typed (:func:`parse_percents`).
    methods : str
        A key of :data:`METHOD_CHOICES` (anything else: ours alone).
    subset : str
        A key of :data:`SUBSET_CHOICES`.
    decide : bool
        Also judge when each method would act (the "When it acts" checkbox).

    Raises
    ------
    ValueError
        The percentages are not valid, the observed modalities are not the workspace's, no
        primitive has :data:`MIN_DEMOS` demonstrations, or ``subset`` is not a choice.
    """
    if subset not in SUBSET_CHOICES:
        raise ValueError(f"held out: expected one of {list(SUBSET_CHOICES)}, got {subset!r}")
    percent_values = parse_percents(percents)
    dataset, skipped = evaluation_dataset(store.names, store.learned)
    layout = store.layout
    if observe is None or any(n not in layout.names for names in observe for n in names):
        raise ValueError("choose the observed modalities")
    if not dataset:
        counts = ", ".join(f"{n}: {c}" for n, c in skipped.items()) or "no primitives"
        raise ValueError(
            f"leave-one-out needs a primitive with at least {MIN_DEMOS} demonstrations ({counts})"
        )
    return EvaluationPlan(
        dataset=dataset,
        skipped=skipped,
        percents=percent_values,
        observe_sets=[list(s) for s in observe],
        alpha_methods=list(ALPHA_CHOICES[alpha]),
        settings=store.learning_settings(),
        layout=layout,
        source=str(store.workspace.root),
        findings=store.findings,
        left_out=store.left_out,
        methods=list(METHOD_CHOICES.get(methods, [METHOD])),
        subset=SUBSET_CHOICES[subset],
        decide=bool(decide),
    )
