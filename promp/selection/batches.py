"""The trials of the closed-form leave-one-out rule laid out for its scorer
(:mod:`promp.selection.loo`): grouped by modality set, each observation padded to the same
length (at most :data:`LOO_ROWS` samples), and the quadrature in log alpha every primitive of a
trial shares (:data:`LOO_NODES` nodes) with each primitive's log weights there.

Everything here is independent of the candidate settings: built once per choice. The speed
prior of each primitive, its Student-t density, its range and the quadrature weights are
recognition's own (:func:`promp.evidence.speed.speed_prior`, :func:`~promp.evidence.speed.t_logpdf`,
:func:`~promp.evidence.speed.central_range`, :func:`~promp.evidence.speed.quadrature_weights`), in
their batch form.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np
from scipy import special

from promp.data import Demonstration, Layout
from promp.evidence.speed import (
    AlphaPrior,
    central_range,
    quadrature_weights,
    speed_prior,
    t_logpdf,
)
from promp.selection.trials import Trial
from promp.timing import alpha_from_duration, n_observed_for

__all__ = ["LOO_NODES", "LOO_ROWS", "Batch", "make_batches", "priors_without_each"]

LOO_NODES = 12
LOO_ROWS = 48


@dataclasses.dataclass(frozen=True, eq=False)
class Batch:
    """The trials of one modality set, laid out for :func:`promp.selection.loo.loo_score`
    (independent of the candidate settings: built once per choice). ``index``: their
    positions in the plan."""

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
    priors: np.ndarray  # (3, T, K) each primitive's speed prior: location, scale, dof
    bounds: np.ndarray  # (T,) the log of the longest alpha each observation allows


def make_batches(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    trials: Sequence[Trial],
    dt: float,
    s_bar: float,
) -> list[Batch]:
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
                loo[trial.primitive] = priors_without_each(alphas[trial.primitive], s_bar)
            params[:, i] = [[p.locs[0] for p in full], [p.scales[0] for p in full],
                            [p.dofs[0] for p in full]]  # fmt: skip
            params[:, i, trial.primitive] = loo[trial.primitive][:, trial.demo]
        bounds = np.log(s_bar / (elapsed[:, -1] / dt + 1.0))  # (T,) the longest alpha
        log_alphas, log_weights = _quadrature_grid(*params, bounds)
        truth_alphas = np.array([alphas[t.primitive][t.demo] for t in batch])
        out.append(
            Batch(
                index, np.array([t.primitive for t in batch]), [t.demo for t in batch], dims,
                elapsed, mask, values, log_alphas, log_weights, np.log(truth_alphas), params,
                bounds,
            )
        )  # fmt: skip
    return out


def priors_without_each(alphas: np.ndarray, s_bar: float) -> np.ndarray:
    """:meth:`promp.evidence.speed.AlphaPrior.from_alphas` of ``alphas`` (n,) without each one in
    turn, all at once (:func:`promp.evidence.speed.speed_prior` of n rows): (location, scale,
    dof) x n."""
    logs = np.log(np.asarray(alphas, dtype=float))
    n = logs.shape[0]
    others = np.broadcast_to(logs, (n, n))[~np.eye(n, dtype=bool)].reshape(n, n - 1)
    return np.stack(speed_prior(others, s_bar))


def _quadrature_grid(
    locs: np.ndarray, scales: np.ndarray, dofs: np.ndarray, bounds: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:data:`LOO_NODES` nodes per trial spanning every primitive's prior (Student-t in log
    alpha, parameters (T, K)) as :meth:`promp.evidence.speed.AlphaPrior.span` does
    (:func:`promp.evidence.speed.central_range`), truncated at the trial's bound (T,); and each
    primitive's log quadrature weights there, (T, K, A), normalised to its prior mass below
    the bound (:func:`promp.evidence.speed.quadrature_weights` for every trial and primitive at
    once)."""
    lo, hi = central_range(locs, scales, dofs)
    hi = np.minimum(hi, bounds[:, None])
    empty = hi <= lo  # every plausible speed ends too early: the tail just below the bound
    lo = np.where(empty, bounds[:, None] - 4.0 * scales, lo)
    hi = np.where(empty, bounds[:, None], hi)
    steps = np.linspace(0.0, 1.0, LOO_NODES)
    start, stop = lo.min(axis=1), hi.max(axis=1)
    nodes = start[:, None] + (stop - start)[:, None] * steps  # (T, A)
    z = (nodes[:, None, :] - locs[..., None]) / scales[..., None]
    # the Student-t log density, per unit of log alpha
    log_prior = t_logpdf(z, dofs[..., None]) - np.log(scales)[..., None]  # (T, K, A)
    with np.errstate(divide="ignore"):
        log_mass = np.log(special.stdtr(dofs, (bounds[:, None] - locs) / scales))  # (T, K)
    return nodes, quadrature_weights(nodes[:, None, :], log_prior, log_mass)


def _rows(n: int) -> np.ndarray:
    """The samples of an ``n``-sample observation a trial scores: all of them, or
    :data:`LOO_ROWS` evenly spread from the first to the last (the noise model is a process in
    time, so fewer samples are scored as what they are: observations further apart)."""
    if n <= LOO_ROWS:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, LOO_ROWS)).astype(int))
