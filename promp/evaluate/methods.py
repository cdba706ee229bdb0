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
from promp.evidence.pipeline import infer, recognise
from promp.inference import Observation
from promp.learn import choose, fit
from promp.model import ProMPModel, Settings

__all__ = ["ALPHA_ROWS", "TrialAnswer", "ProMPEngine", "TRUE_DURATION"]

# The evaluation's oracle row: the speed told, from the test movement's true duration (how far
# a perfect estimate of the duration would take the method).
TRUE_DURATION = "true"
ALPHA_ROWS = ("ml", "model", TRUE_DURATION)


@dataclass(frozen=True, eq=False)
class TrialAnswer:
    """One inference, as the metrics need it.

    Attributes
    ----------
    index : int
        Recognised primitive (index into the fitted primitives).
    probabilities : array, shape (n_primitives,)
    alpha : float
    duration : float
        Predicted duration, seconds.
    duration_low, duration_high : float
        Its central 90 % interval (NaN for a method that gives none).
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
    duration_low: float = float("nan")
    duration_high: float = float("nan")


class ProMPEngine:
    """This project's multi-modal ProMP engine (:func:`promp.evidence.infer`): `--method ours`."""

    name = "ours"

    def __init__(self, layout: Layout, settings: Settings | None = None):
        self.layout = layout
        self.settings = settings or Settings()
        self.model: ProMPModel | None = None

    @property
    def chooses(self) -> bool:
        """Whether a fit chooses any setting from its training set (else :meth:`choose`
        gives None, and the sweep has nothing to choose in blocks)."""
        return self.settings.to_choose

    def choose(
        self, dataset: Mapping[str, Sequence[Demonstration]], sample_period: float
    ) -> Settings | None:
        """The settings a fit on ``dataset`` chooses (:func:`promp.learn.choose`), or None when
        every one is given (nothing to choose). The sweep chooses once for several folds
        (:func:`promp.evaluate.sweep.run_sweep`) and hands the result to their fits."""
        if not self.chooses:
            return None
        return choose(dataset, self.layout, self.settings, sample_period=sample_period)

    def fit(
        self,
        dataset: Mapping[str, Sequence[Demonstration]],
        sample_period: float,
        chosen: Settings | None = None,
    ) -> None:
        """Learn ``dataset`` at this engine's settings, or at ``chosen`` (settings chosen
        beforehand by :meth:`choose` on other demonstrations: not chosen again)."""
        # the drawn region's calibration is for the studio: nothing here reads it
        self.model = fit(dataset, self.layout, chosen or self.settings,
                         sample_period=sample_period, regions=False)  # fmt: skip

    def infer(
        self, demo: Demonstration, n_observed: int, observe: Sequence[str], alpha_method: str
    ) -> TrialAnswer:
        model = self.model
        assert model is not None, "fit() first"
        obs = Observation.from_demo(model, demo, n_observed, observe)
        if alpha_method == TRUE_DURATION:
            result = infer(model, obs, duration=demo.duration)
        else:
            result = infer(model, obs, alpha_method=alpha_method)
        interval = result.timing.duration
        return TrialAnswer(
            index=result.index,
            probabilities=result.probabilities,
            alpha=result.alpha,
            duration=result.duration,
            prior_mean=result.prior.mean,
            prior_std=result.prior.std,
            posterior_mean=result.prediction.mean,
            posterior_std=result.prediction.std,
            duration_low=interval.low,
            duration_high=interval.high,
        )

    def probabilities_at(
        self,
        demo: Demonstration,
        n_observed: Sequence[int],
        observe: Sequence[str],
        alpha_method: str,
    ) -> tuple[np.ndarray, str]:
        """The primitives' probabilities after each of ``n_observed`` samples of ``demo``:
        what :meth:`infer` gives, recognised alone (nothing is conditioned or predicted).
        Each step is recognised from its samples alone: carrying the likelihood's sums from
        one step to the next (:meth:`promp.evidence.Evidence.extended`, what a live
        session does at every sample) saved nothing at steps of 2 % of these movements.

        Returns
        -------
        probabilities : array, shape (len(n_observed), n_primitives)
            A row of NaN where recognition raised ``ValueError``.
        error : str
            The first such reason ('' when there was none).
        """
        model = self.model
        assert model is not None, "fit() first"
        out = np.full((len(n_observed), len(model.primitives)), np.nan)
        error, done = "", {}
        duration = demo.duration if alpha_method == TRUE_DURATION else None
        method = "ml" if alpha_method == TRUE_DURATION else alpha_method
        for i, n in enumerate(int(n) for n in n_observed):
            if n not in done:
                try:
                    obs = Observation.from_demo(model, demo, n, observe)
                    done[n] = recognise(model, obs, method, duration).probabilities
                except ValueError as exc:
                    done[n], error = out[i], error or str(exc)
            out[i] = done[n]
        return out, error
