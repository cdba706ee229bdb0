"""The settings chosen from the training demonstrations, by every fit.

The basis count M, its width and the noise scale decide how sharply a primitive's prior
separates the movements it explains from the others, so they are chosen by how well the
resulting model does what the studio does with it: recognise a primitive from the start of a
movement. The score of a candidate is the **recognition log-loss of training demonstrations
held out** (a proper scoring rule, so probabilities are rewarded for being right, not only the
arg-max): a demonstration observed for its first 10, 30, 50, 70 or 90 % (:data:`PERCENTS`),
every modality alone and all of them together, is recognised by a model that has not seen it,
with the speed integrated over each primitive's prior; the loss is ``-ln p(true primitive)``,
with the "none of these" hypothesis of :func:`promp.recognition.with_label_noise`. A candidate
whose mean trajectories leave the box the demonstrations span, widened on every side by its
extent (:func:`within_region`), is never chosen: its predictions would be metres off. Two rules
compute it (``Settings.select``):

* ``"loo"`` (the default): **leave-one-out in closed form**. One model is fitted per candidate
  basis on every demonstration (:func:`promp.model.fit_parts`); each trial's demonstration is
  then taken out of it exactly where it matters most: its primitive's mean, regression on
  log alpha and residual scatter, and the pooled scatter every primitive's covariance prior
  borrows from (rank-one downdates; the noise, the ridge and the prior's target and strength
  stay those of the whole set), and its primitive's speed prior. All trials of a modality set
  are scored in one batch (:class:`LooScorer`: Eq. 6 in weight space with the
  Ornstein-Uhlenbeck noise at :data:`LOO_NODES` shared speed nodes, at most :data:`LOO_ROWS`
  samples per observation), every noise scale from the same factorisations. The search walks
  from the reference values (:func:`_walk`): M from 7 to its neighbours and on while the loss
  drops, then the width, then the noise scale. At most :data:`LOO_MAX_TRIALS` trials.
  ``tests/test_promp_selection.py`` checks the downdates against refits and the batched score
  against the engine's own likelihood.
* ``"cv"``: **inner cross-validation** (the rule it replaces, kept for comparison). Each
  primitive's demonstrations are dealt into :data:`INNER_FOLDS` folds; a model is fitted
  without each fold for every candidate and recognises its demonstrations
  (:func:`promp.recognition.recognise`'s quadrature, without the refinement of the mode); M
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
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from collections.abc import Mapping, Sequence

import numpy as np
from scipy import special

from promp._likelihood import log_likelihoods_scaled
from promp._weight_space import equilibrated_precision
from promp.data import Demonstration, Layout
from promp.duration import choose_temperature
from promp.model import FALLBACK, FitParts, ProMPModel, Settings, fit_parts, fit_with
from promp.observation import Observation
from promp.quality import DURATION_FACTOR, OUTLIER_Z, winsorized
from promp.recognition import (
    MAX_SPAN,
    TAIL,
    AlphaPrior,
    label_noise,
    quadrature,
    quadrature_weights,
    with_label_noise,
)
from promp.timing import alpha_from_duration, duration_from_alpha, n_observed_for

BASIS_GRID = (5, 7, 10, 14)
WIDTH_GRID = (0.7, 1.0, 1.5)
NOISE_GRID = (1.0, 1.4, 2.0, 2.8, 4.0)  # factors of sqrt(2)
INNER_FOLDS = 3
MAX_TRIALS = 30
LOO_MAX_TRIALS = 30
LOO_NODES = 12
LOO_ROWS = 48
PERCENTS = (10, 30, 50, 70, 90)
RULE = (
    f"{INNER_FOLDS}-fold cross-validated recognition log-loss inside the training "
    f"demonstrations ({', '.join(map(str, PERCENTS))} % observed, every modality alone and all "
    f"together, at most {MAX_TRIALS} trials per candidate); M over {list(BASIS_GRID)} at width "
    f"1, then the width over {list(WIDTH_GRID)}, each with every noise scale of "
    f"{list(NOISE_GRID)}; the lowest mean loss among the candidates whose mean trajectories "
    "stay within the box the demonstrations span, widened by its extent"
)

LOO_RULE = (
    "recognition log-loss of the training demonstrations, each left out of its model in "
    f"closed form ({', '.join(map(str, PERCENTS))} % observed, every modality alone and all "
    f"together, the speed integrated over its prior; at most {LOO_MAX_TRIALS} trials, one fit "
    f"per basis); a walk from the reference: M over {list(BASIS_GRID)} from 7 and both its "
    f"neighbours on while the loss drops, then the width over {list(WIDTH_GRID)}, then the "
    f"noise scale over {list(NOISE_GRID)}; the lowest mean loss among the candidates whose "
    "mean trajectories stay within the box the demonstrations span, widened by its extent"
)

TEMPERATURE_RULE = (
    "the largest power of the likelihood in the speed's posterior (of 1, 1/sqrt 2, ..., 1/256) "
    "whose 90 % intervals hold the true speed of at least ceil(0.9 (n + 1)) / n of the n "
    "held-out training demonstrations (nested conformal; the same trials, closed-form "
    "leave-one-out, at the chosen settings)"
)

KEEP_LIMIT = 10
KEPT_RULE = (
    "kept from the previous fit: on these demonstrations' trials the choice still has a lower "
    "leave-one-out loss than the runner-up of the last search (the search runs again when it "
    f"does not, and after {KEEP_LIMIT} refits kept in a row)"
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
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    seed: int = 0,
    max_trials: int = MAX_TRIALS,
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
    n_trials = min(max_trials, len(held_out) * len(combos))
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


@dataclasses.dataclass(frozen=True, eq=False)
class _Batch:
    """The trials of one modality set, laid out for :func:`loo_score` (independent of the
    candidate settings: built once per choice). ``index``: their positions in the plan."""

    index: list[int]
    truth: np.ndarray  # (T,) true primitive
    demos: list[int]  # (T,) demonstration within its primitive
    dims: np.ndarray  # (Do,)
    elapsed: np.ndarray  # (T, n) padded with the last value
    mask: np.ndarray  # (T, n) real rows
    values: np.ndarray  # (T, n, Do) zero-padded
    log_alphas: np.ndarray  # (T, A) quadrature nodes shared by the primitives
    log_weights: np.ndarray  # (T, K, A) each primitive's log quadrature weights
    true_log_alphas: np.ndarray  # (T,) each trial's demonstration's own speed


def _batches(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    trials: Sequence[Trial],
    dt: float,
    s_bar: float,
) -> list[_Batch]:
    """The trials grouped by modality set, each observation padded, with the quadrature
    nodes: :data:`LOO_NODES` equally spaced in log alpha over the union of the primitives'
    priors (each primitive's prior from its training alphas, the held-out demonstration's
    own primitive without it), truncated at the longest alpha the observation allows."""
    names = list(dataset)
    alphas = [
        np.array([alpha_from_duration(d.duration, dt, s_bar) for d in dataset[name]])
        for name in names
    ]
    full = [AlphaPrior.from_alphas(a, s_bar) for a in alphas]
    loo: dict[int, np.ndarray] = {}  # a primitive's priors without each of its own
    extracted: dict[Demonstration, np.ndarray] = {}  # each demonstration's values, once
    out = []
    for modalities in sorted({t.modalities for t in trials}):
        index = [i for i, t in enumerate(trials) if t.modalities == modalities]
        batch = [trials[i] for i in index]
        dims = layout.dims(modalities)
        demos = [dataset[names[t.primitive]][t.demo] for t in batch]
        n_obs = [n_observed_for(t.percent, d.n_samples) for t, d in zip(batch, demos, strict=True)]
        width = min(max(n_obs), LOO_ROWS)
        elapsed = np.empty((len(batch), width))
        mask = np.zeros((len(batch), width), dtype=bool)
        values = np.zeros((len(batch), width, dims.shape[0]))
        # each trial's priors, one (single) component each: (T, K) locations, scales, dofs
        params = np.empty((3, len(batch), len(names)))
        for i, (trial, demo, n) in enumerate(zip(batch, demos, n_obs, strict=True)):
            rows = _rows(n)
            e = demo.times[rows] - demo.times[0]
            elapsed[i, : rows.size], elapsed[i, rows.size :] = e, e[-1]
            mask[i, : rows.size] = True
            if demo not in extracted:
                extracted[demo] = layout.extract(demo)
            values[i, : rows.size] = extracted[demo][rows][:, dims]
            if trial.primitive not in loo:
                loo[trial.primitive] = _loo_priors(alphas[trial.primitive], s_bar)
            params[:, i] = [[p.locs[0] for p in full], [p.scales[0] for p in full],
                            [p.dofs[0] for p in full]]  # fmt: skip
            params[:, i, trial.primitive] = loo[trial.primitive][:, trial.demo]
        bounds = np.log(s_bar / (elapsed[:, -1] / dt + 1.0))  # (T,) the longest alpha
        log_alphas, log_weights = _quadrature_grid(*params, bounds)
        truth_alphas = np.array([alphas[t.primitive][t.demo] for t in batch])
        out.append(
            _Batch(
                index, np.array([t.primitive for t in batch]), [t.demo for t in batch], dims,
                elapsed, mask, values, log_alphas, log_weights, np.log(truth_alphas),
            )
        )  # fmt: skip
    return out


def _loo_priors(alphas: np.ndarray, s_bar: float) -> np.ndarray:
    """:meth:`promp.recognition.AlphaPrior.from_alphas` of ``alphas`` without each one in
    turn, all at once: (location, scale, dof) x n."""
    logs = np.log(np.asarray(alphas, dtype=float))
    n = logs.shape[0]
    others = np.broadcast_to(logs, (n, n))[~np.eye(n, dtype=bool)].reshape(n, n - 1)
    # winsorized, row by row (promp.quality.ordinary)
    centre = np.median(others, axis=1, keepdims=True)
    spread = np.median(np.abs(others - centre), axis=1, keepdims=True) / 0.6745
    bound = np.maximum(OUTLIER_Z * spread, math.log(DURATION_FACTOR))
    keep = np.abs(others - centre) <= bound
    low = np.where(keep, others, np.inf).min(axis=1, keepdims=True)
    high = np.where(keep, others, -np.inf).max(axis=1, keepdims=True)
    others = np.clip(others, low, high)
    loc = others.mean(axis=1)
    spread = others.std(axis=1, ddof=1) if n > 2 else np.zeros(n)
    floor = np.maximum(np.exp(loc) / s_bar, 1e-3)
    scale = np.maximum(spread * math.sqrt(1.0 + 1.0 / (n - 1)), floor)
    return np.stack([loc, scale, np.full(n, float(max(n - 2, 1)))])


def _quadrature_grid(
    locs: np.ndarray, scales: np.ndarray, dofs: np.ndarray, bounds: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:data:`LOO_NODES` nodes per trial spanning every primitive's prior (Student-t in log
    alpha, parameters (T, K)) as :meth:`promp.recognition.AlphaPrior.span` does, truncated at
    the trial's bound (T,); and each primitive's log quadrature weights there, (T, K, A),
    normalised to its prior mass below the bound (:func:`promp.recognition.quadrature_weights`
    for every trial and primitive at once)."""
    lo = np.maximum(locs + scales * special.stdtrit(dofs, TAIL), locs - MAX_SPAN)
    hi = np.minimum(locs + scales * special.stdtrit(dofs, 1.0 - TAIL), locs + MAX_SPAN)
    hi = np.minimum(hi, bounds[:, None])
    empty = hi <= lo  # every plausible speed ends too early: the tail just below the bound
    lo = np.where(empty, bounds[:, None] - 4.0 * scales, lo)
    hi = np.where(empty, bounds[:, None], hi)
    steps = np.linspace(0.0, 1.0, LOO_NODES)
    start, stop = lo.min(axis=1), hi.max(axis=1)
    nodes = start[:, None] + (stop - start)[:, None] * steps  # (T, A)
    z = (nodes[:, None, :] - locs[..., None]) / scales[..., None]
    d = dofs[..., None]
    log_prior = (  # Student-t log density, per unit of log alpha
        special.gammaln((d + 1) / 2) - special.gammaln(d / 2) - 0.5 * np.log(d * math.pi)
        - (d + 1) / 2 * np.log1p(z**2 / d) - np.log(scales)[..., None]
    )  # fmt: skip
    with np.errstate(divide="ignore"):
        log_mass = np.log(special.stdtr(dofs, (bounds[:, None] - locs) / scales))  # (T, K)
    log_w = log_prior + np.log(np.gradient(nodes, axis=1))[:, None, :]
    top = log_w.max(axis=-1, keepdims=True)
    norm = top + np.log(np.exp(log_w - top).sum(axis=-1, keepdims=True))
    return nodes, log_w + log_mass[..., None] - norm


