"""The trial plan: which training demonstrations are held out, at which observed share and in
which modalities, to score a candidate's settings (:mod:`promp.selection`).

Each primitive of three demonstrations or more has its demonstrations dealt into
:data:`INNER_FOLDS` folds, in an order drawn from their content
(:func:`promp.content_key.keyed_shuffle`): the same demonstrations are held out whatever the
files are called, in whatever order they come and in whatever unit. The trials take the
primitives in turn, each trial the next (percentage of :data:`PERCENTS`, modality set of
:func:`observe_sets`). The same trials score every candidate, so the comparison is paired. At
most :data:`MAX_TRIALS` trials for the inner cross-validation, :data:`LOO_MAX_TRIALS` for the
closed-form leave-one-out rule.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

from promp.content_key import keyed_shuffle
from promp.data import Demonstration, Layout

__all__ = [
    "INNER_FOLDS", "LOO_MAX_TRIALS", "MAX_TRIALS", "PERCENTS", "Trial", "observe_sets",
    "plan_trials",
]  # fmt: skip

INNER_FOLDS = 3
MAX_TRIALS = 30
# The closed-form rule's trials. Its choice is a minimum of mean log-losses whose differences
# between candidates are small beside their sampling noise: with 30 trials, five draws of the
# trials (other salts of the plan) chose four or five different settings on each shared set and
# on the studio's default workspace; with 270, the same on heights and flt in five of five,
# flt-shapes in four, the default workspace between two neighbours (M 10 or 14, width 0.7,
# noise x4), at 4-8x the CPU of a choice (docs/evaluation.md, "Content keys").
LOO_MAX_TRIALS = 270
PERCENTS = (10, 30, 50, 70, 90)


@dataclasses.dataclass(frozen=True)
class Trial:
    """One inner trial: demonstration ``demo`` of primitive ``primitive`` (both indices), held
    out by fold ``fold``, observed for ``percent`` % in ``modalities``."""

    primitive: int
    demo: int
    fold: int
    percent: float
    modalities: tuple[str, ...]


def observe_sets(layout: Layout) -> list[tuple[str, ...]]:
    """Every modality alone, and all of them together when there are several."""
    sets = [(name,) for name in layout.names]
    return sets + [tuple(layout.names)] if len(sets) > 1 else sets


def plan_trials(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    seed: int = 0,
    max_trials: int = MAX_TRIALS,
) -> list[Trial]:
    """The inner folds and trials (see the module docstring); empty when nothing can be scored.

    Each primitive of three demonstrations or more has its demonstrations shuffled by their
    content (:func:`promp.content_key.keyed_shuffle`, salted by ``seed`` and the primitive's
    name) and dealt into :data:`INNER_FOLDS` folds; the others are never
    held out. Trials take the primitives in turn (by name), and each trial the next
    (percentage, modalities) combination. The
    model that scores a fold's trials is fitted on every demonstration that none of them
    holds out (at least two per primitive remain: a fold holds out at most a third).
    """
    if len(dataset) < 2:
        return []
    queues = []
    # By name, each with its own seed: the plan does not depend on the primitives' order.
    for k, name in sorted(enumerate(dataset), key=lambda item: item[1]):
        demos = dataset[name]
        if len(demos) >= 3:
            order = keyed_shuffle(demos, f"{seed}/{name}")
            queues.append([(k, int(j), i % INNER_FOLDS) for i, j in enumerate(order)])
    if not queues:
        return []
    # Round robin over the primitives, so every primitive is tested as often as it can be.
    held_out = [q[i] for i in range(max(map(len, queues))) for q in queues if i < len(q)]
    combos = [(p, m) for m in observe_sets(layout) for p in PERCENTS]
    n_trials = min(max_trials, len(held_out) * len(combos))
    trials = []
    for i in range(n_trials):
        k, j, fold = held_out[i % len(held_out)]
        # shifted at every pass over the demonstrations: a demonstration seen twice is seen
        # at another percentage
        percent, modalities = combos[(i + i // len(held_out)) % len(combos)]
        trials.append(Trial(k, j, fold, float(percent), modalities))
    return trials
