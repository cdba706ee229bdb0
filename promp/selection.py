"""The settings chosen from the training demonstrations, by every fit.

The basis count M, its width and the noise scale decide how sharply a primitive's prior
separates the movements it explains from the others, so they are chosen by how well the
resulting model does what the studio does with it: recognise a primitive from the start of a
movement. The score of a candidate is its **cross-validated recognition log-loss inside the
training demonstrations** (a proper scoring rule, so probabilities are rewarded for being
right, not only the arg-max): each primitive's demonstrations are split into
:data:`INNER_FOLDS` folds; a model is fitted without each fold (with the candidate settings,
its covariance prior still chosen by marginal likelihood) and recognises that fold's
demonstrations from their first 10, 30, 50, 70 and 90 % (:data:`PERCENTS`), every modality
alone and all of them together; the loss is ``-ln p(true primitive)`` with the speed
integrated over its prior (:func:`promp.recognition.recognise`'s quadrature, without the
refinement of the mode). The lowest mean loss wins (a tie goes to the candidate closest to the
reference settings :data:`promp.model.FALLBACK`). A candidate whose inner models' mean
trajectories leave the box the demonstrations span, widened on every side by its extent
(:func:`within_region`), is never chosen: its predictions would be metres off.

The cost is bounded: at most :data:`MAX_TRIALS` (demonstration, percentage, modalities)
trials per candidate, spread evenly over the primitives, the folds, the percentages and the
modality sets (each trial a different demonstration while there are enough); a fold without a
trial is not fitted; the noise scale costs almost nothing, since the likelihood at every scale of
:data:`NOISE_GRID` shares one evaluation of the basis and its eigendecompositions
(:func:`promp._likelihood.log_likelihoods_scaled`). M is searched over :data:`BASIS_GRID` at
width 1, then the width over :data:`WIDTH_GRID` at the best M (two line searches rather than the
whole grid), every pair with every noise scale. The same trials score every candidate, so the
comparison is paired.

Settings given explicitly are kept (only the others are chosen). With a single primitive
(nothing to recognise) or no primitive of three demonstrations or more (none can lose one and
keep two), nothing can be scored and the fallback values of :data:`promp.model.FALLBACK` are
used; the report says so.
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from collections.abc import Mapping, Sequence

import numpy as np

from promp._likelihood import log_likelihoods_scaled
from promp.data import Demonstration, Layout
from promp.model import FALLBACK, ProMPModel, Settings, fit_with
from promp.observation import Observation
from promp.quality import winsorized
from promp.recognition import (
    AlphaPrior,
    label_noise,
    quadrature,
    quadrature_weights,
    with_label_noise,
)
from promp.timing import n_observed_for

BASIS_GRID = (5, 7, 10, 14)
WIDTH_GRID = (0.7, 1.0, 1.5)
NOISE_GRID = (1.0, 1.4, 2.0, 2.8, 4.0)  # factors of sqrt(2)
INNER_FOLDS = 3
MAX_TRIALS = 30
PERCENTS = (10, 30, 50, 70, 90)
RULE = (
    f"{INNER_FOLDS}-fold cross-validated recognition log-loss inside the training "
    f"demonstrations ({', '.join(map(str, PERCENTS))} % observed, every modality alone and all "
    f"together, at most {MAX_TRIALS} trials per candidate); M over {list(BASIS_GRID)} at width "
    f"1, then the width over {list(WIDTH_GRID)}, each with every noise scale of "
    f"{list(NOISE_GRID)}; the lowest mean loss among the candidates whose mean trajectories "
    "stay within the box the demonstrations span, widened by its extent"
)


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
    dataset: Mapping[str, Sequence[Demonstration]], layout: Layout, seed: int = 0
) -> list[Trial]:
    """The inner folds and trials (see the module docstring); empty when nothing can be scored.

    Each primitive of three demonstrations or more has its demonstrations shuffled (a seed
    fixed per primitive name) and dealt into :data:`INNER_FOLDS` folds; the others are never
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
            rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
            order = rng.permutation(len(demos))
            queues.append([(k, int(j), i % INNER_FOLDS) for i, j in enumerate(order)])
    if not queues:
        return []
    # Round robin over the primitives, so every primitive is tested as often as it can be.
    held_out = [q[i] for i in range(max(map(len, queues))) for q in queues if i < len(q)]
    combos = [(p, m) for m in observe_sets(layout) for p in PERCENTS]
    n_trials = min(MAX_TRIALS, len(held_out) * len(combos))
    trials = []
    for i in range(n_trials):
        k, j, fold = held_out[i % len(held_out)]
        # shifted at every pass over the demonstrations: a demonstration seen twice is seen
        # at another percentage
        percent, modalities = combos[(i + i // len(held_out)) % len(combos)]
        trials.append(Trial(k, j, fold, float(percent), modalities))
    return trials


def _rows_logsumexp(values: np.ndarray) -> np.ndarray:
    """:func:`promp._likelihood.logsumexp` of every row of ``values`` (2-D) at once."""
    top = values.max(axis=-1)
    finite = np.isfinite(top)
    out = top.copy()
    shifted = values[finite] - top[finite, None]
    out[finite] = top[finite] + np.log(np.exp(shifted).sum(axis=-1))
    return out


def _losses(
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
        obs = Observation.from_demo(
            model, demo, n_observed_for(trial.percent, demo.n_samples), trial.modalities
        )
        quadratures = []
        for prior in priors:
            nodes, log_prior, log_mass = quadrature(model, obs, prior)
            quadratures.append((np.exp(nodes), quadrature_weights(nodes, log_prior, log_mass)))
        cache[trial] = (obs, quadratures)
    obs, quadratures = cache[trial]
    evidence = np.empty((factors.shape[0], len(model.primitives)))
    for k, (primitive, (alphas, log_w)) in enumerate(
        zip(model.primitives, quadratures, strict=True)
    ):
        table = log_likelihoods_scaled(model, primitive, obs, alphas, factors)
        evidence[:, k] = _rows_logsumexp(table + log_w)
    total = _rows_logsumexp(evidence)
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
    :func:`_losses`; the same ``dataset``, ``trials``, ``dt`` and ``s_bar``).
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
                out[:, i] = _losses(model, demo, trial, priors, factors, cache)
    return out


def data_region(
    dataset: Mapping[str, Sequence[Demonstration]], layout: Layout
) -> tuple[np.ndarray, np.ndarray]:
    """The box the demonstrations span, widened on every side by its own extent: (low, high),
    shape (n_dims,) each. A modality's extent is its largest range over its dimensions (a
    dimension that hardly moves is not held to its own few millimetres)."""
    values = np.concatenate([layout.extract(d) for demos in dataset.values() for d in demos])
    low, high = values.min(axis=0), values.max(axis=0)
    extent = np.empty(layout.n_dims)
    for modality in layout.modalities:
        dims = layout.dims([modality.name])
        extent[dims] = float((high - low)[dims].max())
    return low - extent, high + extent


REGION_PHASES = np.linspace(0.0, 1.0, 51)


def within_region(model: ProMPModel, low: np.ndarray, high: np.ndarray) -> bool:
    """Whether every primitive's mean trajectory, at the slowest and the fastest of its
    training speeds (winsorized, as the coupling of shape and speed saw them), stays inside
    [``low``, ``high``] (:func:`data_region`): a candidate whose predictions leave the region
    the demonstrations span is never chosen."""
    phi = model.basis(REGION_PHASES)
    for primitive in model.primitives:
        logs = winsorized(np.log(primitive.alphas))
        alphas = np.exp([logs.min(), logs.max()])
        means = primitive.mean_at(alphas).reshape(2, model.n_dims, -1)
        paths = means @ phi.T  # (2, n_dims, n_phases)
        if np.any(paths < low[None, :, None]) or np.any(paths > high[None, :, None]):
            return False
    return True


def _preference(n_basis: int, width: float, noise_scale: float) -> float:
    """Distance from the fallback settings: breaks ties (e.g. every candidate perfect)."""
    return (
        abs(math.log(n_basis / FALLBACK["n_basis"]))
        + abs(math.log(width / FALLBACK["width"]))
        + abs(math.log(noise_scale / FALLBACK["noise_scale"]))
    )


def choose_settings(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
) -> tuple[Settings, dict]:
    """``settings`` with every automatic one (None) chosen from ``dataset``, and the report of
    the choice (JSON-ready: the rule, the values chosen, the score of every candidate).

    Parameters
    ----------
    dataset : mapping of str to list of Demonstration
        The training demonstrations of every primitive.
    dt : float
        The sample period (s) the model will use.
    """
    automatic = settings.automatic
    given = {name: getattr(settings, name) for name in FALLBACK if name not in automatic}
    trials = plan_trials(dataset, layout)
    if not trials:
        reason = (
            "a single primitive: nothing to recognise"
            if len(dataset) < 2
            else "no primitive has three demonstrations: none can be held out"
        )
        chosen = settings.with_fallback()
        return chosen, {
            "rule": f"fallback values ({reason})",
            "chosen": {name: getattr(chosen, name) for name in automatic},
            "given": given,
        }
    fixed_scale = settings.noise_scale
    inner = dataclasses.replace(settings, noise_scale=fixed_scale or 1.0)
    scales = NOISE_GRID if fixed_scale is None else (1.0,)
    basis_grid = BASIS_GRID if settings.n_basis is None else (settings.n_basis,)
    width_grid = WIDTH_GRID if settings.width is None else (settings.width,)
    start_width = 1.0 if settings.width is None else settings.width
    scores: dict[tuple[int, float], np.ndarray] = {}
    cache: dict = {}  # every candidate's observations and quadratures (see _losses)
    region = data_region(dataset, layout)

    def evaluate(n_basis: int, width: float) -> float:
        if (n_basis, width) not in scores:
            candidate = dataclasses.replace(inner, n_basis=n_basis, width=width)
            scores[(n_basis, width)] = score(
                dataset, layout, candidate, dt, trials, scales, cache, region
            )
        return float(scores[(n_basis, width)].mean(axis=1).min())

    best_basis = min(basis_grid, key=lambda m: (evaluate(m, start_width), abs(m - 7)))
    for width in width_grid:
        evaluate(best_basis, width)
    table = [
        (m, w, s * inner.noise_scale, losses)
        for (m, w), rows in scores.items()
        for s, losses in zip(scales, rows, strict=True)
    ]
    if not any(np.isfinite(c[3]).all() for c in table):
        chosen = settings.with_fallback()
        return chosen, {
            "rule": "fallback values (every candidate's mean trajectory left the region the "
            "demonstrations span)",
            "chosen": {name: getattr(chosen, name) for name in automatic},
            "given": given,
        }
    # the lowest mean loss; a tie (e.g. every candidate perfect) goes to the reference
    n_basis, width, noise_scale, losses = min(
        table, key=lambda c: (round(float(c[3].mean()), 9), _preference(*c[:3]))
    )
    chosen = dataclasses.replace(settings, n_basis=n_basis, width=width, noise_scale=noise_scale)
    return chosen, {
        "rule": RULE,
        "chosen": {name: getattr(chosen, name) for name in automatic},
        "given": given,
        "log_loss": float(losses.mean()),
        "trials": len(trials),
        "candidates": [
            {"n_basis": m, "width": w, "noise_scale": [s * inner.noise_scale for s in scales],
             "log_loss": [round(float(x), 6) if np.isfinite(x) else None
                          for x in rows.mean(axis=1)]}
            for (m, w), rows in scores.items()
        ],
    }  # fmt: skip
