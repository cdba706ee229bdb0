"""Baseline: the original ProMP toolbox's recognition and prediction (``--method seed``).

Reproduced for comparison only; it is not the method of this project. Following the authors'
Matlab code:

* M = 5 basis functions per dimension, centres ``(i - 1) / M`` and ``exp(-(z - c)^2 / (1/M^2))``,
  normalised (:class:`promp.basis.SeedBasis`); sample ``t`` (1-based) of a movement of
  ``n = s_bar / alpha`` samples has phase ``alpha * t / s_bar``;
* weights by least squares with ridge 1e-12; the plain sample covariance (plus a tiny jitter
  when it is not positive definite, where the toolbox calls ``nearestSPD``);
* recognition: for every primitive and every training alpha of that primitive whose length
  covers the observation, the observed samples are shifted so their first sample equals the
  prior mean's first sample, and scored with ``log N(x | Phi_o mu_w, 1e-5 I)``: the weight
  covariance is ignored, so this is template matching. The best (primitive, alpha) wins;
* conditioning of the full weight distribution on the (unshifted) observation with noise 1e-5;
* "model" alpha: alpha regressed at the observed length on 5 normalised RBFs per component of
  ``|X(n_o) - X(1)|`` (training demonstrations shorter than ``n_o`` use their last sample),
  with centres spread over the training range as the toolbox intends (its inference call
  recomputes the range from the single test point, which we do not reproduce).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from promp.basis import SeedBasis
from promp.data import Demonstration, Layout
from promp.evaluate.methods import TRUE_DURATION, TrialAnswer

__all__ = ["NOISE", "N_BASIS", "RIDGE", "S_BAR", "ToolboxBaseline"]

N_BASIS = 5
RIDGE = 1e-12
NOISE = 1e-5
S_BAR = 100.0


def _seed_phases(alpha: float, n: int) -> np.ndarray:
    return alpha * np.arange(1, n + 1) / S_BAR


def _alpha_features(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The toolbox's AlphaBasis: 5 RBFs per component, ``exp(-(x - c)^2 / sqrt(0.2))``."""
    inter = (hi - lo + 1.0) / 5.0
    centres = lo[:, None] + inter[:, None] * np.arange(5)[None, :]  # (n_comp, 5)
    values = np.exp(-((x[..., :, None] - centres) ** 2) / math.sqrt(0.2))
    total = values.sum(axis=-1, keepdims=True)
    values = np.where(total > 0, values / np.where(total > 0, total, 1.0), 0.0)
    return values.reshape(*values.shape[:-2], -1)


class _SeedPrimitive:
    def __init__(self, trajectories: list[np.ndarray], basis: SeedBasis):
        self.trajectories = trajectories
        n_dims = trajectories[0].shape[1]
        self.alphas = np.array([S_BAR / t.shape[0] for t in trajectories])
        weights = []
        for traj, alpha in zip(trajectories, self.alphas, strict=True):
            phi = basis(_seed_phases(alpha, traj.shape[0]))
            gram = phi.T @ phi + RIDGE * np.eye(N_BASIS)
            weights.append(np.linalg.solve(gram, phi.T @ traj).T.reshape(-1))
        w = np.array(weights)
        self.mean = w.mean(axis=0)
        cov = np.cov(w, rowvar=False)
        cov = 0.5 * (cov + cov.T)
        jitter = 0.0
        scale = max(float(np.mean(np.diag(cov))), 1e-300)
        while True:  # nearest SPD by the smallest jitter that makes it factorisable
            try:
                np.linalg.cholesky(cov + jitter * np.eye(cov.shape[0]))
                break
            except np.linalg.LinAlgError:
                jitter = max(jitter * 10, 1e-12 * scale)
        self.cov = cov + jitter * np.eye(cov.shape[0])
        self.n_dims = n_dims


