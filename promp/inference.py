"""Distributions over the weights and the trajectories they give (paper Eqs. 1, 5 and 8).

* :class:`Gaussian` and :class:`Posterior`: a distribution over the weights (a posterior keeps
  the covariance of each dimension's weights and computes the full one on first use);
* :func:`condition_dense`: the Kalman update of any Gaussian over the weights on observed
  samples (Eq. 8), densely, in observation space or weight space, whichever is smaller, with
  Cholesky solves; the structured update from a primitive's own prior is the evidence's
  (:meth:`promp.evidence.Evidence.condition`, over the likelihood's terms), and
  :func:`promp.evidence.condition` gives either;
* :func:`predict` gives the mean and standard deviation over [0, t_f] of every modality,
  observed or not: the cross-covariance of the weights predicts the unobserved ones
  (:func:`trajectory_at` at any phases).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve, solve_triangular

from promp.model import Primitive, ProMPModel
from promp.noise import noise_groups, whiten
from promp.observation import Observation, check_observation  # (Observation re-exported)
from promp.timing import check_alpha, duration_from_alpha, n_samples_from_alpha

__all__ = [
    "Gaussian", "Observation", "Posterior", "Prediction", "condition_dense", "observation_basis",
    "observed_duration",
    "per_dimension", "predict", "trajectory_at"
]  # fmt: skip


def per_dimension(vector: np.ndarray, n_dims: int) -> np.ndarray:
    """A dimension-major weight vector (n_dims * M,) as rows, shape (n_dims, M)."""
    return vector.reshape(n_dims, -1)


@dataclass(frozen=True, eq=False)
class Gaussian:
    """A distribution over weights: ``mean`` (n_weights,), ``cov`` (n_weights, n_weights)."""

    mean: np.ndarray
    cov: np.ndarray

    def blocks(self, n_dims: int) -> np.ndarray:
        """Covariance of each dimension's weights, shape (n_dims, n_basis, n_basis)."""
        m = self.mean.shape[0] // n_dims
        return np.stack([self.cov[d * m : (d + 1) * m, d * m : (d + 1) * m] for d in range(n_dims)])


class Posterior:
    """The weight distribution after conditioning (Eq. 8).

    Attributes
    ----------
    mean : array, shape (n_weights,)
    cov : array, shape (n_weights, n_weights)
        The full covariance, computed on first use (predictions only need the blocks).
    """

    def __init__(self, mean: np.ndarray, blocks: np.ndarray, full: Callable[[], np.ndarray]):
        self.mean = mean
        self._blocks = blocks
        self._full = full

    def blocks(self, n_dims: int) -> np.ndarray:
        """Covariance of each dimension's weights, shape (n_dims, n_basis, n_basis)."""
        if self._blocks.shape[0] != n_dims:
            raise ValueError(f"the posterior has {self._blocks.shape[0]} dimensions, not {n_dims}")
        return self._blocks

    @functools.cached_property
    def cov(self) -> np.ndarray:
        return self._full()


def observation_basis(model: ProMPModel, obs: Observation, alpha: float) -> np.ndarray:
    """Basis at the observed phases for ``alpha``, shape (n_observed, n_basis).

    Raises
    ------
    ValueError
        If the observation lasts longer than the duration ``alpha`` predicts.
    """
    return model.basis(obs.elapsed / observed_duration(model, obs, alpha))


def observed_duration(model: ProMPModel, obs: Observation, alpha: float) -> float:
    """The duration (s) that ``alpha`` predicts, checked to hold the observation.

    Raises
    ------
    ValueError
        alpha <= 0, or the observation lasts longer than that duration.
    """
    check_alpha(alpha)
    duration = float(duration_from_alpha(alpha, model.sample_period, model.settings.s_bar))
    if obs.elapsed[-1] > duration * (1.0 + 1e-9):
        raise ValueError(
            f"the observation ({obs.elapsed[-1]:.3f} s) is longer than the predicted duration "
            f"({duration:.3f} s) for alpha = {alpha:.4g}"
        )
    return duration


