"""The whole inference, once: recognise, condition, predict (and how typical a movement is).

The studio's scrub step and live stream, the evaluation and the robot-side example all call
:func:`infer`; the studio's outlier flag calls :func:`typicality`. A change of method lands
here (or below) and nowhere else.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from promp.data import Demonstration, Layout
from promp.inference import Observation, Posterior, Prediction, condition, log_likelihoods, predict
from promp.learn import fit
from promp.model import ProMPModel, Settings
from promp.recognition import AlphaMethod, Recognition, recognise


@dataclass(frozen=True, eq=False)
class Inference:
    """What an early observation says about the rest of the movement.

    Attributes
    ----------
    recognition : Recognition
        Which primitive, its alpha, the probability of each primitive.
    posterior : Posterior
        The recognised primitive's weights conditioned on the observation (Eq. 8).
    prior, prediction : Prediction
        The recognised primitive's prior and posterior trajectories at the recognised alpha,
        over the predicted duration.
    """

    recognition: Recognition
    posterior: Posterior
    prior: Prediction
    prediction: Prediction

    @property
    def index(self) -> int:
        return self.recognition.index

    @property
    def primitive(self) -> str:
        return self.recognition.primitive

    @property
    def alpha(self) -> float:
        return self.recognition.alpha

    @property
    def probabilities(self) -> np.ndarray:
        return self.recognition.probabilities

    @property
    def duration(self) -> float:
        return self.prediction.duration


def infer(
    model: ProMPModel,
    obs: Observation,
    alpha_method: AlphaMethod = "ml",
    n_points: int | None = None,
) -> Inference:
    """Recognise the primitive and its speed, condition on the observation, predict.

    ``n_points`` samples the predictions (default: the predicted number of samples).

    Raises
    ------
    ValueError
        An unknown modality or alpha method, an empty or non-finite observation.
    """
    recognition = recognise(model, obs, alpha_method=alpha_method)
    primitive = model.primitives[recognition.index]
    posterior = condition(model, primitive, obs, recognition.alpha)
    return Inference(
        recognition=recognition,
        posterior=posterior,
        prior=predict(model, primitive, recognition.alpha, n_points=n_points),
        prediction=predict(model, posterior, recognition.alpha, n_points=n_points),
    )


@dataclass(frozen=True)
class Typicality:
    """How a demonstration compares with its primitive's other demonstrations.

    ``percentile`` is the fraction of the primitive's demonstrations (each scored by a model
    learned without it) whose log-likelihood is lower than this one's: near 0 means an
    outlier.
    """

    log_likelihood: float
    percentile: float

    @property
    def label(self) -> str:
        if self.percentile < 0.05:
            return "outlier"
        if self.percentile < 0.2:
            return "unusual"
        return "typical"


def _per_sample_log_likelihood(
    model: ProMPModel, demo: Demonstration, layout: Layout, settings: Settings
) -> float:
    """Log-likelihood per sample of the whole ``demo`` at its own speed."""
    obs = Observation.from_demo(model, demo, demo.n_samples, layout.names)
    alpha = settings.s_bar / (demo.duration / model.sample_period + 1.0)
    value = log_likelihoods(model, model.primitives[0], obs, np.array([alpha * (1 - 1e-9)]))[0]
    return float(value) / demo.n_samples


def typicality(
    demo: Demonstration,
    others: Sequence[Demonstration],
    layout: Layout,
    settings: Settings,
) -> Typicality | None:
    """Typicality of ``demo`` against the model learned from ``others`` (its primitive's other
    demonstrations), ranked among the others each scored without itself; None with fewer than
    three others."""
    others = list(others)
    if len(others) < 3:
        return None
    try:
        model = fit({"primitive": others}, layout, settings)
    except ValueError:
        return None
    score = _per_sample_log_likelihood(model, demo, layout, settings)
    references = []
    for i, other in enumerate(others):
        rest = others[:i] + others[i + 1 :]
        held_out = fit({"primitive": rest}, layout, settings)
        references.append(_per_sample_log_likelihood(held_out, other, layout, settings))
    percentile = float(np.mean(np.array(references) < score))
    return Typicality(score, percentile)
