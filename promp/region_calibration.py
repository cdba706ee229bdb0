"""The region that holds what it says: each primitive's calibrated radius, chosen from its own
demonstrations left out in turn.

The predictive region of a new movement (:mod:`promp.region`) is the Gaussian's ellipsoid of
radius ``r_P = sqrt(chi2_k^-1(P))``. It holds ``P`` of the samples when the demonstrations
vary as one Gaussian over the weights does: in shape and overall speed. Demonstrations that
vary in their timing within the movement (one lingers where another hurries) do not: at the
same phase their samples lie apart along the path, further than the Gaussian says, and the
region holds less than ``P`` of a new demonstration; a model whose covariance borrows a wider
shape from the other primitives (:mod:`promp.covariance`) may hold more.

So the fit measures it (:func:`calibrate`): for each primitive of ``n >= 3`` demonstrations
and each modality, every demonstration ``j`` is left out and the region of the model learned
without it is computed (the rank-one downdates of :class:`promp.fitting.FitParts`: its mean,
regression on log alpha and covariance without ``j``, the speeds' variance without ``j``);
``d2_jt`` is the squared Mahalanobis distance of its sample ``t`` (at its own phase ``t / T``)
to that region. The factor is ``c = sqrt(q(d2) / r_P^2)``, ``q`` the quantile of every
held-out sample's ``d2`` at the level ``P + (1 - P) / n``: the radius ``c r_P`` holds that
share of the held-out samples of the training demonstrations. The ``1 / n`` is a finite-sample
correction: a radius chosen on ``n`` demonstrations holds less of the next one than of them (in
the conformal rule, the next one is the ``n + 1``-th of the exchangeable draws); it vanishes as
demonstrations accumulate. (The leave-one-out downdates keep the fit's pooled prior strength,
shrinkage target and noise, which the left-out demonstration helped choose: slightly optimistic
too.) The factor is stored per modality (:attr:`promp.model.Primitive.region_scale`) and
scales the region drawn at every probability (``S`` times ``c^2``). The factor of a model
learned without a demonstration is chosen without it too, so scoring that demonstration against
it (``bench/tube_coverage.py``'s held-out column) is nested: its samples never chose the factor
they are scored with. The region stays a display and coverage matter: recognition and
prediction never use the factor.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from promp.data import Demonstration
from promp.model import Primitive, ProMPModel
from promp.quality import winsorized
from promp.region import DEFAULT_PROBABILITY, region_radius, sample_noise_var
from promp.timing import demo_phases

__all__ = ["MIN_DEMOS", "calibrate", "held_out_distances"]

MIN_DEMOS = 3  # each left out, two remain to spread a Gaussian


def calibrate(
    model: ProMPModel,
    parts: Sequence[Any],
    dataset: Mapping[str, Sequence[Demonstration]],
    probability: float = DEFAULT_PROBABILITY,
) -> ProMPModel:
    """``model`` with each primitive's :attr:`~promp.model.Primitive.region_scale`: per
    modality, the factor on the radius of its region that holds ``probability`` of its own
    demonstrations' samples, each demonstration left out in turn (module docstring; the
    quantile's level ``probability + (1 - probability) / n`` for ``n`` demonstrations). A
    primitive of fewer than :data:`MIN_DEMOS` demonstrations keeps none (factor 1).

    Parameters
    ----------
    model : ProMPModel
        Fitted on ``dataset``.
    parts : sequence of promp.fitting.FitParts
        Its fit's parts, one per primitive (:func:`promp.fitting.fit_parts`; not imported
        here: the fit calls this module).
    dataset : mapping of str to sequence of Demonstration
        What ``model`` was fitted on, in its primitives' order.
    """
    primitives = []
    for prim, part in zip(model.primitives, parts, strict=True):
        demos = dataset[prim.name]
        scales = {}
        if len(demos) >= MIN_DEMOS:
            level = probability + (1.0 - probability) / len(demos)
            for modality in model.layout.modalities:
                # a pooled prior of one primitive's fewest demonstrations has no degree of
                # freedom left without one of them: no factor (the region as drawn before)
                with np.errstate(divide="ignore", invalid="ignore"):
                    d2 = held_out_distances(model, prim, part, demos, modality.name)
                radius = region_radius(probability, len(modality.columns))
                scale = float(np.sqrt(np.quantile(d2, level)) / radius)
                if np.all(np.isfinite(d2)) and np.isfinite(scale) and scale > 0:
                    scales[modality.name] = scale
        primitives.append(dataclasses.replace(prim, region_scale=scales))
    return dataclasses.replace(model, primitives=tuple(primitives))


def held_out_distances(
    model: ProMPModel,
    prim: Primitive,
    part: Any,
    demos: Sequence[Demonstration],
    modality: str,
) -> np.ndarray:
    """The squared Mahalanobis distance of every sample of every one of ``demos`` (``prim``'s
    training demonstrations, in order; ``part`` its :class:`promp.fitting.FitParts`) in
    ``modality`` to the region of ``prim`` learned without that demonstration (unscaled, with
    the samples' noise), concatenated: shape (total samples,)."""
    m = model.basis.n_basis
    dims = model.layout.dims([modality])
    cols = (dims[:, None] * m + np.arange(m)).reshape(-1)
    k = dims.size
    noise = np.diag(sample_noise_var(model, prim)[dims])
    base = prim.cov[np.ix_(cols, cols)] - _covariance(part, cols, None)  # the floor's part
    logs = np.log(np.asarray(prim.alphas, dtype=float))
    out = []
    for j, demo in enumerate(demos):
        mean_j, slope_j, drop, dof = part.without(j, prim.mean, prim.alpha_slope, cols)
        others = winsorized(np.delete(logs, j))
        v_a = float(np.var(others, ddof=1))
        # the regression predicts at the whole set's typical speed; the refit's is the others'
        mean_j = mean_j + (float(others.mean()) - prim.log_alpha_mean) * slope_j
        sigma = base + _covariance(part, cols, (drop, dof))
        sigma = sigma + v_a * np.outer(slope_j[cols], slope_j[cols])
        phi = model.basis(demo_phases(demo.times))  # (n, M)
        blocks = sigma.reshape(k, m, k, m)
        cov = np.einsum("nm,dmek,nk->nde", phi, blocks, phi) + noise[None]
        cov = 0.5 * (cov + cov.transpose(0, 2, 1))
        mean = phi @ mean_j[cols].reshape(k, m).T  # (n, k)
        r = model.layout.extract(demo)[:, dims] - mean
        out.append(np.einsum("ni,ni->n", r, np.linalg.solve(cov, r[..., None])[..., 0]))
    return np.concatenate(out)


def _covariance(
    part: Any, cols: np.ndarray, left_out: tuple[np.ndarray, int] | None
) -> np.ndarray:
    """The covariance of the weights ``cols`` as the fit's rule gives it (before its floor and
    compression): the whole primitive's (``left_out`` None) or without one demonstration
    (``left_out = (drop, dof)`` of :meth:`promp.fitting.FitParts.without`). Only the
    difference of the two is used, added to the stored covariance."""
    n = part.residuals.shape[0]
    own = part.residuals[:, cols].T @ part.residuals[:, cols]
    if left_out is None:
        a, b = part.weights_of(n, part.dof)
        drop = np.zeros_like(own)
        pooled_dof = part.prior.dof if part.prior is not None else 0.0
    else:
        drop, dof = left_out
        a, b = part.weights_of(n - 1, dof)
        pooled_dof = part.prior.dof - 1.0 if part.prior is not None else 0.0
    if part.prior is None:  # a fixed shrinkage: the target part does not move
        return b * (own - drop)
    prior = part.prior
    keep = prior.keep[cols]
    pooled = (prior.scatter[np.ix_(cols, cols)] - drop) / pooled_dof
    sigma0 = keep[:, None] * pooled * keep[None, :]
    sigma0[np.diag_indices_from(sigma0)] += prior.target_part[cols]
    return a * sigma0 + b * (own - drop)
