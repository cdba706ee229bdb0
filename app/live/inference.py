"""One scrub step of the Infer tab as pure computation: no viser, testable without a browser.

Given a model and an early observation (the first samples of a held-out test demonstration, or
of the live stream), a scrub step recognises the primitive and its time modulation alpha
(Eq. 6, ML over the training alphas or the Eq. 7 model), conditions the recognised primitive on
the observation (Eq. 8) and predicts the prior and posterior trajectory distributions (mean and
standard deviation of every dimension over the predicted duration). With the true
demonstration, it also measures the errors the evaluation reports (:mod:`promp.metrics`):
position error of the remainder, goal error and duration error.

A test demonstration is held out from the model while it is inspected: :class:`HeldOutModels`
fits (and caches) the model on the session's demonstrations minus that one.
:func:`typical_prior` is what the Teach tab plots and the scene's tubes show: a primitive's prior
at its typical speed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from app.core.lru import LruCache
from promp.data import Demonstration, Layout, Modality
from promp.duration import Timing
from promp.inference import Observation, Prediction, predict
from promp.learn import fit
from promp.metrics import position_modality
from promp.model import ProMPModel, Settings
from promp.pipeline import infer
from promp.recognition import Recognition
from promp.timing import n_observed_for
from robots.icub.layout import hand_dims

TUBE_POINTS = 100  # rings of the posterior tube (fixed mesh topology)
PATH_POINTS = 60  # samples of the predicted future hand path


def held_out_training(
    demos: Mapping[str, Sequence[Demonstration]], primitive: str, demo_name: str
) -> dict[str, list[Demonstration]]:
    """The training set of the model that must not see ``demo_name`` of ``primitive``: every
    primitive with at least two demonstrations once the test one is removed.

    Raises
    ------
    ValueError
        Unknown primitive or demonstration, or fewer than two demonstrations of ``primitive``
        left (its model could not be learned, so it could not be recognised).
    """
    if primitive not in demos:
        raise ValueError(f"unknown primitive {primitive!r}")
    if demo_name not in {d.name for d in demos[primitive]}:
        raise ValueError(f"primitive {primitive!r} has no demonstration {demo_name!r}")
    train = {
        name: [d for d in items if not (name == primitive and d.name == demo_name)]
        for name, items in demos.items()
    }
    if len(train[primitive]) < 2:
        raise ValueError(
            f"holding out {demo_name!r} leaves {primitive!r} with {len(train[primitive])} "
            "demonstration(s); record at least three to test one"
        )
    return {name: items for name, items in train.items() if len(items) >= 2}


class HeldOutModels:
    """Models learned without one test demonstration, cached by (version of what is learned
    from, primitive, demonstration, settings): scrubbing never refits; a change of the
    demonstrations or the settings does (:attr:`app.core.session.Session.learn_version`)."""

    def __init__(self, max_entries: int = 8):
        self._cache: LruCache[ProMPModel] = LruCache(max_entries)

    def has(self, version: int, primitive: str, demo_name: str, settings: Settings) -> bool:
        return (version, primitive, demo_name, repr(settings)) in self._cache

    def get(
        self,
        version: int,
        demos: Mapping[str, Sequence[Demonstration]],
        primitive: str,
        demo_name: str,
        settings: Settings,
        layout: Layout,
    ) -> ProMPModel:
        """The model fitted on ``demos`` minus ``demo_name`` (see :func:`held_out_training`)."""
        key = (version, primitive, demo_name, repr(settings))
        model = self._cache.get(key)
        if model is None:
            model = fit(held_out_training(demos, primitive, demo_name), layout, settings)
            self._cache.put(key, model)
        return model

    def __len__(self) -> int:
        return len(self._cache)


@dataclass(frozen=True, eq=False)
class ScrubResult:
    """Everything the Infer tab shows for one observation.

    Attributes
    ----------
    names : tuple of str
        The model's primitives, in the order of ``recognition.probabilities``.
    layout : Layout
        The model's modalities (what ``prior`` and ``posterior`` have columns for).
    observation : Observation
    recognition : Recognition
    timing : Timing
        The duration and the observed share of the movement, with their intervals
        (:mod:`promp.duration`).
    prior, posterior : Prediction
        The recognised primitive's prior and posterior at the speed of the predicted duration, on
        ``TUBE_POINTS`` evenly spaced phases of the predicted duration.
    observed_until : float
        Seconds from the start of the movement to the last observed sample.
    future_times : array, shape (PATH_POINTS,)
        Seconds from the start, from ``observed_until`` to the predicted end.
    future_hand : array, shape (PATH_POINTS, 3), or None
        Posterior mean hand position at ``future_times`` (None when the layout has no hand).
    truth : Demonstration or None
        The whole test demonstration (None for the live stream).
    position_error_m, goal_error_m, duration_error_s : float
        Against the truth (NaN without one; the position error is NaN when nothing remains).
        The first two are in the unit of :func:`error_modality` (metres for the hand).
    typical_alpha : float
        The recognised primitive's typical alpha (exp of its training demonstrations' mean
        log-alpha): ``alpha / typical_alpha`` is the speed relative to its usual one.
    """

    names: tuple[str, ...]
    layout: Layout
    observation: Observation
    recognition: Recognition
    timing: Timing
    prior: Prediction
    posterior: Prediction
    observed_until: float
    future_times: np.ndarray
    future_hand: np.ndarray | None
    truth: Demonstration | None
    position_error_m: float
    goal_error_m: float
    duration_error_s: float
    typical_alpha: float = math.nan

    @property
    def primitive(self) -> str:
        return self.recognition.primitive

    @property
    def alpha(self) -> float:
        """The speed the predictions are drawn at (the predicted duration's)."""
        return self.timing.alpha

    @property
    def probabilities(self) -> np.ndarray:
        return self.recognition.probabilities

    @property
    def duration(self) -> float:
        """Predicted duration of the whole movement, seconds."""
        return self.posterior.duration

    @property
    def true_duration(self) -> float:
        return self.truth.duration if self.truth is not None else math.nan

    @property
    def relative_speed(self) -> float:
        """The recognised alpha over the primitive's typical one: 1 is its usual speed, more
        is faster."""
        return self.alpha / self.typical_alpha

    @property
    def remaining(self) -> float:
        """Predicted time left after the observation, seconds."""
        return max(0.0, self.duration - self.observed_until)


def error_modality(layout: Layout) -> Modality:
    """The modality the errors are measured on, the evaluation's
    (:func:`promp.metrics.position_modality`): the hand when there is one."""
    return layout.modality(position_modality(layout))


def scrub_step(
    model: ProMPModel,
    observation: Observation,
    alpha_method: str,
    truth: Demonstration | None = None,
) -> ScrubResult:
    """Recognise, condition on the recognised primitive, predict, and measure the errors.

    Parameters
    ----------
    model : ProMPModel
    observation : Observation
        Its times start at the start of the movement.
    alpha_method : {"ml", "model"}
    truth : Demonstration, optional
        The whole movement the observation was taken from (errors are NaN without it).

    Raises
    ------
    ValueError
        From the engine: an unknown modality, an unknown alpha method, or an observation longer
        than every candidate duration.
    """
    result = infer(model, observation, alpha_method, n_points=TUBE_POINTS, truth=truth)
    posterior, post_pred = result.posterior, result.prediction
    duration = post_pred.duration
    observed_until = result.observed_until
    z_start = min(observed_until / duration, 1.0) if duration > 0 else 1.0
    phases = np.linspace(z_start, 1.0, PATH_POINTS)
    hand = hand_dims(model.layout)
    future_hand = None
    if hand is not None:
        weights = posterior.mean.reshape(model.n_dims, -1)[hand]  # (3, M)
        future_hand = model.basis(phases) @ weights.T
    errors = result.errors
    return ScrubResult(
        names=model.names,
        layout=model.layout,
        observation=observation,
        recognition=result.recognition,
        timing=result.timing,
        prior=result.prior,
        posterior=post_pred,
        observed_until=observed_until,
        future_times=phases * duration,
        future_hand=future_hand,
        truth=truth,
        position_error_m=math.nan if errors is None else errors.position,
        goal_error_m=math.nan if errors is None else errors.goal,
        duration_error_s=math.nan if errors is None else errors.duration,
        typical_alpha=float(np.exp(model.primitives[result.index].log_alpha_mean)),
    )


def demo_observation(
    model: ProMPModel, demo: Demonstration, percent: float, modalities: Sequence[str]
) -> Observation:
    """The first ``ceil(percent / 100 * n)`` samples of ``demo`` in ``modalities``."""
    return Observation.from_demo(
        model, demo, n_observed_for(percent, demo.n_samples), tuple(modalities)
    )


def typical_prior(model: ProMPModel, name: str, n_points: int) -> Prediction:
    """The prior of primitive ``name`` at its typical speed (alpha = exp of the mean training
    log-alpha), on ``n_points`` phases."""
    primitive = model.primitive(name)
    return predict(model, primitive, float(np.exp(primitive.log_alpha_mean)), n_points)
