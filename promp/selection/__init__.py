"""The settings chosen from the training demonstrations, by every fit.

The basis count M, its width and the noise scale decide how sharply a primitive's prior
separates the movements it explains from the others, so they are chosen by how well the
resulting model does what the studio does with it: recognise a primitive from the start of a
movement. The score of a candidate is the **recognition log-loss of training demonstrations
held out** (a proper scoring rule, so probabilities are rewarded for being right, not only the
arg-max): a demonstration observed for its first 10, 30, 50, 70 or 90 % (:data:`PERCENTS`),
every modality alone and all of them together, is recognised by a model that has not seen it,
with the speed integrated over each primitive's prior; the loss is ``-ln p(true primitive)``, with
the "none of these" hypothesis of :func:`promp.recognition.with_label_noise`. A candidate
whose mean trajectories leave the box the demonstrations span, widened on every side by its extent
(:func:`within_region`), is never chosen: its predictions would be metres off. Two rules compute it
(``Settings.select``):

* ``"loo"`` (the default): **leave-one-out in closed form**. One model is fitted per candidate
  basis on every demonstration (:func:`promp.fitting.fit_parts`); each trial's demonstration is
  then taken out of it exactly where it matters most: its primitive's mean, regression on
  log alpha and residual scatter, and the pooled scatter every primitive's covariance prior
  borrows from (rank-one downdates; the noise, the ridge and the prior's target and strength
  stay those of the whole set), and its primitive's speed prior. All trials of a modality set
  are scored in one batch (:class:`LooScorer`: Eq. 6 in weight space with the
  Ornstein-Uhlenbeck noise at :data:`LOO_NODES` shared speed nodes, at most :data:`LOO_ROWS`
  samples per observation), every noise scale from the same factorisations, with
  recognition's own speed prior, Student-t and quadrature weights in batch form. The search
  walks from the reference values: M from 7 to its neighbours and on while the loss drops,
  then the width, then the noise scale. At most :data:`LOO_MAX_TRIALS` trials.
* ``"cv"``: **inner cross-validation** (the rule it replaces, kept for comparison). Each
  primitive's demonstrations are dealt into :data:`INNER_FOLDS` folds; a model is fitted
  without each fold for every candidate and recognises its demonstrations
  (recognition's quadrature, :mod:`promp.evidence.speed`, without the refinement of the mode); M
  over :data:`BASIS_GRID` at width 1, then the width over :data:`WIDTH_GRID` at the best M,
  every pair with every noise scale; at most :data:`MAX_TRIALS` trials. About six times
  slower (``bench/evaluate.py``).

The lowest mean loss wins (a tie goes to the candidate closest to the reference settings
:data:`promp.model.FALLBACK`); the same trials score every candidate, so the comparison is
paired. A refit of nearly the same demonstrations (the studio's, after a take) may keep the
previous choice (``previous``, :data:`KEPT_RULE`).

Settings given explicitly are kept (only the others are chosen). With a single primitive
(nothing to recognise) or no primitive of three demonstrations or more (none can lose one and
keep two), nothing can be scored and the fallback values of :data:`promp.model.FALLBACK` are
used; the report says so.

One concept per module:

============== ==============================================================================
``trials``     the trial plan: folds, observed shares, modality sets
``cv``         the inner cross-validation rule
``batches``    the leave-one-out rule's trials laid out: padded observations, shared nodes
``loo``        the closed-form leave-one-out scorer
``region``     the data-region guard
``candidates`` the candidate grids, the tie-break, each candidate basis's scorer
``search``     the leave-one-out rule's search walk
``keep``       keeping the previous choice
``choice``     the choice and its report (:func:`choose_settings`)
============== ==============================================================================
"""

from promp.selection.batches import LOO_NODES, LOO_ROWS
from promp.selection.candidates import BASIS_GRID, NOISE_GRID, WIDTH_GRID
from promp.selection.choice import TEMPERATURE_RULE, choose_settings
from promp.selection.cv import RULE, score
from promp.selection.keep import KEEP_LIMIT, KEPT_RULE
from promp.selection.loo import LooScorer, loo_score
from promp.selection.region import data_region, within_region
from promp.selection.search import LOO_RULE
from promp.selection.trials import (
    INNER_FOLDS,
    LOO_MAX_TRIALS,
    MAX_TRIALS,
    PERCENTS,
    Trial,
    observe_sets,
    plan_trials,
)

__all__ = [
    "BASIS_GRID",
    "INNER_FOLDS",
    "KEEP_LIMIT",
    "KEPT_RULE",
    "LOO_MAX_TRIALS",
    "LOO_NODES",
    "LOO_ROWS",
    "LOO_RULE",
    "MAX_TRIALS",
    "NOISE_GRID",
    "PERCENTS",
    "RULE",
    "TEMPERATURE_RULE",
    "WIDTH_GRID",
    "LooScorer",
    "Trial",
    "choose_settings",
    "data_region",
    "loo_score",
    "observe_sets",
    "plan_trials",
    "score",
    "within_region",
]