class ToolboxBaseline:
    """The authors' Matlab toolbox, reproduced as the baseline (`--method seed`; see the module
    docstring)."""

    name = "seed"

    def __init__(self, layout: Layout):
        self.layout = layout
        self.basis = SeedBasis(N_BASIS)
        self.primitives: list[_SeedPrimitive] = []
        self.sample_period = 1.0

    def fit(self, dataset: Mapping[str, Sequence[Demonstration]], sample_period: float) -> None:
        self.sample_period = sample_period
        self.primitives = [
            _SeedPrimitive([self.layout.extract(d) for d in demos], self.basis)
            for demos in dataset.values()
        ]

    def _observed_blocks(self, dims: np.ndarray) -> np.ndarray:
        return (dims[:, None] * N_BASIS + np.arange(N_BASIS)[None, :]).reshape(-1)

    def _model_alpha(self, prim: _SeedPrimitive, y: np.ndarray, dims: np.ndarray) -> float:
        n_obs = y.shape[0]
        variation = np.array(
            [np.abs(t[min(n_obs, t.shape[0]) - 1, dims] - t[0, dims]) for t in prim.trajectories]
        )
        lo, hi = variation.min(axis=0), variation.max(axis=0)
        feats = _alpha_features(variation, lo, hi)
        gram = feats.T @ feats + RIDGE * np.eye(feats.shape[1])
        w_alpha = np.linalg.solve(gram, feats.T @ prim.alphas)
        alpha = float(_alpha_features(np.abs(y[-1] - y[0]), lo, hi) @ w_alpha)
        if not np.isfinite(alpha) or alpha <= 0:
            alpha = float(prim.alphas.min())
        if math.floor(S_BAR / alpha) < n_obs:  # the toolbox's guard
            alpha = S_BAR / n_obs
        return alpha

    def _score(self, prim: _SeedPrimitive, y: np.ndarray, dims: np.ndarray, alpha: float):
        phi = self.basis(_seed_phases(alpha, y.shape[0]))
        mu = prim.mean.reshape(prim.n_dims, N_BASIS)[dims]  # (Do, M)
        u = phi @ mu.T  # (n, Do)
        x = y - y[0] + u[0]
        resid = x - u
        n = resid.size
        return -0.5 * ((resid**2).sum() / NOISE + n * math.log(2 * math.pi * NOISE))

    def _evidence(
        self, demo: Demonstration, y: np.ndarray, dims: np.ndarray, alpha_method: str
    ) -> tuple[np.ndarray, tuple[float, int, float]]:
        """Every primitive's best score over its candidate alphas, shape (n_primitives,), and
        the best (score, primitive, alpha) of all."""
        n_observed = y.shape[0]
        best = (-np.inf, 0, 1.0)
        evidence = np.full(len(self.primitives), -np.inf)
        for k, prim in enumerate(self.primitives):
            if alpha_method == "model":
                alphas = [self._model_alpha(prim, y, dims)]
            elif alpha_method == TRUE_DURATION:  # the toolbox's alpha of the true length
                alphas = [S_BAR / demo.n_samples]
            else:
                alphas = [a for a in prim.alphas if math.floor(S_BAR / a) >= n_observed]
            for alpha in alphas:
                score = self._score(prim, y, dims, alpha)
                evidence[k] = max(evidence[k], score)
                if score > best[0]:
                    best = (score, k, alpha)
        return evidence, best

    def infer(
        self, demo: Demonstration, n_observed: int, observe: Sequence[str], alpha_method: str
    ) -> TrialAnswer:
        dims = self.layout.dims(observe)
        y = self.layout.extract(demo)[:n_observed, dims]
        evidence, best = self._evidence(demo, y, dims, alpha_method)
        _, index, alpha = best
        if not np.isfinite(best[0]):
            # No training alpha covers the observation: the toolbox would fail; fall back to
            # the longest movement of the first primitive.
            index, alpha = 0, float(self.primitives[0].alphas.min())
        prim = self.primitives[index]
        n_f = max(int(round(S_BAR / alpha)), n_observed, 2)
        phi_full = self.basis(_seed_phases(alpha, n_f))
        blocks = self._observed_blocks(dims)
        a = np.zeros((n_observed * len(dims), prim.mean.shape[0]))
        for i, b in enumerate(range(0, len(blocks), N_BASIS)):
            a[i * n_observed : (i + 1) * n_observed, blocks[b : b + N_BASIS]] = phi_full[
                :n_observed
            ]
        s = a @ prim.cov @ a.T + NOISE * np.eye(a.shape[0])
        gain = np.linalg.solve(s, a @ prim.cov).T
        mean = prim.mean + gain @ (y.T.reshape(-1) - a @ prim.mean)
        cov = prim.cov - gain @ a @ prim.cov

        def trajectory(w: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            m = phi_full @ w.reshape(prim.n_dims, N_BASIS).T
            var = np.stack(
                [
                    np.einsum(
                        "nm,mk,nk->n",
                        phi_full,
                        sigma[d * N_BASIS : (d + 1) * N_BASIS, d * N_BASIS : (d + 1) * N_BASIS],
                        phi_full,
                    )
                    for d in range(prim.n_dims)
                ],
                axis=1,
            )
            return m, np.sqrt(np.maximum(var, 0))

        prior_mean, prior_std = trajectory(prim.mean, prim.cov)
        post_mean, post_std = trajectory(mean, cov)
        return TrialAnswer(
            index=index,
            probabilities=_probabilities(evidence),
            alpha=float(alpha),
            duration=(S_BAR / alpha - 1.0) * self.sample_period,
            prior_mean=prior_mean,
            prior_std=prior_std,
            posterior_mean=post_mean,
            posterior_std=post_std,
        )

    def probabilities_at(
        self,
        demo: Demonstration,
        n_observed: Sequence[int],
        observe: Sequence[str],
        alpha_method: str,
    ) -> tuple[np.ndarray, str]:
        """The probabilities :meth:`infer` gives after each of ``n_observed`` samples, without
        its conditioning and trajectories: shape (len(n_observed), n_primitives); a row of NaN
        where no training speed of any primitive covers the observation, and why."""
        dims = self.layout.dims(observe)
        values = self.layout.extract(demo)[:, dims]
        out = np.full((len(n_observed), len(self.primitives)), np.nan)
        error = ""
        for i, n in enumerate(int(n) for n in n_observed):
            evidence, _ = self._evidence(demo, values[:n], dims, alpha_method)
            if np.isfinite(evidence).any():
                out[i] = _probabilities(evidence)
            else:
                error = error or "no training speed of any primitive covers the observation"
        return out, error


def _probabilities(evidence: np.ndarray) -> np.ndarray:
    """The toolbox's class probabilities: its scores normalised (NaN when none is finite)."""
    with np.errstate(invalid="ignore"):
        probabilities = np.exp(evidence - np.max(evidence))
        return probabilities / probabilities.sum()
