"""The inference methods the evaluation compares: ours and the original toolbox ("seed").

Both expose the same two steps: ``fit(dataset)`` on the training demonstrations, then
``infer(demo, n_observed, observe, alpha_method)`` giving the recognised primitive, alpha, and
the prior and posterior mean trajectories of every dimension over the predicted duration.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from promp.data import Demonstration, Layout
from promp.inference import Observation, condition, predict, recognise
from promp.model import ProMPModel, Settings, fit


@dataclass(frozen=True, eq=False)
class Inferred:
    """One inference, as the metrics need it.

    Attributes
    ----------
    index : int
        Recognised primitive (index into the fitted primitives).
    probabilities : array, shape (n_primitives,)
    alpha : float
    duration : float
        Predicted duration, seconds.
    prior_mean, posterior_mean, posterior_std, prior_std : array, shape (n_points, n_dims)
        Over [0, duration], ``n_points`` evenly spaced phases from 0 to 1.
    """

    index: int
    probabilities: np.ndarray
    alpha: float
    duration: float
    prior_mean: np.ndarray
    prior_std: np.ndarray
    posterior_mean: np.ndarray
    posterior_std: np.ndarray


class Ours:
    """The method of this project (:mod:`promp.inference`)."""

    name = "ours"

    def __init__(
        self,
        layout: Layout,
        settings: Settings | None = None,
        refine: bool = False,
        evidence: str = "marginal",
    ):
        self.layout = layout
        self.settings = settings or Settings()
        self.refine = refine
        self.evidence = evidence
        self.model: ProMPModel | None = None

    def fit(self, dataset: Mapping[str, Sequence[Demonstration]], sample_period: float) -> None:
        self.model = fit(dataset, self.layout, self.settings, sample_period=sample_period)

    def infer(
        self, demo: Demonstration, n_observed: int, observe: Sequence[str], alpha_method: str
    ) -> Inferred:
        model = self.model
        assert model is not None, "fit() first"
        obs = Observation.from_demo(model, demo, n_observed, observe)
        reco = recognise(
            model, obs, alpha_method=alpha_method, refine=self.refine, evidence=self.evidence
        )
        prim = model.primitives[reco.index]
        posterior = condition(model, prim, obs, reco.alpha)
        prior = predict(model, prim, reco.alpha)
        post = predict(model, posterior, reco.alpha)
        return Inferred(
            index=reco.index,
            probabilities=reco.probabilities,
            alpha=reco.alpha,
            duration=post.duration,
            prior_mean=prior.mean,
            prior_std=prior.std,
            posterior_mean=post.mean,
            posterior_std=post.std,
        )
