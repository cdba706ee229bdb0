"""The whole inference, once: recognise, condition, predict.

The studio's scrub step and live stream, the evaluation and the robot-side example all call
:func:`infer` (the studio's outlier flag is :func:`promp.typicality.typicality`). A change of
method lands here (or below) and nowhere else.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from promp._threads import one_blas_thread
from promp.inference import Observation, Posterior, Prediction, condition, predict
from promp.model import ProMPModel
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


@one_blas_thread
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
