"""What an evidence says about the rest of the movement (:meth:`promp.evidence.Evidence.infer`):
the :class:`Inference`, and the :class:`Position` of every position modality it holds.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from promp.duration import Timing
from promp.inference import Gaussian, Posterior, Prediction
from promp.metrics import Errors
from promp.model import ProMPModel
from promp.observation import Observation
from promp.recognition import Recognition
from promp.region import SampleDistribution, mean_position, sample_distribution, sample_noise_var
from promp.via_points import ViaPoint

__all__ = ["Inference", "PATH_POINTS", "Position"]

PATH_POINTS = 60  # samples of a position's future path


@dataclass(frozen=True, eq=False)
class Position:
    """A position modality of an inference, as a 3D view draws it.

    Attributes
    ----------
    modality : str
    region : SampleDistribution
        Where the movement's samples are, on the prediction's phases over the predicted
        duration: means (n, k), covariances (n, k, k), in the modality's unit
        (:func:`promp.region.sample_distribution`, with the samples' noise).
    times : array, shape (path_points,)
        Seconds from the start of the movement, from the last observed sample to the end.
    future : array, shape (path_points, k)
        The predicted mean at ``times``.
    """

    modality: str
    region: SampleDistribution
    times: np.ndarray
    future: np.ndarray


@dataclass(frozen=True, eq=False)
class Inference:
    """What an early observation says about the rest of the movement
    (:meth:`promp.evidence.Evidence.infer`).

    Attributes
    ----------
    model : ProMPModel
    observation : Observation
    recognition : Recognition
        Which primitive, the probability of each primitive, the speed's posterior.
    timing : Timing
        The recognised primitive's duration and the observed share of it (posterior medians
        and intervals), and the speed the predictions are drawn at.
    posterior : Posterior
        The recognised primitive's weights conditioned on the observation (Eq. 8).
    weights : Gaussian or Posterior
        ``posterior`` conditioned on ``via_points`` as well (``posterior`` itself without).
    prior, prediction : Prediction
        The recognised primitive's prior, and ``weights``' trajectories, at ``timing.alpha``
        over the predicted duration.
    via_points : tuple of ViaPoint
        The points the prediction was made to pass through.
    natural : Prediction or None
        ``posterior``'s trajectories on the predicted number of samples (what the errors are
        measured on: the method's own prediction, without via-points); given with a truth.
    errors : Errors or None
        Against the truth, when given.
    """

    model: ProMPModel
    observation: Observation
    recognition: Recognition
    timing: Timing
    posterior: Posterior
    weights: Gaussian | Posterior
    prior: Prediction
    prediction: Prediction
    via_points: tuple[ViaPoint, ...] = ()
    natural: Prediction | None = None
    errors: Errors | None = None
    path_points: int = PATH_POINTS

    @property
    def index(self) -> int:
        return self.recognition.index

    @property
    def primitive(self) -> str:
        return self.recognition.primitive

    @property
    def alpha(self) -> float:
        """The speed of the predictions (the posterior-median duration's)."""
        return self.timing.alpha

    @property
    def probabilities(self) -> np.ndarray:
        return self.recognition.probabilities

    @property
    def observed_until(self) -> float:
        """The observation's last sample, seconds from its first."""
        return float(self.observation.elapsed[-1])

    @property
    def duration(self) -> float:
        """The predicted duration of the whole movement, seconds."""
        return self.prediction.duration

    @property
    def remaining(self) -> float:
        """Predicted seconds left after the observation."""
        return max(0.0, self.duration - self.observed_until)

    @property
    def observed_phase(self) -> float:
        """The share of the predicted duration observed, in [0, 1] (where futures start)."""
        duration = self.duration
        return min(self.observed_until / duration, 1.0) if duration > 0 else 1.0

    def mean_at(self, modality: str, phase: float) -> np.ndarray:
        """The predicted mean of ``modality`` at ``phase`` (in [0, 1]), shape (k,)."""
        return mean_position(self.model, self.weights, modality, phase)

    @functools.cached_property
    def positions(self) -> tuple[Position, ...]:
        """Every position modality of the layout (:attr:`promp.data.Modality.is_position`, in
        the layout's order): its region and future path under ``weights`` (computed on first
        use: the region needs the posterior's full covariance)."""
        model, weights = self.model, self.weights
        noise = sample_noise_var(model, model.primitives[self.index])
        phases = np.linspace(0.0, 1.0, self.prediction.times.shape[0])
        path = np.linspace(self.observed_phase, 1.0, self.path_points)
        future, times = model.basis(path), path * self.duration
        mean = np.asarray(weights.mean).reshape(model.n_dims, -1)
        out = []
        for modality in model.layout.positions:
            dims = model.layout.dims([modality.name])
            region = sample_distribution(model, weights, dims, phases, noise)
            out.append(Position(modality.name, region, times, future @ mean[dims].T))
        return tuple(out)

    @functools.cached_property
    def via_errors(self) -> np.ndarray:
        """How far the prediction passes from each via-point, shape (n_via_points,): the
        distance between its mean at the point's phase and the point, in its columns' unit."""
        model, columns = self.model, self.model.layout.columns
        mean = np.asarray(self.weights.mean).reshape(model.n_dims, -1)
        out = np.empty(len(self.via_points))
        for i, point in enumerate(self.via_points):
            phi = model.basis(np.array([point.phase_at(model, self.alpha)]))[0]
            at = mean[[columns.index(c) for c in point.columns]] @ phi
            out[i] = float(np.linalg.norm(at - point.values))
        return out
