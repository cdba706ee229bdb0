"""The sweep's trials as a viewer log (``python -m promp.evaluate ... --rerun FILE.rrd
--mcap FILE.mcap``).

Every kept trial is in the one file, each held-out demonstration at its own path,
``trials/<method>/<observed>/<alpha>/<primitive>/<demonstration>``, its inferences stepped on
one timeline, the percent observed (:data:`promp.viewers.trial.OBSERVED`): scrubbing it moves
every trial at once, and the path's levels let a viewer show one method, one alpha method or
one primitive's trials side by side. Under each path (:mod:`promp.viewers.trial`): the whole
held-out movement (``truth``), and at each percent what was observed of the position, the
posterior's 90 % region, the predicted mean path and its end; ``p/<primitive>``: each
primitive's probability against the percent, the trial's own numbers (a failed trial: NaN).

The region here is the posterior mean path's, from each coordinate's standard deviation (a
trial keeps no covariance between coordinates): ellipsoids along the axes of the frame. The
studio's Infer tab exports the region of a new sample, with its covariance.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from promp.data import Demonstration, Layout
from promp.evaluate.sweep import SweepResult, Trial
from promp.metrics import position_modality
from promp.timing import n_observed_for
from promp.viewers.scene_log import Color, Item, Note, SceneLog, Strips
from promp.viewers.trial import (
    OBSERVED,
    TRUTH_COLOR,
    path_name,
    probability_series,
    trial_items,
    whole_percents,
)

__all__ = ["NOTE", "PALETTE", "REGION_PROBABILITY", "trial_path", "trials_log"]

# A primitive's colour, by its index (cycled): distinct on a white or a dark background.
PALETTE: tuple[Color, ...] = ((31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189),
                              (140, 86, 75), (227, 119, 194), (23, 190, 207), (188, 189, 34))
REGION_PROBABILITY = 0.9

NOTE = """# Leave-one-out trials

One path per held-out demonstration: `trials/<method>/<observed>/<alpha>/<primitive>/<demo>`.
Timeline `observed_percent`: the percent of the held-out movement observed (MCAP: at that
many seconds).

* `truth`: the whole held-out movement (m);
* `observed`: what was observed of it (m);
* `region`: the posterior mean path's {p:.0%} region, from each coordinate's standard
  deviation (m);
* `predicted`, `end`: the posterior mean path over the predicted duration and its end (m);
* `p/<primitive>`: each primitive's probability.

Positions in metres in the iCub's root frame (z up); angles in radians.
"""


def trial_path(names: Sequence[str], trial: Trial) -> str:
    """The path of ``trial``'s held-out demonstration (see the module docstring)."""
    parts = (trial.method or "method", "+".join(trial.observed), trial.alpha_method,
             names[trial.primitive], trial.demo)  # fmt: skip
    return "trials/" + "/".join(path_name(p) for p in parts)


def _demo(dataset: Mapping[str, Sequence[Demonstration]], primitive: str, name: str):
    for demo in dataset[primitive]:
        if demo.name == name:
            return demo
    raise ValueError(f"the sweep's trial {primitive}/{name} is not in the dataset")


def trials_log(
    result: SweepResult,
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    name: str = "evaluation",
) -> SceneLog:
    """Every trial of ``result`` (kept: ``keep_trials``) as a viewer log.

    Raises
    ------
    ValueError
        No trial kept, a percent that is not whole, a trial of a demonstration not in
        ``dataset``.
    """
    if not result.trials:
        raise ValueError("the sweep kept no trials to show")
    names = list(dataset)
    position = position_modality(layout)
    pos_dims = layout.dims([position])
    if len(pos_dims) != 3:
        pos_dims = None  # no 3-D position: only the probabilities
    groups: dict[str, list[Trial]] = {}
    for trial in result.trials:
        groups.setdefault(trial_path(names, trial), []).append(trial)
    items: list[Item] = [Note("about", NOTE.format(p=REGION_PROBABILITY))]
    for prefix, trials in groups.items():
        trials = sorted(trials, key=lambda t: t.percent)
        percents = whole_percents([t.percent for t in trials])
        demo = _demo(dataset, names[trials[0].primitive], trials[0].demo)
        whole = layout.extract(demo)
        if pos_dims is not None:
            items.append(Strips(f"{prefix}/truth", (whole[:, pos_dims],), TRUTH_COLOR, 0.002))
        probabilities = np.full((len(trials), len(names)), np.nan)
        for i, (trial, percent) in enumerate(zip(trials, percents, strict=True)):
            answer = trial.inferred
            if answer is None:
                continue
            probabilities[i] = answer.probabilities
            if pos_dims is None or not np.all(np.isfinite(answer.posterior_mean[:, pos_dims])):
                continue  # a baseline only recognises
            mean = answer.posterior_mean[:, pos_dims]
            std = answer.posterior_std[:, pos_dims]
            n_o = n_observed_for(trial.percent, demo.n_samples)
            observed = whole[:n_o, pos_dims] if position in trial.observed else None
            color = PALETTE[answer.index % len(PALETTE)]
            items += trial_items(prefix, percent, observed, mean,
                                 std[:, :, None] ** 2 * np.eye(3), mean, color,
                                 REGION_PROBABILITY)  # fmt: skip
        items += probability_series(prefix, names, percents, probabilities)
    return SceneLog(path_name(name), (OBSERVED,), tuple(items))
