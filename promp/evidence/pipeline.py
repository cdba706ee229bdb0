"""The method as functions: infer, recognise, condition and score an observation, each one
question asked of its :class:`promp.evidence.Evidence`.

The studio's scrub step and live stream, the evaluation and the robot-side example all call
:func:`infer` (the studio's outlier flag is :func:`promp.typicality.typicality`); a stream that
grows keeps its evidence and extends it (:meth:`promp.evidence.Evidence.extended`,
:mod:`promp.live.predictor`). A change of method lands in :mod:`promp.evidence` (or below) and
nowhere else.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from promp.data import Demonstration
from promp.evidence.evidence import Evidence
from promp.evidence.inference import Inference
from promp.evidence.speed import AlphaMethod
from promp.inference import Gaussian, Posterior, condition_dense, observed_duration
from promp.model import Primitive, ProMPModel
from promp.observation import Observation, check_observation
from promp.recognition import Recognition
from promp.via_points import ViaPoint

__all__ = ["condition", "infer", "log_likelihoods", "recognise", "relative_speed"]


def infer(
    model: ProMPModel,
    obs: Observation,
    alpha_method: AlphaMethod = "ml",
    n_points: int | None = None,
    truth: Demonstration | None = None,
    duration: float | None = None,
    via_points: Sequence[ViaPoint] = (),
) -> Inference:
    """Recognise the primitive and its speed, condition on the observation (and on
    ``via_points``), predict; with ``truth`` (the whole movement ``obs`` is the start of),
    measure the errors (:meth:`promp.evidence.Evidence.infer`).

    The primitive whose evidence (Eq. 6 integrated over its speed prior) is highest is
    recognised; the prediction is drawn at the speed of its posterior-median duration
    (:mod:`promp.duration`), the weights conditioned on the observation there (Eq. 8) and on
    the via-points, and every dimension predicted over the whole movement.

    Parameters
    ----------
    model, obs, alpha_method, duration
        The model, the first samples of the movement in any of its modalities, the speed's
        prior (``"ml"`` or ``"model"``) and the movement's duration when it is known (s):
        :class:`promp.evidence.Evidence`'s.
    n_points, truth, via_points
        The predictions' samples (default: the predicted number), the whole movement (the
        errors are measured against it), points the prediction must pass through
        (:mod:`promp.via_points`): :meth:`promp.evidence.Evidence.infer`'s.

    Returns
    -------
    Inference
        ``primitive``, ``probabilities`` (n_primitives,), ``timing`` (the duration and the
        observed share, with intervals), ``posterior`` (weights), ``prior`` and
        ``prediction`` (trajectories: ``mean``, ``std`` of shape (n_points, n_dims)),
        ``positions`` (every position's region and future path), ``errors`` with ``truth``.

    Raises
    ------
    ValueError
        An unknown modality or alpha method, an empty or non-finite observation, a truth
        without the model's columns, a via-point the model cannot place.
    """
    evidence = Evidence(model, obs, alpha_method, duration)
    return evidence.infer(via_points, n_points=n_points, truth=truth)


def recognise(
    model: ProMPModel,
    obs: Observation,
    alpha_method: AlphaMethod = "ml",
    duration: float | None = None,
) -> Recognition:
    """Recognise the primitive and its time modulation from an early observation: every
    primitive's evidence, its likelihood of Eq. 6 integrated over its speed prior, and the
    class posterior with the "none of these" hypothesis
    (:attr:`promp.evidence.Evidence.recognition`).

    Parameters
    ----------
    model : ProMPModel
    obs : Observation
    alpha_method : {"ml", "model"}
        The speed's prior: the primitive's training speeds, or half of it on the Eq. 7
        regression from the early displacement.
    duration : float, optional
        When the whole movement's duration is known (s; the evaluation's oracle row): every
        primitive is scored at the speed of that duration alone.

    Returns
    -------
    Recognition
        ``index``/``primitive`` recognised, ``probabilities`` (n_primitives,), ``alpha`` (its
        posterior mode), and per primitive the nodes, log-likelihoods and log prior of the
        quadrature.

    Raises
    ------
    ValueError
        Unknown modality or alpha method, an empty or non-finite observation, a duration
        shorter than the observation, an observation no primitive explains.
    """
    return Evidence(model, obs, alpha_method, duration).recognition


def condition(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    alpha: float,
    prior: Gaussian | None = None,
) -> Posterior:
    """Posterior weight distribution given the observation (Eq. 8).

    ``mu' = mu + Sigma A^T (A Sigma A^T + R)^-1 (y_o - A mu)`` and ``Sigma' = Sigma -
    Sigma A^T (A Sigma A^T + R)^-1 A Sigma``, with ``A`` the basis at the observed phases
    for ``alpha`` (block-diagonal over the observed dimensions) and ``R`` the
    Ornstein-Uhlenbeck observation noise. Without ``prior``, the primitive's prior at
    ``alpha``, by the evidence's structured update (:meth:`promp.evidence.Evidence.condition`:
    the mean and each dimension's block in O(D M^2 r), the full covariance on first use);
    with an explicit ``prior`` (any Gaussian), the dense update
    (:func:`promp.inference.condition_dense`). Returns a new object; nothing is modified.

    Parameters
    ----------
    model : ProMPModel
    primitive : Primitive
        One of ``model.primitives`` (its prior at ``alpha`` unless ``prior`` is given).
    obs : Observation
    alpha : float
        The time modulation (> 0); the observation must fit in its duration.
    prior : Gaussian, optional
        Any prior over the weights: mean (n_weights,), cov (n_weights, n_weights).

    Returns
    -------
    Posterior
        ``mean`` (n_weights,), ``blocks(n_dims)`` (n_dims, n_basis, n_basis), ``cov``
        (n_weights, n_weights).

    Raises
    ------
    ValueError
        Unknown modalities, alpha <= 0, or an observation longer than alpha's duration.
    """
    if prior is None:
        return Evidence(model, obs).condition(primitive, alpha)
    check_observation(model, obs)
    observed_duration(model, obs, alpha)  # validates alpha against the observation
    mean, cov = condition_dense(model, primitive, obs, alpha, prior, None)
    return Posterior(mean, Gaussian(mean, cov).blocks(model.n_dims), lambda: cov)


def log_likelihoods(
    model: ProMPModel, primitive: Primitive, obs: Observation, alphas: np.ndarray
) -> np.ndarray:
    """Log marginal likelihood of ``obs`` under ``primitive`` for each of ``alphas`` (A,)
    (Eq. 6): shape (A,), ``-inf`` where the candidate's duration is shorter than the
    observation (:meth:`promp.evidence.Evidence.log_likelihoods`)."""
    return Evidence(model, obs).log_likelihoods(primitive, alphas)


def relative_speed(model: ProMPModel, inference: Inference) -> float:
    """The prediction's speed over the recognised primitive's typical one (exp of its training
    demonstrations' mean log alpha): 1 is its usual speed, more is faster."""
    typical = math.exp(model.primitives[inference.index].log_alpha_mean)
    return inference.alpha / typical