def _rows(n: int) -> np.ndarray:
    """The samples of an ``n``-sample observation a trial scores: all of them, or
    :data:`LOO_ROWS` evenly spread from the first to the last (the noise model is a process in
    time, so fewer samples are scored as what they are: observations further apart)."""
    if n <= LOO_ROWS:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, LOO_ROWS)).astype(int))


def _whiten_padded(elapsed: np.ndarray, mask: np.ndarray, tau: float, x: np.ndarray) -> np.ndarray:
    """:func:`promp.noise.whiten` along axis -2 of padded observations (..., T, [A,] n, k):
    ``elapsed``/``mask`` (T, n) broadcast over the axes between; padded rows come out zero."""
    extra = x.ndim - 3  # axes between T and n
    shape = (elapsed.shape[0],) + (1,) * extra + (elapsed.shape[1], 1)
    keep = mask.reshape(shape)
    if tau <= 0:
        return np.where(keep, x, 0.0)
    step = np.diff(elapsed, axis=1)
    rho = np.exp(-np.where(step > 0, step, np.inf) / tau).reshape(shape[:-2] + (-1, 1))
    out = np.array(x, dtype=float, copy=True)
    out[..., 1:, :] = (x[..., 1:, :] - rho * x[..., :-1, :]) / np.sqrt(1.0 - rho**2)
    return np.where(keep, out, 0.0)


