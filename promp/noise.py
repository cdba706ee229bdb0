"""The observation noise of a dimension: an Ornstein-Uhlenbeck process, and its whitening.

The fit residuals are strongly correlated from one sample to the next, so the noise of
dimension d is ``sigma_d^2 K`` with ``K_ij = exp(-|t_i - t_j| / tau_d)`` (``tau_d = 0``: white
noise). Its precision is tridiagonal, so the likelihoods whiten the observation and the basis
instead of forming ``K``.

Observation noise is a property of the sensor, not of a primitive: per modality, its level is
the mean squared fit residual of its dimensions over the demonstrations of all primitives,
with the degrees of freedom of the regression removed, unless given in
:class:`promp.model.Settings` (:func:`estimate_noise`). (Per-primitive noise levels would bias
recognition towards the primitive fitted most tightly: the normalising term
``n_o log sigma^2`` of the likelihood then outweighs the data.)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from promp.data import Layout
from promp.model import Primitive, Settings
from promp.scale import RELATIVE_FLOOR
from promp.weights import WeightFits

__all__ = [
    "correlation_steps", "estimate_noise", "noise_groups", "whiten"
]  # fmt: skip


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
    rho, scale = _steps(elapsed, tau)
    out = np.array(x, dtype=float, copy=True)
    out[..., 1:, :] = (x[..., 1:, :] - rho[:, None] * x[..., :-1, :]) / scale[:, None]
    return out, float(2.0 * np.log(scale).sum())


def correlation_steps(elapsed: np.ndarray, taus: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``rho_i`` and ``sqrt(1 - rho_i^2)`` of each step between the samples ``elapsed`` (n,)
    for each correlation time of ``taus`` (G,) (:func:`whiten`; 0 and 1 for white noise,
    ``tau = 0``, which leaves a sample as it is): arrays of shape (G, n - 1)."""
    rho = np.zeros((taus.shape[0], elapsed.shape[0] - 1))
    scale = np.ones_like(rho)
    for index, tau in enumerate(taus.tolist()):
        if tau > 0:
            rho[index], scale[index] = _steps(elapsed, tau)
    return rho, scale


def _steps(elapsed: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """``rho_i`` and ``sqrt(1 - rho_i^2)`` of each step, shape (n - 1,), for ``tau > 0``."""
    rho = np.exp(-np.diff(elapsed) / tau)
    return rho, np.sqrt(1.0 - rho**2)


def noise_groups(primitive: Primitive, dims: np.ndarray) -> dict[float, np.ndarray]:
    """Observed dimensions grouped by noise correlation time: {tau: positions in dims}."""
    taus = primitive.noise_tau[dims]
    return {float(tau): np.nonzero(taus == tau)[0] for tau in np.unique(taus)}


def estimate_noise(
    fits: WeightFits,
    times: Sequence[np.ndarray],
    layout: Layout,
    settings: Settings,
) -> tuple[np.ndarray, np.ndarray]:
    """Observation noise per dimension, one level per modality (see the module docstring).

    Parameters
    ----------
    fits : WeightFits
        Fits of every demonstration (of every primitive).
    times : list of arrays, shape (n_j,)
        Their sample times, in the same order.

    Returns
    -------
    noise_var : array, shape (n_dims,)
        Pooled residual variance of the per-demonstration fits, with the regression's degrees
        of freedom removed, scaled by ``settings.noise_scale``, or ``settings.noise_std``
        squared where given; never below :data:`promp.scale.RELATIVE_FLOOR` times the
        modality's squared scale (``fits.scale``: a floor in the data's unit, not an absolute
        one).
    noise_tau : array, shape (n_dims,)
        Correlation time (s) of an Ornstein-Uhlenbeck noise with the residuals' pooled lag-one
        autocorrelation ``rho`` at the mean sample step ``dt``: ``-dt / log(rho)``; 0 (white)
        when ``rho <= 0`` or ``settings.noise_correlation`` is off.
    """
    sse, lagged = fits.sse, fits.lagged  # sums of r_i^2 and of r_i r_(i-1)
    dof = np.maximum(sum(fits.dof), 1.0)
    # the residuals' step: a demonstration's duration over its steps (they are evenly spaced
    # in phase, :mod:`promp.weights`); the median over demonstrations, so one with a long
    # logging pause does not stretch the correlation time of them all
    dt = float(np.median([(t[-1] - t[0]) / (t.shape[0] - 1) for t in times]))
    noise_var = sse / dof
    noise_tau = np.zeros(layout.n_dims)
    for modality in layout.modalities:
        dims = layout.dims([modality.name])
        rho = float(lagged[dims].sum() / max(sse[dims].sum(), 1e-300))
        if settings.noise_correlation and 0.0 < rho < 1.0:
            noise_tau[dims] = -dt / np.log(rho)
        if modality.name in settings.noise_std:
            noise_var[dims] = settings.noise_std[modality.name] ** 2
        else:
            noise_var[dims] = noise_var[dims].mean() * settings.noise_scale**2
    return np.maximum(noise_var, RELATIVE_FLOOR * fits.scale), noise_tau
