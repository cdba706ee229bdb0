"""The observation noise of a dimension: an Ornstein-Uhlenbeck process, and its whitening.

The fit residuals are strongly correlated from one sample to the next, so the noise of
dimension d is ``sigma_d^2 K`` with ``K_ij = exp(-|t_i - t_j| / tau_d)`` (``tau_d = 0``: white
noise). Its precision is tridiagonal, so the likelihoods whiten the observation and the basis
instead of forming ``K``.
"""

from __future__ import annotations

import numpy as np

from promp.model import Primitive


def whiten(elapsed: np.ndarray, tau: float, x: np.ndarray) -> tuple[np.ndarray, float]:
    """Apply the whitening transform of an Ornstein-Uhlenbeck noise along axis -2.

    The noise of one dimension is ``sigma^2 K`` with ``K_ij = exp(-|t_i - t_j| / tau)``; its
    precision is tridiagonal, ``K^-1 = W^T W`` with ``(W x)_0 = x_0`` and
    ``(W x)_i = (x_i - rho_i x_(i-1)) / sqrt(1 - rho_i^2)``, ``rho_i = exp(-(t_i - t_(i-1)) /
    tau)``, so that ``x^T K^-1 x = |W x|^2``. ``tau = 0`` is white noise.

    Parameters
    ----------
    elapsed : array, shape (n,)
    x : array, shape (..., n, k)

    Returns
    -------
    (W x, log det K)
    """
    if tau <= 0 or x.shape[-2] < 2:
        return x, 0.0
    rho = np.exp(-np.diff(elapsed) / tau)
    scale = np.sqrt(1.0 - rho**2)
    out = np.array(x, dtype=float, copy=True)
    out[..., 1:, :] = (x[..., 1:, :] - rho[:, None] * x[..., :-1, :]) / scale[:, None]
    return out, float(2.0 * np.log(scale).sum())


def noise_groups(primitive: Primitive, dims: np.ndarray) -> dict[float, np.ndarray]:
    """Observed dimensions grouped by noise correlation time: {tau: positions in dims}."""
    taus = primitive.noise_tau[dims]
    return {float(tau): np.nonzero(taus == tau)[0] for tau in np.unique(taus)}