def loo_score(
    fitted: tuple[ProMPModel, Sequence[FitParts]],
    batches: Sequence[_Batch],
    n_trials: int,
    noise_scales: Sequence[float],
    region: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """:func:`score` by the closed-form leave-one-out rule: shape (n_scales, n_trials),
    ``-ln p(true primitive)`` of every trial; infinite everywhere when the model's mean
    trajectories leave ``region``.

    ``fitted``: the model fitted on every demonstration with the candidate settings (noise
    scale 1, or the one given), and its parts (:func:`promp.model.fit_parts`). A trial's
    demonstration is then left out of its own primitive exactly for the mean, the regression
    on log alpha and the residual scatter (rank-one downdates, :class:`promp.model.FitParts`),
    while the noise, the ridge and the pooled prior's target and strength stay those of the
    whole set (an approximation: one demonstration moves them little). Each primitive's
    likelihood (Eq. 6 in weight space, with the Ornstein-Uhlenbeck noise) is integrated over
    its speed prior on the batch's nodes, as :func:`promp.recognition.recognise` does; the
    terms every primitive shares (the noise determinant) cancel in the posterior.
    """
    return LooScorer(fitted, batches, n_trials, region)(noise_scales)


class LooScorer:
    """:func:`loo_score` of one candidate at any noise scales: what does not depend on the
    scale (the observations' whitened statistics against every primitive's prior, the
    downdated covariances' factorisations) is computed once per batch, on first use."""

    def __init__(
        self,
        fitted: tuple[ProMPModel, Sequence[FitParts]],
        batches: Sequence[_Batch],
        n_trials: int,
        region: tuple[np.ndarray, np.ndarray] | None = None,
    ):
        self.model, self.parts = fitted
        self.batches, self.n_trials = batches, n_trials
        self.inside = region is None or within_region(self.model, *region)
        self._setups: dict[int, tuple] = {}
        # per noise scale: each batch's true primitive's log-likelihood at every node, (T, A)
        self._speed_tables: dict[float, dict[int, np.ndarray]] = {}

    def __call__(self, noise_scales: Sequence[float]) -> np.ndarray:
        """``-ln p(true primitive)`` of every trial at every scale, (n_scales, n_trials)."""
        model, settings = self.model, self.model.settings
        layout = model.layout
        n_scales = len(noise_scales)
        out = np.empty((n_scales, self.n_trials))
        if not self.inside:
            out[:] = np.inf
            return out
        n_prims, m = len(model.primitives), model.basis.n_basis
        scaled = np.array([name not in settings.noise_std for name in layout.names])
        per_dim = np.concatenate(
            [np.full(len(mod.columns), s) for mod, s in zip(layout.modalities, scaled, strict=True)]
        )
        factors = np.where(per_dim[None, :], np.square(noise_scales)[:, None], 1.0)
        noise_var = model.primitives[0].noise_var  # pooled: the same for every primitive
        eps = label_noise(model)
        for i, batch in enumerate(self.batches):
            if i not in self._setups:
                self._setups[i] = self._setup(batch)
            precision, logdet_sigma, gram, proj, rr = self._setups[i]
            dims = batch.dims
            n_t, n_a = batch.log_alphas.shape
            n_do = dims.shape[0]
            p = n_do * m
            inv_s2 = 1.0 / (noise_var[dims][None, :] * factors[:, dims])  # (L, Do)
            bordered = np.empty((n_t, n_prims, n_a, p + 1, p + 1))
            for level in range(n_scales):
                bordered[..., :p, :p] = precision[:, :, None]
                for d in range(n_do):
                    block = slice(d * m, (d + 1) * m)
                    bordered[..., block, block] += inv_s2[level, d] * gram[:, None, :, d]
                b = (inv_s2[level, :, None] * proj).reshape(n_t, n_prims, n_a, p)
                bordered[..., :p, p] = b
                bordered[..., p, :p] = b
                bordered[..., p, p] = rr @ inv_s2[level] + 1.0
                diag = np.diagonal(np.linalg.cholesky(bordered), axis1=-2, axis2=-1)
                log_lik = -0.5 * (
                    diag[..., p] ** 2
                    - 1.0
                    + 2.0 * np.log(diag[..., :p]).sum(-1)
                    + logdet_sigma[..., None]
                )  # (T, K, A), without the terms every primitive shares
                self._speed_tables.setdefault(float(noise_scales[level]), {})[i] = log_lik[
                    np.arange(n_t), batch.truth
                ]
                evidence = _rows_logsumexp((log_lik + batch.log_weights).reshape(-1, n_a))
                evidence = evidence.reshape(n_t, n_prims)
                total = _rows_logsumexp(evidence)
                with np.errstate(invalid="ignore", over="ignore"):
                    p_all = with_label_noise(np.exp(evidence - total[:, None]), eps)
                out[level, batch.index] = np.where(
                    np.isfinite(total),
                    -np.log(p_all[np.arange(n_t), batch.truth]),
                    math.log(n_prims),
                )
        return out

    def speed_trials(self, noise_scale: float) -> list[tuple[np.ndarray, ...]]:
        """What the speed's posterior of every trial's own primitive is made of at
        ``noise_scale`` (scored first if it was not): per batch, the nodes (T, A) in log
        alpha, the log-likelihood (T, A) and the log quadrature weights (T, A) of the true
        primitive, and the true log alphas (T,)."""
        if not self.inside:
            return []
        if float(noise_scale) not in self._speed_tables:
            self((noise_scale,))
        tables = self._speed_tables[float(noise_scale)]
        return [
            (b.log_alphas, tables[i], b.log_weights[np.arange(b.truth.shape[0]), b.truth],
             b.true_log_alphas)
            for i, b in enumerate(self.batches)
        ]  # fmt: skip

    def _setup(self, batch: _Batch) -> tuple:
        """(precision (T, K, p, p), log det Sigma (T, K), gram (T, A, Do, M, M), proj
        (T, K, A, Do, M), rr (T, K, A, Do)) of one batch: every primitive's prior of the
        observed weights, without the trial's demonstration (its own primitive's mean,
        regression and scatter, and the pooled prior every primitive borrows from), and the
        whitened statistics of the observation's residual at every node."""
        model, parts = self.model, self.parts
        settings, dt = model.settings, model.sample_period
        n_prims, m = len(model.primitives), model.basis.n_basis
        noise_tau = model.primitives[0].noise_tau
        dims = batch.dims
        n_t, n_a = batch.log_alphas.shape
        n_do = dims.shape[0]
        p = n_do * m
        cols = (dims[:, None] * m + np.arange(m)).reshape(-1)
        durations = duration_from_alpha(np.exp(batch.log_alphas), dt, settings.s_bar)
        phases = batch.elapsed[:, None, :] / durations[:, :, None]  # (T, A, n)
        real = np.broadcast_to(batch.mask[:, None, :], phases.shape)
        psi = np.zeros(phases.shape + (m,))  # (T, A, n, M), padded rows zero
        psi[real] = model.basis(phases[real])
        gram = np.empty((n_t, n_a, n_do, m, m))
        cross = np.empty((n_t, n_a, n_do, m))  # Psi^T K^-1 y
        yy = np.empty((n_t, n_do))
        for tau in np.unique(noise_tau[dims]):
            group = np.nonzero(noise_tau[dims] == tau)[0]
            psi_w = _whiten_padded(batch.elapsed, batch.mask, float(tau), psi)
            y_w = _whiten_padded(batch.elapsed, batch.mask, float(tau), batch.values[..., group])
            gram[:, :, group] = (psi_w.swapaxes(-1, -2) @ psi_w)[:, :, None]
            cross[:, :, group] = (psi_w.swapaxes(-1, -2) @ y_w[:, None]).swapaxes(-1, -2)
            yy[:, group] = (y_w**2).sum(axis=1)
        truth = batch.truth
        held = _held_out(parts, model, truth, np.array(batch.demos), cols)
        means = np.empty((n_t, n_prims, n_a, p))
        sigma = np.empty((n_t, n_prims, p, p))
        prior = parts[0].prior
        if prior is not None:
            keep = prior.keep[cols]
            pooled = (prior.scatter[np.ix_(cols, cols)][None] - held.drop) / (prior.dof - 1.0)
            sigma0 = keep[:, None] * pooled * keep[None, :]
            sigma0[:, np.arange(p), np.arange(p)] += prior.target_part[cols]
        for k, prim in enumerate(model.primitives):
            part = parts[k]
            means[:, k] = prim.mean_at(np.exp(batch.log_alphas))[..., cols]
            n = part.residuals.shape[0]
            scatter = part.residuals[:, cols].T @ part.residuals[:, cols]
            mine = truth == k
            own = np.where(mine[:, None, None], scatter[None] - held.drop, scatter[None])
            a_full, b_full = part.weights_of(n, part.dof)
            loo = {d: part.weights_of(n - 1, int(d)) for d in np.unique(held.dof[mine])}
            a = np.array([loo[d][0] if t else a_full for d, t in zip(held.dof, mine, strict=True)])
            b = np.array([loo[d][1] if t else b_full for d, t in zip(held.dof, mine, strict=True)])
            if prior is not None:
                sigma[:, k] = a[:, None, None] * sigma0 + b[:, None, None] * own
            else:  # a fixed shrinkage: the target part stays
                target = prim.cov[np.ix_(cols, cols)] - b_full * scatter
                sigma[:, k] = target[None] + b[:, None, None] * own
            if mine.any():  # the regression without the demonstration
                shift = batch.log_alphas[mine] - prim.log_alpha_mean  # (T_k, A)
                means[mine, k] = (
                    held.mean[mine][:, None] + shift[..., None] * held.slope[mine][:, None]
                )[..., cols]
        precision, logdet_sigma = equilibrated_precision(sigma)  # (T, K, p, p), (T, K)
        means = means.reshape(n_t, n_prims, n_a, n_do, m)
        proj = cross[:, None] - np.einsum("tadmn,tkadn->tkadm", gram, means)  # Psi^T K^-1 r
        rr = (
            yy[:, None, None]
            - 2.0 * np.einsum("tkadm,tadm->tkad", means, cross)
            + np.einsum("tkadm,tadmn,tkadn->tkad", means, gram, means)
        )
        return precision, logdet_sigma, gram, proj, rr


@dataclasses.dataclass(frozen=True)
class _HeldOut:
    """Each trial's primitive refitted without its demonstration (:meth:`FitParts.without`,
    vectorised): mean and slope (T, P), scatter lost (T, p, p), degrees of freedom (T,)."""

    mean: np.ndarray
    slope: np.ndarray
    drop: np.ndarray
    dof: np.ndarray


def _held_out(
    parts: Sequence[FitParts],
    model: ProMPModel,
    truth: np.ndarray,
    demos: np.ndarray,
    cols: np.ndarray,
) -> _HeldOut:
    n_t, n_w = truth.shape[0], model.primitives[0].mean.shape[0]
    mean, slope = np.empty((n_t, n_w)), np.empty((n_t, n_w))
    drop, dof = np.empty((n_t, cols.shape[0], cols.shape[0])), np.empty(n_t, dtype=int)
    for k, (prim, part) in enumerate(zip(model.primitives, parts, strict=True)):
        mine = np.nonzero(truth == k)[0]
        if not mine.size:
            continue
        n = part.residuals.shape[0]
        if part.slope_weight > 0.0 and n - 1 < 3:  # the few: one at a time
            for t in mine:
                mean[t], slope[t], drop[t], dof[t] = part.without(
                    int(demos[t]), prim.mean, prim.alpha_slope, cols
                )
            continue
        rows = demos[mine]
        e, h = part.residuals[rows], part.leverage[rows]
        mean[mine] = prim.mean - e / (n * (1.0 - h))[:, None]
        slope[mine] = (
            prim.alpha_slope
            - (part.slope_weight * part.centred_log_alphas[rows] / (1.0 - h))[:, None] * e
        )
        e_o = e[:, cols]
        drop[mine] = e_o[:, :, None] * e_o[:, None, :] / (1.0 - h)[:, None, None]
        dof[mine] = part.dof - 1
    return _HeldOut(mean, slope, drop, dof)


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


class _Candidates:
    """The leave-one-out scorer of each candidate basis of one choice (:class:`LooScorer`):
    each basis fitted once, every score on the same trials' observations and quadrature nodes
    (:func:`_batches`, built at the first score)."""

    def __init__(
        self,
        dataset: Mapping[str, Sequence[Demonstration]],
        layout: Layout,
        inner: Settings,
        dt: float,
        trials: Sequence[Trial],
        region: tuple[np.ndarray, np.ndarray],
    ):
        self.dataset, self.layout, self.inner, self.dt = dataset, layout, inner, dt
        self.trials, self.region, self.n_trials = trials, region, len(trials)
        self._batches: list[_Batch] | None = None
        self._scorers: dict[tuple[int, float], LooScorer] = {}

    def __call__(self, n_basis: int, width: float) -> LooScorer:
        key = (n_basis, width)
        if key not in self._scorers:
            if self._batches is None:
                self._batches = _batches(
                    self.dataset, self.layout, self.trials, self.dt, self.inner.s_bar
                )
            candidate = dataclasses.replace(self.inner, n_basis=n_basis, width=width)
            fitted = fit_parts(self.dataset, self.layout, candidate, self.dt, alpha_models=False)
            self._scorers[key] = LooScorer(fitted, self._batches, self.n_trials, self.region)
        return self._scorers[key]


def _neighbours_walk(grid: Sequence, start: int, loss, both_sides: bool = True) -> None:
    """Score ``grid[start]`` and its neighbours, then walk on from the best in its direction
    while ``loss`` (a function of the grid's index) drops: a coarse-to-fine line search that
    stops at a local minimum. ``both_sides``: both neighbours first (the loss of a basis is not
    always unimodal: 5 and 10 functions may both beat 7); else one side, the other only when
    the first is not downhill."""
    values = {start: loss(start)}
    best = start
    for step in (-1, 1):
        i = start + step
        if 0 <= i < len(grid):
            values[i] = loss(i)
            if values[i] < values[best]:
                best = i
            if best != start and not both_sides:
                break
    step = best - start
    while step and 0 <= best + step < len(grid):
        value = loss(best + step)
        if not value < values[best]:
            break
        values[best + step] = value
        best += step


def _walk(
    candidates: _Candidates,
    scales: Sequence[float],
    basis_grid: Sequence[int],
    width_grid: Sequence[float],
    scores: dict,
) -> None:
    """The leave-one-out rule's search, filling ``scores`` ({(M, width): {scale: losses}}):
    M from the grid's value nearest the reference 7, then both its neighbours, then on while
    the loss drops (width 1, at the better of the two noise scales either side of the grid's
    middle for the reference basis); then the width the same way at that M and the noise
    scale at that basis, one side first (:func:`_neighbours_walk`). Each candidate basis is
    fitted once (:class:`_Candidates`)."""
    # the reference basis is scored at two noise scales either side of the grid's middle, the
    # other bases at the better of the two (the scale's own walk comes last)
    middle = len(scales) // 2
    search = sorted({max(middle - 1, 0), min(middle + 1, len(scales) - 1)})

    def loss(n_basis: int, width: float, levels: Sequence[int] | None = None) -> float:
        levels = search if levels is None else levels
        by_scale = scores.setdefault((n_basis, width), {})
        missing = [scales[i] for i in levels if scales[i] not in by_scale]
        if missing:
            by_scale.update(zip(missing, candidates(n_basis, width)(missing), strict=True))
        values = [float(by_scale[scales[i]].mean()) for i in levels]
        value = min(values)
        return value if np.isfinite(value) else math.inf

    def nearest(grid: Sequence[float], value: float) -> int:
        return min(range(len(grid)), key=lambda i: abs(math.log(grid[i] / value)))

    start_width = width_grid[nearest(width_grid, FALLBACK["width"])]
    start_basis = nearest(basis_grid, FALLBACK["n_basis"])
    reference = basis_grid[start_basis], start_width
    search[:] = [min(search, key=lambda i: (loss(*reference, (i,)), i))]
    basis_scores: dict[int, float] = {}

    def basis_loss(i: int) -> float:
        basis_scores[i] = loss(basis_grid[i], start_width)
        return basis_scores[i]

    _neighbours_walk(basis_grid, start_basis, basis_loss)
    n_basis = basis_grid[min(basis_scores, key=lambda i: (basis_scores[i], i))]
    width_scores: dict[int, float] = {}

    def width_loss(i: int) -> float:
        width_scores[i] = loss(n_basis, width_grid[i])
        return width_scores[i]

    _neighbours_walk(width_grid, nearest(width_grid, start_width), width_loss, both_sides=False)
    width = width_grid[min(width_scores, key=lambda i: (width_scores[i], i))]
    _neighbours_walk(scales, search[0], lambda i: loss(n_basis, width, (i,)), both_sides=False)


def _keep_previous(
    candidates: _Candidates, settings: Settings, previous: Mapping
) -> tuple[Settings, dict] | None:
    """The previous choice kept, if it still beats the previous runner-up on ``dataset``'s
    trials (see :func:`choose_settings`); None when the search must run again."""
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
        (round(loss, 9), _preference(v["n_basis"], v["width"], v["noise_scale"]))
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


def choose_settings(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
    previous: Mapping | None = None,
) -> tuple[Settings, dict]:
    """``settings`` with every automatic one (None) chosen from ``dataset``, and the report of
    the choice (JSON-ready: the rule, the values chosen, the score of every candidate).

    Parameters
    ----------
    dataset : mapping of str to list of Demonstration
        The training demonstrations of every primitive.
    dt : float
        The sample period (s) the model will use.
    previous : mapping, optional
        The report of the choice made for nearly the same demonstrations (the studio's last
        fit, before a demonstration was added or deleted). With the leave-one-out rule the
        search runs again only when the evidence says the choice may have changed: the
        previous choice and the previous runner-up are scored on ``dataset``'s trials (a
        paired comparison) and the choice is kept while it still wins (:data:`KEPT_RULE`), at
        most :data:`KEEP_LIMIT` times in a row.
    """
    chosen, report, candidates = _choose(dataset, layout, settings, dt, previous)
    if settings.duration_temperature is not None:
        return chosen, report
    tau, scores = 1.0, {}
    if candidates is not None:
        scale = chosen.noise_scale / candidates.inner.noise_scale
        scorer = candidates(chosen.n_basis, chosen.width)
        tau, scores = choose_temperature(scorer.speed_trials(scale))
    chosen = dataclasses.replace(chosen, duration_temperature=tau)
    report = dict(report)
    report["duration_temperature"] = {
        "value": tau,
        "rule": TEMPERATURE_RULE if scores else "1 (no demonstration could be held out)",
        "coverage": {str(t): round(v, 4) for t, v in scores.items()},
    }
    return chosen, report


def _choose(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
    previous: Mapping | None,
) -> tuple[Settings, dict, _Candidates | None]:
    """:func:`choose_settings` without the temperature, and the candidates' scorers (None
    when nothing can be held out)."""
    automatic = settings.automatic
    given = {name: getattr(settings, name) for name in FALLBACK if name not in automatic}
    loo = settings.select == "loo" or not automatic  # (only the temperature: the leave-one-out
    # scorer gives it)
    trials = plan_trials(dataset, layout, max_trials=LOO_MAX_TRIALS if loo else MAX_TRIALS)
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
        }, None
    fixed_scale = settings.noise_scale
    inner = dataclasses.replace(settings, noise_scale=fixed_scale or 1.0)
    scales = NOISE_GRID if fixed_scale is None else (1.0,)
    basis_grid = BASIS_GRID if settings.n_basis is None else (settings.n_basis,)
    width_grid = WIDTH_GRID if settings.width is None else (settings.width,)
    start_width = 1.0 if settings.width is None else settings.width
    region = data_region(dataset, layout)
    candidates = _Candidates(dataset, layout, inner, dt, trials, region)
    if not automatic:
        return settings, {"rule": "given", "chosen": {}, "given": given}, candidates
    if loo and previous is not None:
        kept = _keep_previous(candidates, settings, previous)
        if kept is not None:
            return (*kept, candidates)
    # every candidate scored: {(n_basis, width): {noise scale: losses per trial}}
    scores: dict[tuple[int, float], dict[float, np.ndarray]] = {}
    if loo:
        _walk(candidates, scales, basis_grid, width_grid, scores)
    else:
        cache: dict = {}  # every candidate's observations and quadratures (see _losses)

        def evaluate(n_basis: int, width: float) -> float:
            if (n_basis, width) not in scores:
                candidate = dataclasses.replace(inner, n_basis=n_basis, width=width)
                rows = score(dataset, layout, candidate, dt, trials, scales, cache, region)
                scores[(n_basis, width)] = dict(zip(scales, rows, strict=True))
            return min(float(r.mean()) for r in scores[(n_basis, width)].values())

        start_width = 1.0 if settings.width is None else settings.width
        best_basis = min(basis_grid, key=lambda m: (evaluate(m, start_width), abs(m - 7)))
        for width in width_grid:
            evaluate(best_basis, width)
    table = [
        (m, w, s * inner.noise_scale, losses)
        for (m, w), by_scale in scores.items()
        for s, losses in by_scale.items()
    ]
    if not any(np.isfinite(c[3]).all() for c in table):
        chosen = settings.with_fallback()
        return chosen, {
            "rule": "fallback values (every candidate's mean trajectory left the region the "
            "demonstrations span)",
            "chosen": {name: getattr(chosen, name) for name in automatic},
            "given": given,
        }, candidates
    # the lowest mean loss; a tie (e.g. every candidate perfect) goes to the reference
    n_basis, width, noise_scale, losses = min(
        table, key=lambda c: (round(float(c[3].mean()), 9), _preference(*c[:3]))
    )
    chosen = dataclasses.replace(settings, n_basis=n_basis, width=width, noise_scale=noise_scale)
    others = [
        c for c in table
        if c[:3] != (n_basis, width, noise_scale) and np.isfinite(c[3]).all()
    ]  # fmt: skip
    margin: dict = {"kept": 0}
    if others:  # the best of the others: what a later refit checks the choice against
        m, w, scale, runner_losses = min(
            others, key=lambda c: (round(float(c[3].mean()), 9), _preference(*c[:3]))
        )
        runner = dataclasses.replace(settings, n_basis=m, width=w, noise_scale=scale)
        margin["runner_up"] = {name: getattr(runner, name) for name in automatic}
        margin["runner_up_log_loss"] = float(runner_losses.mean())
    return chosen, {
        "rule": LOO_RULE if loo else RULE,
        "chosen": {name: getattr(chosen, name) for name in automatic},
        "given": given,
        "log_loss": float(losses.mean()),
        "trials": len(trials),
        **margin,
        "candidates": [
            {"n_basis": m, "width": w,
             "noise_scale": [s * inner.noise_scale for s in sorted(by_scale)],
             "log_loss": [round(float(by_scale[s].mean()), 6)
                          if np.isfinite(by_scale[s]).all() else None
                          for s in sorted(by_scale)]}
            for (m, w), by_scale in scores.items()
        ],
    }, candidates  # fmt: skip
