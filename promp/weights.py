"""Per-demonstration weights by ridge regression on the phase basis (paper Eq. 2).

A demonstration is a continuous movement known at its samples; between two samples it is taken
to move in a straight line. Its weights minimise the squared error **integrated over the phase**
(plus the ridge), computed on ``n`` evenly spaced phases (``n`` its number of samples) where the
straight lines are read: for an evenly sampled demonstration those are its own samples, so
nothing changes; for one whose logger paused (a gap) or skipped samples, every part of the
phase is weighted by how long it lasts, not by how many samples it happened to get. Fitted at the
samples themselves, a 20 s logging pause leaves the basis functions of the gap unconstrained and
their weights reach metres for a hand that spans 20 cm (``tests/test_promp_quality.py``).
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from promp.basis import RBFBasis
from promp.data import Demonstration, Layout
from promp.scale import modality_scale
from promp.timing import demo_phases


def fit_weights(
    basis: RBFBasis, times: np.ndarray, values: np.ndarray, ridge: float
) -> tuple[np.ndarray, np.ndarray]:
    """Ridge regression of one demonstration on the basis (paper Eq. 2).

    Parameters
    ----------
    times : array, shape (n_samples,)
    values : array, shape (n_samples, n_dims)

    Returns
    -------
    weights : array, shape (n_dims * n_basis,)
        Dimension-major.
    residuals : array, shape (n_samples, n_dims)
    """
    phi = basis(demo_phases(times))
    gram = phi.T @ phi
    lam = ridge * np.trace(gram) / gram.shape[0]
    chol = np.linalg.cholesky(gram + (lam + 1e-12) * np.eye(gram.shape[0]))
    w = np.linalg.solve(chol.T, np.linalg.solve(chol, phi.T @ values))  # (n_basis, n_dims)
    return w.T.reshape(-1), values - phi @ w


RIDGE_GRID = np.logspace(-10, 1, 23)


@dataclass
class WeightFits:
    """Per-demonstration weights (Eq. 2) of a set of demonstrations.

    Attributes
    ----------
    weights : list of arrays, shape (n_dims * n_basis,)
    residuals : list of arrays, shape (n_samples_j, n_dims)
    dof : list of arrays, shape (n_dims,)
        Residual degrees of freedom, ``n_j - trace(hat matrix)``.
    ridge : array, shape (n_dims,)
        The relative ridge strength used for each dimension.
    scale : array, shape (n_dims,)
        The squared scale of each dimension's modality (:func:`promp.scale.modality_scale`),
        what every floor of the fit is relative to.
    """

    weights: list[np.ndarray]
    residuals: list[np.ndarray]
    dof: list[np.ndarray]
    ridge: np.ndarray
    scale: np.ndarray


def uniform_phase_values(demo: Demonstration, layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """The layout's values of ``demo`` read on ``n`` evenly spaced phases, straight lines
    between samples: (phases (n,), values (n, n_dims)); its own samples when they are evenly
    spaced. Kept per demonstration and layout (both immutable): every fit of the automatic
    settings' search reads the same demonstrations."""
    cache = _UNIFORM.setdefault(demo, {})
    if layout not in cache:
        values = layout.extract(demo)
        phases = np.linspace(0.0, 1.0, demo.n_samples)
        own = demo_phases(demo.times)
        if float(np.abs(own - phases).max()) > 1e-9:
            values = np.column_stack([np.interp(phases, own, v) for v in values.T])
        values.setflags(write=False)
        cache[layout] = (phases, values)
    return cache[layout]


_UNIFORM: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def fit_all_weights(
    basis: RBFBasis,
    demos: Sequence[Demonstration],
    layout: Layout,
    ridge: float | None,
) -> WeightFits:
    """Ridge weights of every demonstration (on evenly spaced phases, see the module docstring;
    the residuals are there too); the ridge per modality by pooled GCV if None.

    Generalised cross-validation (Golub, Heath & Wahba 1979), pooled over demonstrations:
    ``sum_j n_j RSS_j(lambda) / (n_j - df_j(lambda))^2`` summed over a modality's dimensions,
    minimised over a log grid of relative strengths. Computed through the eigendecomposition of
    each ``Phi_j^T Phi_j``, so every candidate costs O(M D) per demonstration.
    """
    n_dims = layout.n_dims
    uniform = [uniform_phase_values(demo, layout) for demo in demos]
    values = [v for _, v in uniform]
    phis = [basis(z) for z, _ in uniform]
    eig, vec = np.linalg.eigh(np.stack([phi.T @ phi for phi in phis]))  # (N, M), (N, M, M)
    eig = np.maximum(eig, 0.0)
    scale = eig.sum(axis=1) / eig.shape[1]  # mean diagonal of Phi^T Phi, (N,)
    proj = np.stack(
        [v.T @ (phi.T @ y) for v, phi, y in zip(vec, phis, values, strict=True)]
    )  # (N, M, D)
    yy = np.stack([(y**2).sum(axis=0) for y in values])  # (N, D)
    n = np.array([y.shape[0] for y in values], dtype=float)

    rel = np.full(n_dims, ridge if ridge is not None else 0.0)
    if ridge is None:
        grid = RIDGE_GRID[:, None, None]
        shrink = 1.0 / (eig + (grid + 1e-12) * scale[:, None])  # (G, N, M)
        coef = proj * shrink[..., None]  # (G, N, M, D)
        rss = yy - 2 * (coef * proj).sum(axis=2) + (coef**2 * eig[..., None]).sum(axis=2)
        df = (eig * shrink).sum(axis=2)  # (G, N)
        scores = (n[:, None] * np.maximum(rss, 0.0) / np.maximum(n - df, 1e-3)[..., None] ** 2)
        scores = scores.sum(axis=1)  # (G, D)
        for modality in layout.modalities:
            dims = layout.dims([modality.name])
            rel[dims] = RIDGE_GRID[int(np.argmin(scores[:, dims].sum(axis=1)))]
    fits = WeightFits(
        weights=[], residuals=[], dof=[], ridge=rel, scale=modality_scale(values, layout)
    )
    shrink = 1.0 / (eig[:, :, None] + (rel[None, None, :] + 1e-12) * scale[:, None, None])
    w_all = vec @ (proj * shrink)  # (N, M, D)
    for y, phi, w, e, sh in zip(values, phis, w_all, eig, shrink, strict=True):
        fits.weights.append(w.T.reshape(-1))
        fits.residuals.append(y - phi @ w)
        fits.dof.append(y.shape[0] - (e[:, None] * sh).sum(axis=0))
    return fits
