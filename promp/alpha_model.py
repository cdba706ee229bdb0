"""The "model" estimate of the time modulation (paper Eq. 7).

Faster movements cover more ground in the same number of samples, so the displacement
``delta = X(n_o) - X(1)`` of an observed modality after ``n_o`` samples predicts alpha. For every
``n_o`` of a grid (1 .. the longest training demonstration, in at most ~60 steps; an observation
uses the grid point at or below its length), alpha is regressed on normalised
Gaussian RBFs of each component of ``delta`` (5 per component, spread over the training range),
by ridge regression whose strength is chosen by generalised cross-validation. Training
demonstrations shorter than ``n_o`` contribute their final displacement, as in the original
toolbox. Each primitive learns its own model from its own training demonstrations, one per
modality; several observed modalities are combined by inverse-variance weighting, with each
model's GCV residual variance at that ``n_o``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from promp.data import Demonstration

__all__ = [
    "AlphaModel", "GRID_POINTS", "MAX_U", "N_RBF", "RELATIVE_SPAN", "combine", "min_span",
    "resample_uniform"
]  # fmt: skip

N_RBF = 5
GRID_POINTS = 60
_RIDGES = np.logspace(-8, 2, 11)


# The smallest span of displacements the features spread over, as a fraction of the largest
# span of the modality at any n_o: the features do not depend on the modality's unit.
RELATIVE_SPAN = 1e-9
MAX_U = 1e6  # beyond this many spans from the range, the features are the edge RBF's alone


def _features(
    delta: np.ndarray, lo: np.ndarray, hi: np.ndarray, min_span: float
) -> np.ndarray:
    """RBF features of displacements.

    Parameters
    ----------
    delta : array, shape (..., n_components)
    lo, hi : array, shape (..., n_components)
        Range of the training displacements spanned by the centres.
    min_span : float
        The smallest span (:func:`min_span`), in the modality's unit.

    Returns
    -------
    array, shape (..., n_components * N_RBF)
    """
    span = np.maximum(hi - lo, min_span)
    u = np.clip((delta - lo) / span, -MAX_U, MAX_U)  # 0..1 over the training range
    centres = np.linspace(0.0, 1.0, N_RBF)
    sigma = 1.0 / (N_RBF - 1)
    exponent = -0.5 * ((u[..., None] - centres) / sigma) ** 2
    exponent -= exponent.max(axis=-1, keepdims=True)
    values = np.exp(exponent)
    values /= values.sum(axis=-1, keepdims=True)
    return values.reshape(*values.shape[:-2], -1)


def min_span(lo: np.ndarray, hi: np.ndarray) -> float:
    """:data:`RELATIVE_SPAN` of the largest span of displacements at any ``n_o`` (lo, hi:
    shape (n_grid, n_components)); 1 for a modality that never moved (then every training
    displacement is 0 and nothing depends on it)."""
    largest = float(np.max(hi - lo)) if hi.size else 0.0
    return RELATIVE_SPAN * largest if largest > 0.0 else 1.0


@dataclass(frozen=True, eq=False)
class AlphaModel:
    """Eq. 7 for one primitive and one modality.

    Attributes
    ----------
    n_observed : array of int, shape (n_grid,)
        The ``n_o`` of each row, increasing from 1.
    lo, hi : array, shape (n_grid, n_components)
        Training displacement range per ``n_o``.
    weights : array, shape (n_grid, n_components * N_RBF)
    residual_var : array, shape (n_grid,)
        GCV estimate of the squared alpha error at each ``n_o``.
    """

    n_observed: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    weights: np.ndarray
    residual_var: np.ndarray

    @property
    def n_grid(self) -> int:
        return int(self.weights.shape[0])

    @classmethod
    def fit(cls, trajectories: Sequence[np.ndarray], alphas: np.ndarray) -> AlphaModel:
        """Learn from training trajectories of one modality.

        Parameters
        ----------
        trajectories : list of arrays, shape (n_j, n_components)
            Each training demonstration's values of the modality, at the model's sample rate.
        alphas : array, shape (n_demos,)
        """
        alphas = np.asarray(alphas, dtype=float)
        longest = max(t.shape[0] for t in trajectories)
        step = max(1, -(-longest // GRID_POINTS))
        n_observed = np.arange(1, longest + 1, step)
        n_grid = n_observed.shape[0]
        # deltas[g, j] = X_j(min(n_observed[g], n_j)) - X_j(1)
        deltas = np.stack(
            [t[np.minimum(n_observed, t.shape[0]) - 1] - t[0] for t in trajectories], axis=1
        )  # (n_grid, n_demos, n_components)
        lo = deltas.min(axis=1)
        hi = deltas.max(axis=1)
        feats = _features(deltas, lo[:, None, :], hi[:, None, :], min_span(lo, hi))
        # Ridge regressions for every n_o at once, through the eigendecomposition of the
        # F x F Gram matrices: with F^T F = V diag(e) V^T and b = V^T F^T y, the coefficients
        # are V diag(1 / (e + ridge)) b and the hat matrix has trace sum(e / (e + ridge)).
        gram = feats.transpose(0, 2, 1) @ feats  # (n_grid, F, F)
        eig, vec = np.linalg.eigh(gram)
        eig = np.maximum(eig, 0.0)
        b = np.einsum("gfk,gnf,n->gk", vec, feats, alphas)
        n = alphas.shape[0]
        best_w = np.zeros((n_grid, feats.shape[2]))
        best_score = np.full(n_grid, np.inf)
        best_var = np.zeros(n_grid)
        for ridge in _RIDGES * max(float(np.max(eig)), 1e-12):
            coef = np.einsum("gfk,gk->gf", vec, b / (eig + ridge))
            fitted = np.einsum("gnf,gf->gn", feats, coef)
            rss = ((alphas[None, :] - fitted) ** 2).sum(axis=1)
            dof = np.maximum(n - (eig / (eig + ridge)).sum(axis=1), 1e-3)
            score = n * rss / dof**2
            better = score < best_score
            best_w[better] = coef[better]
            best_score[better] = score[better]
            best_var[better] = rss[better] / dof[better]
        return cls(n_observed=n_observed, lo=lo, hi=hi, weights=best_w, residual_var=best_var)

    def predict(self, delta: np.ndarray, n_observed: int) -> tuple[float, float]:
        """Alpha and its error variance after ``n_observed`` samples moved by ``delta``."""
        row = max(int(np.searchsorted(self.n_observed, n_observed, side="right")) - 1, 0)
        feats = _features(
            np.asarray(delta, dtype=float), self.lo[row], self.hi[row], min_span(self.lo, self.hi)
        )
        return float(feats @ self.weights[row]), float(self.residual_var[row])

    def to_arrays(self) -> dict[str, np.ndarray]:
        return {
            "n_observed": self.n_observed,
            "lo": self.lo,
            "hi": self.hi,
            "weights": self.weights,
            "residual_var": self.residual_var,
        }


def combine(
    models: Mapping[str, AlphaModel], deltas: Mapping[str, np.ndarray], n_observed: int
) -> float:
    """Inverse-variance weighted alpha from the models of several observed modalities."""
    estimates = [models[name].predict(deltas[name], n_observed) for name in deltas]
    inv = np.array([1.0 / max(var, 1e-12) for _, var in estimates])
    values = np.array([alpha for alpha, _ in estimates])
    return float((values * inv).sum() / inv.sum())


def resample_uniform(demo: Demonstration, values: np.ndarray, dt: float) -> np.ndarray:
    """Values on a uniform grid of period ``dt`` from the first sample (for Eq. 7)."""
    n = int(round(demo.duration / dt)) + 1
    grid = demo.times[0] + dt * np.arange(n)
    grid[-1] = min(grid[-1], demo.times[-1])
    return np.column_stack([np.interp(grid, demo.times, v) for v in values.T])