def condition_dense(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    alpha: float,
    prior: Gaussian,
    cov_cholesky: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """The dense Kalman update of a Gaussian weight ``prior`` on the observation at speed
    ``alpha`` (Eq. 8): ``mu' = mu + Sigma A^T (A Sigma A^T + R)^-1 (y_o - A mu)`` and
    ``Sigma' = Sigma - Sigma A^T (A Sigma A^T + R)^-1 A Sigma``, with ``A`` the basis at the
    observed phases (block-diagonal over the observed dimensions) and ``R`` the
    Ornstein-Uhlenbeck noise of ``primitive``: (mean (P,), covariance (P, P)), new arrays.
    ``cov_cholesky``: the prior covariance's Cholesky factor when known (the weight-space
    update uses it)."""
    dims = check_observation(model, obs)
    psi = observation_basis(model, obs, alpha)  # (n, M)
    m = model.basis.n_basis
    mean, cov = prior.mean, prior.cov
    n_dims = model.n_dims
    s2 = primitive.noise_var[dims]
    mu_blocks = per_dimension(mean, n_dims)
    resid = obs.values - psi @ mu_blocks[dims].T  # (n, Do)
    w_idx = (dims[:, None] * m + np.arange(m)[None, :]).reshape(-1)  # observed weights
    n_obs, n_do = resid.shape
    if n_obs * n_do <= w_idx.shape[0] * 2 and n_obs * n_do < mean.shape[0]:
        # Observation space: S = A Sigma_OO A^T + R, A = blockdiag(psi) over observed dims.
        cov_ow = cov[w_idx]  # (Do*M, P)
        a_cov = np.einsum("nm,dmp->dnp", psi, cov_ow.reshape(n_do, m, -1))  # (Do, n, P)
        a_cov = a_cov.reshape(n_do * n_obs, -1)
        s = np.einsum("dnem,km->dnek", a_cov[:, w_idx].reshape(n_do, n_obs, n_do, m), psi)
        s = s.reshape(n_do * n_obs, n_do * n_obs)
        lag = np.abs(obs.elapsed[:, None] - obs.elapsed[None, :])
        for i, (var, tau) in enumerate(zip(s2, primitive.noise_tau[dims], strict=True)):
            block = slice(i * n_obs, (i + 1) * n_obs)
            s[block, block] += var * (np.exp(-lag / tau) if tau > 0 else np.eye(n_obs))
        chol = np.linalg.cholesky(s)
        v = solve_triangular(chol, a_cov, lower=True, check_finite=False)  # L^-1 A Sigma
        e = solve_triangular(chol, resid.T.reshape(-1), lower=True, check_finite=False)
        new_mean = mean + v.T @ e
        new_cov = cov - v.T @ v
    else:
        # Weight space: Sigma' = L (I + L^T K L)^-1 L^T with K = A^T R^-1 A.
        chol = cov_cholesky if cov_cholesky is not None else np.linalg.cholesky(cov)
        gram = np.empty((n_do, m, m))
        b = np.empty((n_do, m))  # A^T R^-1 r, observed blocks
        for tau, cols in noise_groups(primitive, dims).items():
            psi_w, _ = whiten(obs.elapsed, tau, psi)
            resid_w, _ = whiten(obs.elapsed, tau, resid[:, cols])
            gram[cols] = psi_w.T @ psi_w
            b[cols] = (psi_w.T @ resid_w).T / s2[cols, None]
        l_o = chol[w_idx].reshape(n_do, m, -1)  # rows of L for the observed weights
        kl = (gram @ l_o) / s2[:, None, None]
        n_w = mean.shape[0]
        inner = np.eye(n_w) + l_o.reshape(-1, n_w).T @ kl.reshape(-1, n_w)
        chol_inner = np.linalg.cholesky(inner)
        # (contiguous right-hand side: scipy is ten times slower on a transposed view)
        e = solve_triangular(
            chol_inner, np.ascontiguousarray(chol.T), lower=True, check_finite=False
        )
        lb = l_o.reshape(-1, n_w).T @ b.reshape(-1)  # L^T A^T R^-1 r
        new_cov = e.T @ e
        new_mean = mean + chol @ cho_solve((chol_inner, True), lb, check_finite=False)
    return new_mean, 0.5 * (new_cov + new_cov.T)


@dataclass(frozen=True, eq=False)
class Prediction:
    """Trajectory distribution over [0, t_f] of every dimension.

    Attributes
    ----------
    times : array, shape (n_points,)
        Seconds from the start of the movement; ``times[-1]`` is the predicted duration.
    mean, std : array, shape (n_points, n_dims)
    alpha : float
    """

    times: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    alpha: float

    @property
    def duration(self) -> float:
        return float(self.times[-1])


def predict(
    model: ProMPModel,
    dist: Gaussian | Posterior | Primitive,
    alpha: float,
    n_points: int | None = None,
) -> Prediction:
    """Mean and standard deviation of every dimension over the predicted duration.

    ``y(z) = Phi(z) w`` over the phases ``z`` in [0, 1] (Eq. 1), ``w`` distributed as
    ``dist``: the mean ``Phi mu_w`` and the standard deviation ``sqrt(diag(Phi Sigma_w
    Phi^T))`` of the trajectory distribution (observation noise excluded), every dimension
    whether observed or not.

    Parameters
    ----------
    model : ProMPModel
    dist : Gaussian, Posterior or Primitive
        The weights' distribution: a primitive's prior (at ``alpha``) or a posterior.
    alpha : float
        The time modulation: the duration is ``(s_bar / alpha - 1) sample_period``.
    n_points : int, optional
        Samples over [0, duration] (at least 2); default the predicted number of samples,
        ``round(s_bar / alpha)``.

    Returns
    -------
    Prediction
        ``times`` (n_points,) in s, ``mean`` and ``std`` (n_points, n_dims).
    """
    n_samples = float(n_samples_from_alpha(alpha, model.settings.s_bar))
    n = max(int(round(n_samples)), 2) if n_points is None else int(n_points)
    if n < 2:
        raise ValueError(f"n_points must be >= 2, got {n}")
    duration = float(duration_from_alpha(alpha, model.sample_period, model.settings.s_bar))
    z = np.linspace(0.0, 1.0, n)
    mean, std = trajectory_at(model, dist, alpha, z)
    return Prediction(times=z * duration, mean=mean, std=std, alpha=float(alpha))


def trajectory_at(
    model: ProMPModel,
    dist: Gaussian | Posterior | Primitive,
    alpha: float,
    phases: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation of every dimension at ``phases`` (n,) in [0, 1]: arrays
    of shape (n, n_dims), ``psi(z) mu_d`` and ``sqrt(psi(z) Sigma_dd psi(z)^T)`` (the
    trajectory distribution, observation noise excluded; what :func:`predict` samples evenly
    and the live predictor at a stated rate, :mod:`promp.live.predictor`)."""
    psi = model.basis(np.asarray(phases, dtype=float))
    n_dims = model.n_dims
    if isinstance(dist, Primitive):
        mean_w, blocks = dist.mean_at(alpha), dist.cov_blocks
    else:
        mean_w, blocks = dist.mean, dist.blocks(n_dims)
    mean = psi @ per_dimension(mean_w, n_dims).T
    var = (((psi[None] @ blocks) * psi[None]).sum(axis=-1)).T  # diag(psi Sigma_dd psi^T)
    return mean, np.sqrt(np.maximum(var, 0.0))
