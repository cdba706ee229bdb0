"""Metrics of one inference against the true demonstration.

Definitions (``n`` true samples, ``n_o`` observed, the predicted mean spans the predicted
duration on ``n_f`` evenly spaced phases):

* ``position_error_m``: mean Euclidean distance, over the unobserved true samples
  ``n_o .. n - 1``, between the true hand position and the predicted one at the same phase of
  the remainder: the predicted remainder (fractional sample index ``n_o`` to ``n_f - 1`` of the
  prediction) is resampled linearly onto the ``n - n_o`` true samples. When the prediction ends
  before ``n_o`` the remainder is its final position.
* ``goal_error_m``: distance between the true and the predicted final hand positions.
* ``duration_error_s``: ``|t_f predicted - t_f true|``.
* ``nrmse_prior`` / ``nrmse_posterior``: RMSE of the prior / posterior mean against the truth
  over the whole movement (both resampled onto the true samples by phase), divided per hand
  dimension by the range of the truth in that dimension, averaged over the hand dimensions.
  ``nrmse_posterior - nrmse_prior < 0`` means that conditioning on the observation helped
  (paper Fig. 6c).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from promp.data import Demonstration, Layout

if TYPE_CHECKING:
    from promp.duration import Timing
    from promp.inference import Prediction
    from promp.model import ProMPModel

__all__ = [
    "Errors", "calibration_error", "goal_error", "measure", "nrmse", "position_modality",
    "reliability", "remainder_error", "resample"
]  # fmt: skip


def resample(values: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``values`` (n, d) at fractional row indices ``positions``."""
    index = np.arange(values.shape[0])
    clipped = np.clip(positions, 0, values.shape[0] - 1)
    return np.column_stack(
        [np.interp(clipped, index, values[:, j]) for j in range(values.shape[1])]
    )


def remainder_error(truth: np.ndarray, predicted: np.ndarray, n_observed: int) -> float:
    """``position_error_m`` for one trial (see the module docstring); NaN if nothing remains."""
    n = truth.shape[0]
    n_remaining = n - n_observed
    if n_remaining <= 0:
        return float("nan")
    n_f = predicted.shape[0]
    start = float(n_observed)
    stop = float(n_f - 1)
    if stop <= start:
        positions = np.full(n_remaining, stop)
    elif n_remaining == 1:
        positions = np.array([start])
    else:
        positions = np.linspace(start, stop, n_remaining)
    pred = resample(predicted, positions)
    return float(np.linalg.norm(truth[n_observed:] - pred, axis=1).mean())


def goal_error(truth: np.ndarray, predicted: np.ndarray) -> float:
    return float(np.linalg.norm(truth[-1] - predicted[-1]))


def nrmse(truth: np.ndarray, predicted: np.ndarray) -> float:
    """Range-normalised RMSE over the whole movement, averaged over dimensions.

    A dimension whose truth does not move (a range below 1e-12 of its magnitude: round-off) is
    normalised by its magnitude instead, or not at all when it is zero, so the figure does not
    depend on the unit.
    """
    positions = np.linspace(0.0, predicted.shape[0] - 1, truth.shape[0])
    pred = resample(predicted, positions)
    rmse = np.sqrt(((truth - pred) ** 2).mean(axis=0))
    span = np.ptp(truth, axis=0)
    magnitude = np.abs(truth).max(axis=0)
    fallback = np.where(magnitude > 0, magnitude, 1.0)
    span = np.where(span > 1e-12 * magnitude, span, fallback)
    return float((rmse / span).mean())


def reliability(
    probabilities: np.ndarray, truth: np.ndarray, n_bins: int = 10
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reliability of predicted class probabilities: every (trial, class) pair is one forecast
    ``p`` of the event "the trial is of this class", binned by ``p`` into ``n_bins`` equal bins.

    Parameters
    ----------
    probabilities : array, shape (n_trials, n_classes)
    truth : int array, shape (n_trials,)
        The true class of each trial.

    Returns
    -------
    mean_forecast, frequency, count : arrays, shape (n_bins,)
        Per bin: the mean forecast, the observed frequency of the event (NaN in an empty bin)
        and the number of forecasts. A calibrated forecaster has ``frequency ~ mean_forecast``.
    """
    probabilities = np.asarray(probabilities, dtype=float)
    truth = np.asarray(truth, dtype=int)
    if probabilities.ndim != 2 or truth.shape != (probabilities.shape[0],):
        raise ValueError(
            f"probabilities (n, K) and truth (n,) expected, got {probabilities.shape} and "
            f"{truth.shape}"
        )
    events = np.zeros_like(probabilities)
    events[np.arange(truth.size), truth] = 1.0
    p, e = probabilities.ravel(), events.ravel()
    index = np.minimum((p * n_bins).astype(int), n_bins - 1)
    count = np.bincount(index, minlength=n_bins).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_forecast = np.bincount(index, weights=p, minlength=n_bins) / count
        frequency = np.bincount(index, weights=e, minlength=n_bins) / count
    return mean_forecast, frequency, count.astype(int)


def calibration_error(
    mean_forecast: np.ndarray, frequency: np.ndarray, count: np.ndarray
) -> float:
    """Expected calibration error: the count-weighted mean of ``|frequency - forecast|``."""
    used = count > 0
    if not used.any():
        return float("nan")
    gaps = np.abs(frequency[used] - mean_forecast[used])
    return float((gaps * count[used]).sum() / count[used].sum())


def position_modality(layout: Layout) -> str:
    """The modality the trajectory errors are measured on: ``hand`` (or ``position``) when the
    layout has it, else its first modality (the errors are then in that modality's unit)."""
    for name in ("hand", "position"):
        if name in layout.names:
            return name
    return layout.names[0]


@dataclass(frozen=True)
class Errors:
    """An inference against the whole movement it observed the start of (:func:`measure`).
    Positions in the unit of ``modality`` (metres for the hand)."""

    modality: str
    position: float  # mean error of the predicted remainder (NaN when nothing remains)
    goal: float  # error of the predicted final position
    duration: float  # |predicted duration (posterior median) - true duration|, seconds
    duration_covered: bool  # the true duration lies in the duration's interval


def measure(
    model: ProMPModel,
    natural: Prediction,
    estimate: Timing,
    truth: Demonstration,
    n_observed: int,
) -> Errors:
    """:class:`Errors` of a prediction on its natural samples against ``truth``, the whole
    movement whose first ``n_observed`` samples were observed."""
    name = position_modality(model.layout)
    dims = model.layout.dims([name])
    true_values = model.layout.extract(truth)[:, dims]
    predicted = natural.mean[:, dims]
    return Errors(
        modality=name,
        position=remainder_error(true_values, predicted, n_observed),
        goal=goal_error(true_values, predicted),
        duration=abs(natural.duration - truth.duration),
        duration_covered=estimate.duration.covers(truth.duration),
    )
