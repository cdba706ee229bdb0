"""Brute-force dense ProMP computations: the textbook formulas with explicit matrices, used only
to check the structured implementation in :mod:`promp.inference`."""

from __future__ import annotations

import numpy as np
from scipy.linalg import block_diag

from promp.inference import Observation
from promp.model import Primitive, ProMPModel
from promp.timing import duration_from_alpha


def design(model: ProMPModel, obs: Observation, alpha: float) -> np.ndarray:
    """Block-diagonal observation matrix A, shape (n_observed * n_obs_dims, n_weights)."""
    dims = model.layout.dims(obs.modalities)
    duration = duration_from_alpha(alpha, model.sample_period, model.settings.s_bar)
    psi = model.basis(obs.elapsed / duration)
    m = model.basis.n_basis
    a = np.zeros((len(dims) * obs.n_observed, model.n_dims * m))
    for i, d in enumerate(dims):
        a[i * obs.n_observed : (i + 1) * obs.n_observed, d * m : (d + 1) * m] = psi
    return a


def _parts(model: ProMPModel, prim: Primitive, obs: Observation, alpha: float):
    dims = model.layout.dims(obs.modalities)
    a = design(model, obs, alpha)
    lag = np.abs(obs.elapsed[:, None] - obs.elapsed[None, :])
    blocks = [
        var * (np.exp(-lag / tau) if tau > 0 else np.eye(obs.n_observed))
        for var, tau in zip(prim.noise_var[dims], prim.noise_tau[dims], strict=True)
    ]
    noise = block_diag(*blocks)  # Ornstein-Uhlenbeck noise, one block per dimension
    y = obs.values.T.reshape(-1)
    return a, noise, y


def log_likelihood(model: ProMPModel, prim: Primitive, obs: Observation, alpha: float) -> float:
    a, noise, y = _parts(model, prim, obs, alpha)
    mean = a @ prim.mean_at(alpha)
    cov = a @ prim.cov @ a.T + noise
    r = y - mean
    sign, logdet = np.linalg.slogdet(cov)
    assert sign > 0
    return float(-0.5 * (r @ np.linalg.inv(cov) @ r + logdet + len(y) * np.log(2 * np.pi)))


def condition(model: ProMPModel, prim: Primitive, obs: Observation, alpha: float):
    a, noise, y = _parts(model, prim, obs, alpha)
    mu = prim.mean_at(alpha)
    gain = prim.cov @ a.T @ np.linalg.inv(a @ prim.cov @ a.T + noise)
    return mu + gain @ (y - a @ mu), prim.cov - gain @ a @ prim.cov


def via_rows(model: ProMPModel, vias, alpha: float | None):
    """Explicit rows, targets and covariance blocks of via-points (one loop per column)."""
    m = model.basis.n_basis
    rows, targets, blocks = [], [], []
    for point in vias:
        if point.phase is not None:
            phase = point.phase
        else:
            phase = point.time / duration_from_alpha(alpha, model.sample_period,
                                                     model.settings.s_bar)  # fmt: skip
        phi = model.basis(np.array([phase]))[0]
        for j, column in enumerate(point.columns):
            d = model.layout.columns.index(column)
            row = np.zeros(model.n_dims * m)
            row[d * m : (d + 1) * m] = phi
            rows.append(row)
            targets.append(point.values[j])
        blocks.append(point.cov)
    return np.array(rows), np.array(targets), block_diag(*blocks)


def condition_on_everything(
    model: ProMPModel, prim: Primitive, alpha: float, obs: Observation | None, vias
):
    """The textbook Eq. 8 on the observation's samples and the via-points stacked together."""
    designs, targets, noises = [], [], []
    if vias:
        a, y, noise = via_rows(model, vias, alpha)
        designs.append(a), targets.append(y), noises.append(noise)
    if obs is not None:
        a, noise, y = _parts(model, prim, obs, alpha)
        designs.append(a), targets.append(y), noises.append(noise)
    a, y, noise = np.vstack(designs), np.concatenate(targets), block_diag(*noises)
    mu = prim.mean_at(alpha)
    gain = prim.cov @ a.T @ np.linalg.inv(a @ prim.cov @ a.T + noise)
    return mu + gain @ (y - a @ mu), prim.cov - gain @ a @ prim.cov
