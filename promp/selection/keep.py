"""Keeping the previous choice: a refit of nearly the same demonstrations (the studio's, after
a take) keeps the settings the last search chose while, on the new trials, they still beat the
runner-up of that search (a paired comparison of two candidates instead of a search), at most
:data:`KEEP_LIMIT` times in a row."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from promp.model import FALLBACK, Settings
from promp.selection.candidates import (
    BASIS_GRID,
    NOISE_GRID,
    WIDTH_GRID,
    Candidates,
    preference,
)

__all__ = ["KEEP_LIMIT", "KEPT_RULE", "keep_previous"]


KEEP_LIMIT = 10


KEPT_RULE = (
    "kept from the previous fit: on these demonstrations' trials the choice still has a lower "
    "leave-one-out loss than the runner-up of the last search (the search runs again when it "
    f"does not, and after {KEEP_LIMIT} refits kept in a row)"
)


def keep_previous(
    candidates: Candidates, settings: Settings, previous: Mapping
) -> tuple[Settings, dict] | None:
    """The previous choice kept, if it still beats the previous runner-up on ``dataset``'s
    trials (see :func:`promp.selection.choice.choose_settings`); None when the search must run
    again."""
    automatic = settings.automatic

    def values_of(entry: object) -> dict | None:
        if not isinstance(entry, Mapping) or set(entry) != set(automatic):
            return None
        values = {name: getattr(settings, name) for name in FALLBACK} | dict(entry)
        if (
            values["n_basis"] not in BASIS_GRID
            or values["width"] not in WIDTH_GRID
            or (settings.noise_scale is None and values["noise_scale"] not in NOISE_GRID)
        ):
            return None
        return values

    chosen_values = values_of(previous.get("chosen"))
    runner_values = values_of(previous.get("runner_up"))
    if chosen_values is None or runner_values is None or chosen_values == runner_values:
        return None
    if int(previous.get("kept", 0)) >= KEEP_LIMIT:
        return None
    # the same trials: a paired comparison; one scorer call per candidate basis (the two
    # often differ in the noise scale alone)
    wanted: dict[tuple[int, float], list[float]] = {}
    for values in (chosen_values, runner_values):
        scale = values["noise_scale"] / candidates.inner.noise_scale
        wanted.setdefault((values["n_basis"], values["width"]), []).append(scale)
    scored = {
        (basis, scale): float(row.mean())
        for basis, scales in wanted.items()
        for scale, row in zip(scales, candidates(*basis)(scales), strict=True)
    }
    losses = [
        scored[(v["n_basis"], v["width"]), v["noise_scale"] / candidates.inner.noise_scale]
        for v in (chosen_values, runner_values)
    ]
    ranks = [  # the choice's own order: the lower loss, a tie to the closer to the reference
        (round(loss, 9), preference(v["n_basis"], v["width"], v["noise_scale"]))
        for loss, v in zip(losses, (chosen_values, runner_values), strict=True)
    ]
    if not ranks[0] <= ranks[1]:
        return None
    chosen = dataclasses.replace(settings, **chosen_values)
    return chosen, {
        "rule": KEPT_RULE,
        "chosen": {name: getattr(chosen, name) for name in automatic},
        "given": {name: getattr(settings, name) for name in FALLBACK if name not in automatic},
        "log_loss": losses[0],
        "trials": candidates.n_trials,
        "runner_up": {name: runner_values[name] for name in automatic},
        "runner_up_log_loss": losses[1],
        "kept": int(previous.get("kept", 0)) + 1,
    }
