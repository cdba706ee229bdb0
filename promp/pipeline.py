"""The whole inference, once: recognise, condition, predict, and (given the truth) measure.

The studio's scrub step and live stream, the evaluation and the robot-side example all call
:func:`infer` (the studio's outlier flag is :func:`promp.typicality.typicality`). A change of
method lands here (or below) and nowhere else.

The prediction is drawn at the speed whose duration is the posterior mean of the recognised
primitive's duration (:mod:`promp.duration`), not at the posterior mode: the mode of a long
observation often sits at the shortest duration that still contains it, a movement ending
now.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from promp import metrics
from promp.data import Demonstration
from promp.duration import Timing, timing
from promp.incremental import IncrementalStatistics
from promp.inference import Observation, Posterior, Prediction, condition, predict
from promp.model import ProMPModel
from promp.recognition import AlphaMethod, Recognition, recognise

__all__ = ["Errors", "Inference", "infer", "measure", "relative_speed"]


@dataclass(frozen=True)
class Errors:
    """An inference against the whole movement it observed the start of
    (:mod:`promp.metrics`). Positions in the unit of ``modality`` (metres for the hand)."""

    modality: str
    position: float  # mean error of the predicted remainder (NaN when nothing remains)
    goal: float  # error of the predicted final position
    duration: float  # |predicted duration (posterior mean) - true duration|, seconds
    duration_covered: bool  # the true duration lies in the duration's interval


@dataclass(frozen=True, eq=False)
class Inference:
    """What an early observation says about the rest of the movement.

    Attributes
    ----------
    recognition : Recognition
        Which primitive, the probability of each primitive, the speed's posterior.
    timing : Timing
        The recognised primitive's duration and the observed share of it (posterior means and
        intervals), and the speed the predictions are drawn at.
    posterior : Posterior
        The recognised primitive's weights conditioned on the observation (Eq. 8).
    prior, prediction : Prediction
        The recognised primitive's prior and posterior trajectories at ``timing.alpha``, over
        the predicted duration.
    natural : Prediction or None
        The posterior on the predicted number of samples (what the errors are measured on);
        given when ``truth`` was.
    errors : Errors or None
        Against ``truth``, when given.
    """

    recognition: Recognition
    timing: Timing
    posterior: Posterior
    prior: Prediction
    prediction: Prediction
    observed_until: float
    natural: Prediction | None = None
    errors: Errors | None = None

    @property
    def index(self) -> int:
        return self.recognition.index

    @property
    def primitive(self) -> str:
        return self.recognition.primitive

    @property
    def alpha(self) -> float:
        """The speed of the predictions (the posterior-mean duration's)."""
        return self.timing.alpha

    @property
    def probabilities(self) -> np.ndarray:
        return self.recognition.probabilities

    @property
    def duration(self) -> float:
        """The predicted duration of the whole movement (posterior mean), seconds."""
        return self.prediction.duration

    @property
    def remaining(self) -> float:
        """Predicted seconds left after the observation."""
        return max(0.0, self.duration - self.observed_until)


def infer(
    model: ProMPModel,
    obs: Observation,
    alpha_method: AlphaMethod = "ml",
    n_points: int | None = None,
    truth: Demonstration | None = None,
    duration: float | None = None,
    statistics: IncrementalStatistics | None = None,
) -> Inference:
    """Recognise the primitive and its speed, condition on the observation, predict; with
    ``truth`` (the whole movement ``obs`` is the start of), measure the errors.

    The primitive whose evidence (Eq. 6 integrated over its speed prior) is highest is
    recognised (:func:`promp.recognition.recognise`); the prediction is drawn at the speed of
    its posterior-mean duration (:mod:`promp.duration`), the weights conditioned on the
    observation there (Eq. 8, :func:`promp.inference.condition`) and every dimension
    predicted over the whole movement (:func:`promp.inference.predict`).

    Parameters
    ----------
    model : ProMPModel
    obs : Observation
        The first samples of the movement, in any of the model's modalities.
    alpha_method : {"ml", "model"}
        The speed's prior: each primitive's, fitted to its training speeds (``"ml"``), or
        half of it centred on the Eq. 7 regression from the early displacement
        (``"model"``).
    n_points : int, optional
        Samples of the predictions (default: the predicted number of samples).
    truth : Demonstration, optional
        The whole movement: the errors are measured against it.
    duration : float, optional
        The movement's duration when it is known (s): every primitive scored at that speed.
    statistics : IncrementalStatistics, optional
        For an observation that grows (a live movement inferred on at each update), what the
        likelihood kept of its first samples (:mod:`promp.incremental`): the same inference
        to round-off (within 1e-9), at a cost that grows with the samples new since the last
        update rather than with all of them.

    Returns
    -------
    Inference
        ``primitive``, ``probabilities`` (n_primitives,), ``timing`` (the duration and the
        observed share, with intervals), ``posterior`` (weights), ``prior`` and
        ``prediction`` (trajectories: ``mean``, ``std`` of shape (n_points, n_dims)),
        ``errors`` with ``truth``.

    Raises
    ------
    ValueError
        An unknown modality or alpha method, an empty or non-finite observation, a truth
        without the model's columns.
    """
    recognition = recognise(model, obs, alpha_method=alpha_method, duration=duration,
                            statistics=statistics)  # fmt: skip
    primitive = model.primitives[recognition.index]
    elapsed = float(obs.elapsed[-1])
    settings = model.settings
    estimate = timing(
        recognition, elapsed, model.sample_period, settings.s_bar,
        settings.duration_temperature or 1.0,
    )  # fmt: skip
    alpha = estimate.alpha
    posterior = condition(model, primitive, obs, alpha)
    prediction = predict(model, posterior, alpha, n_points=n_points)
    natural, errors = None, None
    if truth is not None:
        natural = prediction if n_points is None else predict(model, posterior, alpha)
        errors = measure(model, natural, estimate, truth, obs.n_observed)
    return Inference(
        recognition=recognition,
        timing=estimate,
        posterior=posterior,
        prior=predict(model, primitive, alpha, n_points=n_points),
        prediction=prediction,
        observed_until=elapsed,
        natural=natural,
        errors=errors,
    )


def measure(
    model: ProMPModel,
    natural: Prediction,
    estimate: Timing,
    truth: Demonstration,
    n_observed: int,
) -> Errors:
    """:class:`Errors` of a prediction on its natural samples against ``truth``."""
    name = metrics.position_modality(model.layout)
    dims = model.layout.dims([name])
    true_values = model.layout.extract(truth)[:, dims]
    predicted = natural.mean[:, dims]
    return Errors(
        modality=name,
        position=metrics.remainder_error(true_values, predicted, n_observed),
        goal=metrics.goal_error(true_values, predicted),
        duration=abs(natural.duration - truth.duration),
        duration_covered=estimate.duration.covers(truth.duration),
    )


def relative_speed(model: ProMPModel, inference: Inference) -> float:
    """The prediction's speed over the recognised primitive's typical one (exp of its training
    demonstrations' mean log alpha): 1 is its usual speed, more is faster."""
    typical = math.exp(model.primitives[inference.index].log_alpha_mean)
    return inference.alpha / typical
