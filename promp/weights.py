"""Per-demonstration weights by ridge regression on the phase basis (paper Eq. 2)."""

from __future__ import annotations

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


def fit_all_weights(
    basis: RBFBasis,
    demos: Sequence[Demonstration],
    layout: Layout,
    ridge: float | None,
) -> WeightFits:
    """Ridge weights of every demonstration; the ridge per modality by pooled GCV if None.

    Generalised cross-validation (Golub, Heath & Wahba 1979), pooled over demonstrations:
    ``sum_j n_j RSS_j(lambda) / (n_j - df_j(lambda))^2`` summed over a modality's dimensions,
    minimised over a log grid of relative strengths. Computed through the eigendecomposition of
    each ``Phi_j^T Phi_j``, so every candidate costs O(M D) per demonstration.
    """
    n_dims = layout.n_dims
    values = [layout.extract(demo) for demo in demos]
    phis = [basis(demo_phases(demo.times)) for demo in demos]
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
