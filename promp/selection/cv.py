"""The inner cross-validation rule (``Settings(select="cv")``, the rule the closed-form
leave-one-out replaced, kept for comparison): each primitive's demonstrations dealt into
:data:`~promp.selection.trials.INNER_FOLDS` folds, a model fitted without each fold for every
candidate, recognising its demonstrations with recognition's quadrature
(:mod:`promp.evidence.speed`, without the refinement of the mode); M over the whole basis grid at
width 1, then the width at the best M, every pair with every noise scale. About six times slower
than the leave-one-out rule (``bench/evaluate.py``)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from promp.data import Demonstration, Layout
from promp.evidence.evidence import Evidence
from promp.evidence.speed import (
    AlphaPrior,
    logsumexp_rows,
    longest_alpha,
    quadrature,
    quadrature_weights,
)
from promp.fitting import fit_with
from promp.model import ProMPModel, Settings
from promp.observation import Observation
from promp.recognition import label_noise, with_label_noise
from promp.selection.candidates import BASIS_GRID, NOISE_GRID, WIDTH_GRID
from promp.selection.region import within_region
from promp.selection.trials import INNER_FOLDS, MAX_TRIALS, PERCENTS, Trial

__all__ = ["RULE", "cv_search", "score", "trial_losses"]


RULE = (
    f"{INNER_FOLDS}-fold cross-validated recognition log-loss inside the training "
    f"demonstrations ({', '.join(map(str, PERCENTS))} % observed, every modality alone and all "
    f"together, at most {MAX_TRIALS} trials per candidate); M over {list(BASIS_GRID)} at width "
    f"1, then the width over {list(WIDTH_GRID)}, each with every noise scale of "
    f"{list(NOISE_GRID)}; the lowest mean loss among the candidates whose mean trajectories "
    "stay within the box the demonstrations span, widened by its extent"
)


def trial_losses(
    model: ProMPModel,
    demo: Demonstration,
    trial: Trial,
    priors: Sequence[AlphaPrior],
    factors: np.ndarray,
    cache: dict | None = None,
) -> np.ndarray:
    """``-ln p(true primitive)`` of one trial at every noise level, shape (n_levels,).

    ``cache`` keeps the observation and each primitive's quadrature (nodes and log weights)
    under the trial: they depend on the fold's training alphas, never on the candidate
    settings, so every candidate reuses them.
    """
    cache = {} if cache is None else cache
    if trial not in cache:
        obs = Observation.first(model, demo, trial.percent, trial.modalities)
        quadratures, bound = [], math.log(longest_alpha(model, obs))
        for prior in priors:
            nodes, log_prior, log_mass = quadrature(prior, bound)
            quadratures.append((np.exp(nodes), quadrature_weights(nodes, log_prior, log_mass)))
        cache[trial] = (obs, quadratures)
    obs, quadratures = cache[trial]
    scored = Evidence(model, obs)
    evidence = np.empty((factors.shape[0], len(model.primitives)))
    for k, (primitive, (alphas, log_w)) in enumerate(
        zip(model.primitives, quadratures, strict=True)
    ):
        table = scored.log_likelihoods(primitive, alphas, factors)
        evidence[:, k] = logsumexp_rows(table + log_w)
    total = logsumexp_rows(evidence)
    # what recognise reports: the model's probability with the "none of these" hypothesis;
    # nothing explains the observation: a uniform guess, as in the evaluation
    with np.errstate(invalid="ignore"):
        p_true = with_label_noise(np.exp(evidence - total[:, None]), label_noise(model))
    return np.where(
        np.isfinite(total), -np.log(p_true[:, trial.primitive]), math.log(evidence.shape[1])
    )


def score(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
    trials: Sequence[Trial],
    noise_scales: Sequence[float],
    cache: dict | None = None,
    region: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Inner log-loss of ``settings`` (n_basis and width given) at every noise scale, per
    trial: shape (n_scales, n_trials), in the order of ``trials``; infinite everywhere when
    an inner model's mean trajectory leaves ``region`` (:func:`within_region`).

    ``settings.noise_scale`` (1 when it is chosen here) is the scale the inner models are
    fitted with; ``noise_scales`` multiply it (modalities of ``settings.noise_std`` keep
    their given noise). ``cache``: shared by the candidates of one choice (see
    :func:`trial_losses`; the same ``dataset``, ``trials``, ``dt`` and ``s_bar``).
    """
    names = list(dataset)
    scaled = np.array([name not in settings.noise_std for name in layout.names])
    per_dim = np.concatenate(
        [np.full(len(m.columns), s) for m, s in zip(layout.modalities, scaled, strict=True)]
    )
    factors = np.where(per_dim[None, :], np.square(noise_scales)[:, None], 1.0)
    out = np.zeros((len(noise_scales), len(trials)))
    for fold in sorted({t.fold for t in trials}):
        held = {(t.primitive, t.demo) for t in trials if t.fold == fold}
        train = {
            name: [d for j, d in enumerate(demos) if (k, j) not in held]
            for k, (name, demos) in enumerate(dataset.items())
        }
        model = fit_with(train, layout, settings, dt, alpha_models=False)
        if region is not None and not within_region(model, *region):
            return np.full((len(noise_scales), len(trials)), np.inf)
        priors = [AlphaPrior.from_alphas(p.alphas, settings.s_bar) for p in model.primitives]
        for i, trial in enumerate(trials):
            if trial.fold == fold:
                demo = dataset[names[trial.primitive]][trial.demo]
                out[:, i] = trial_losses(model, demo, trial, priors, factors, cache)
    return out


def cv_search(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    inner: Settings,
    dt: float,
    trials: Sequence[Trial],
    scales: Sequence[float],
    grids: tuple[Sequence[int], Sequence[float]],
    start_width: float,
    region: tuple[np.ndarray, np.ndarray],
    scores: dict,
) -> None:
    """The inner cross-validation's search, filling ``scores`` ({(M, width): {scale:
    losses}}): every M of ``grids[0]`` at ``start_width``, then every width of ``grids[1]``
    at the best M (a tie to the M closest to 7), each candidate at every noise scale;
    ``inner`` the settings the inner models are fitted with (see :func:`score`)."""
    basis_grid, width_grid = grids
    cache: dict = {}  # every candidate's observations and quadratures (see trial_losses)

    def evaluate(n_basis: int, width: float) -> float:
        if (n_basis, width) not in scores:
            candidate = dataclasses.replace(inner, n_basis=n_basis, width=width)
            rows = score(dataset, layout, candidate, dt, trials, scales, cache, region)
            scores[(n_basis, width)] = dict(zip(scales, rows, strict=True))
        return min(float(r.mean()) for r in scores[(n_basis, width)].values())

    best_basis = min(basis_grid, key=lambda m: (evaluate(m, start_width), abs(m - 7)))
    for width in width_grid:
        evaluate(best_basis, width)
