"""What the Infer tab shows for one state of its controls and one snapshot of the studio, as
pure computation: no viser, tested without a browser.

The method's work is one :class:`promp.evidence.Evidence` of the early observation (the first
samples of a held-out test demonstration, or of the live stream): it recognises the primitive
and its speed (Eq. 6), conditions the recognised primitive on the observation and on that
primitive's via-points (Eq. 8), predicts the prior and the posterior over the predicted
duration, gives every position's region and future path, and, given the whole movement,
measures the errors the evaluation reports (:meth:`promp.evidence.Evidence.infer`).
:func:`inferred` asks it and :func:`completed` adds what only the studio draws: the observed
and true parts of each position (:func:`app.live.regions.positions`) and the hand's future,
which the 3D view shows and the arm replays.

The model comes first (:func:`choose_model`): for a test demonstration, the model learned
without it (the learner fits it in the background: until then there is nothing to show, and
the view says so) or an imported one (which cannot be refitted without it); for the live
stream, the model inference uses. Then the early observation (the first samples of the
demonstration, or of the live stream's samples) and one inference (:func:`compute`).
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass

import numpy as np

from app.core.learner import Learner
from app.core.snapshot import Snapshot
from app.core.via_state import StudioViaPoint, of_primitive
from app.live.regions import PATH_POINTS, TUBE_POINTS, PositionView, positions
from app.live.stream import StreamSamples
from promp.data import Demonstration
from promp.evidence import Evidence, Inference
from promp.evidence.pipeline import relative_speed
from promp.inference import Gaussian, Observation, Posterior, Prediction
from promp.model import ProMPModel
from promp.timing import n_observed_for
from robots.icub.layout import HAND, hand_dims

TEST, LIVE = "Test demonstration", "Live stream"  # what is observed
LSL = "Live streams (LSL)"  # a lab's sensors (app.live.lsl_source)
__all__ = ["PATH_POINTS", "TUBE_POINTS"]  # where the scene finds them (app.live.regions')


@dataclass(frozen=True, eq=False)
class FuturePath:
    """The posterior mean hand from the observation point to the predicted end.

    Attributes
    ----------
    times : array, shape (PATH_POINTS,)
        Seconds from the start of the movement, from the last observed sample to the end.
    hand : array, shape (PATH_POINTS, 3)
        Hand positions, metres.
    """

    times: np.ndarray
    hand: np.ndarray


@dataclass(frozen=True, eq=False)
class InferResult:
    """Everything the Infer tab shows of one observation.

    Attributes
    ----------
    model : ProMPModel
        The model inferred with (its primitives' names, its layout).
    observation : Observation
    inference : Inference
        The method's answer: recognition, timing (duration and observed share with their
        intervals), prior and posterior on ``TUBE_POINTS`` phases, and, with a truth, the
        natural-length prediction and the errors.
    truth : Demonstration or None
        The whole test demonstration (None for the live stream).
    future : FuturePath or None
        The hand's predicted path (None when the layout has no hand).
    via_points : tuple of StudioViaPoint
        The recognised primitive's via-points the prediction passes through (none: the
        method's posterior as it is).
    weights : Gaussian or Posterior
        The posterior, conditioned on ``via_points``.
    prediction : Prediction
        Every dimension over the predicted duration on ``TUBE_POINTS`` phases, from
        ``weights`` (the method's ``inference.prediction`` without via-points).
    positions : tuple of PositionView
        Every position in space of the layout (the hand first): its region, predicted and
        observed paths.
    """

    model: ProMPModel
    observation: Observation
    inference: Inference
    truth: Demonstration | None
    future: FuturePath | None
    via_points: tuple[StudioViaPoint, ...] = ()
    weights: Gaussian | Posterior | None = None
    prediction: Prediction | None = None
    positions: tuple[PositionView, ...] = ()

    @property
    def relative_speed(self) -> float:
        """The prediction's speed over the primitive's typical one (1: its usual speed)."""
        return relative_speed(self.model, self.inference)


def inferred(
    model: ProMPModel,
    observation: Observation,
    alpha_method: str,
    truth: Demonstration | None = None,
    via_points: tuple[StudioViaPoint, ...] = (),
) -> InferResult:
    """Infer from ``observation`` (:meth:`promp.evidence.Evidence.infer`, predictions on
    ``TUBE_POINTS`` phases), the posterior shaped by the recognised primitive's via-points (of
    ``via_points``, every primitive's), with what the 3D view draws (:func:`completed`).

    Parameters
    ----------
    model : ProMPModel
    observation : Observation
        Its times start at the start of the movement.
    alpha_method : {"ml", "model"}
    truth : Demonstration, optional
        The whole movement the observation was taken from (the errors are measured on it).

    Raises
    ------
    ValueError
        From the engine: an unknown modality, an unknown alpha method, or an observation longer
        than every candidate duration.
    """
    evidence = Evidence(model, observation, alpha_method)
    has_hand = hand_dims(model.layout) is not None
    vias = of_primitive(via_points, evidence.recognition.primitive) if has_hand else ()
    inference = evidence.infer([v.for_model(model.layout) for v in vias], n_points=TUBE_POINTS,
                               truth=truth, path_points=PATH_POINTS)  # fmt: skip
    return completed(model, observation, inference, truth, vias)


def completed(
    model: ProMPModel,
    observation: Observation,
    inference: Inference,
    truth: Demonstration | None = None,
    via_points: tuple[StudioViaPoint, ...] = (),
) -> InferResult:
    """What only the studio draws, added to ``inference`` of ``observation`` (on
    ``TUBE_POINTS`` phases, shaped by ``via_points``): every position's observed and true
    parts, and the future hand path; :func:`inferred`'s, and a live session's
    (:mod:`app.live.lsl_view`)."""
    whole = model.layout.extract(truth) if truth is not None else None
    views = positions(model, inference, observation, whole)
    hand = next((v for v in views if v.modality == HAND.name), None)
    future = FuturePath(hand.times, hand.future) if hand is not None else None
    return InferResult(
        model, observation, inference, truth, future, via_points, inference.weights,
        inference.prediction, views,
    )  # fmt: skip


def demo_observation(
    model: ProMPModel, demo: Demonstration, percent: float, modalities: Sequence[str]
) -> Observation:
    """The first ``ceil(percent / 100 * n)`` samples of ``demo`` in ``modalities``."""
    return Observation.from_demo(
        model, demo, n_observed_for(percent, demo.n_samples), tuple(modalities)
    )


# ---------------------------------------------------------------------- the Infer tab


@dataclass(frozen=True)
class InferState:
    """The Infer tab's choices at one frame: what its controls say (the alpha method by the
    engine's name), the computation's only input from the GUI."""

    source: str
    primitive: str
    demo: str
    observed: str
    alpha_method: str  # the engine's name: "ml" or "model"
    percent: int
    show_3d: bool
    priors: str

    @property
    def live(self) -> bool:
        """Observed as it happens (the dragged hand, or the LSL streams)."""
        return self.source in (LIVE, LSL)

    @property
    def lsl(self) -> bool:
        return self.source == LSL


@dataclass(frozen=True)
class CurveRequest:
    """What a curve is computed from; ``key`` says what it depends on (demonstration, model,
    observed modalities, alpha method)."""

    key: Hashable
    model: ProMPModel
    demo: Demonstration
    modalities: tuple[str, ...]
    alpha_method: str
    truth: str


@dataclass(frozen=True, eq=False)
class ModelChoice:
    """The model an inference uses, or why there is none yet (``message``).

    Attributes
    ----------
    model : ProMPModel or None
    note : str
        Which model, as the status says it.
    origin : hashable
        What the model depends on (the recognition curve's cache key).
    fit_ms : float
        The time its held-out fit took (0 when reused or not fitted for it).
    """

    model: ProMPModel | None
    note: str = ""
    origin: Hashable = None
    fit_ms: float = 0.0
    message: str = ""


@dataclass(frozen=True, eq=False)
class InferView:
    """What the Infer tab shows (see the module docstring).

    Attributes
    ----------
    state : InferState
        The controls it was computed from.
    result : InferResult or None
        The inference (None: ``message`` says why); its ``inference.timing`` holds the
        duration and the observed share with their intervals.
    message : str
    model : ModelChoice
    curve : CurveRequest or None
        The recognition over the whole test demonstration (None for the live stream).
    samples : StreamSamples, LslObserved or None
        The live stream's samples it observed (the LSL source's latest prediction:
        :class:`app.live.lsl_view.LslObserved`).
    """

    state: InferState
    result: InferResult | None
    message: str = ""
    model: ModelChoice = ModelChoice(None)
    curve: CurveRequest | None = None
    samples: StreamSamples | None = None

    @property
    def movement(self) -> tuple:
        """What is inspected: a test demonstration, or the live stream since its last clear
        (the charts' ranges grow while it stays the same)."""
        if self.state.lsl:
            return ("lsl", getattr(self.samples, "movement", None))
        if self.state.live:
            return ("live", self.samples.epoch if self.samples is not None else -1)
        return ("test", self.state.primitive, self.state.demo)


def choose_model(state: InferState, snapshot: Snapshot, learner: Learner) -> ModelChoice:
    """The model for ``state`` (a held-out one is asked of ``learner`` when it is not known
    yet: the one side effect, made before the pure computation)."""
    imported = snapshot.imported
    if state.live:
        model = snapshot.inference_model
        if model is None:
            error = snapshot.learner.error or "teach some primitives"
            return ModelChoice(None, message=f"no model yet: {error}")
        if imported is not None:
            return ModelChoice(model, f"imported ({imported.source})", ("imported", id(model)))
        return ModelChoice(model, "the session's, all demonstrations", ("learned", id(model)))
    demos = snapshot.store.demos.get(state.primitive, ())
    if not any(d.name == state.demo for d in demos):
        return ModelChoice(None, message="choose a test demonstration (the session has none yet)")
    if imported is not None:  # inferred as is: an imported model cannot be refitted without it
        model = imported.model
        return ModelChoice(model, "imported, so NOT held out", ("imported", id(model)))
    try:
        fitted = learner.held_out(snapshot.store, state.primitive, state.demo)
    except ValueError as exc:
        return ModelChoice(None, message=str(exc))
    if fitted is None:
        return ModelChoice(None, message=f"learning a model without {state.demo} (held out)...")
    if fitted.model is None:
        return ModelChoice(None, message=fitted.error or "no model")
    # the settings the learner resolved once for this version (held_out waited for them)
    origin = ("held out", snapshot.store.learn_version, repr(snapshot.learner.settings))
    return ModelChoice(
        fitted.model, f"learned without {state.demo} (held out)", origin,
        0.0 if fitted.reused else fitted.ms,
    )  # fmt: skip


def compute(
    state: InferState,
    snapshot: Snapshot,
    modalities: tuple[str, ...] | None,
    choice: ModelChoice,
    samples: StreamSamples | None = None,
) -> InferView:
    """The view of ``state`` (observing ``modalities``; None: not a choice of this layout)
    with the model ``choice``, on ``snapshot`` (a test demonstration) or the live stream's
    ``samples``."""
    model, vias = choice.model, snapshot.view.via_points
    if modalities is None:
        return InferView(state, None, "choose the observed modalities", choice, samples=samples)
    if model is None:
        return InferView(state, None, choice.message, choice, samples=samples)
    try:
        if state.live:
            if samples is None:
                raise ValueError("nothing observed yet: press Start observing and move the hand")
            observation = samples.observation(state.percent, modalities, model.layout)
            result = inferred(model, observation, state.alpha_method, via_points=vias)
            return InferView(state, result, "", choice, samples=samples)
        demo = next(d for d in snapshot.store.demos[state.primitive] if d.name == state.demo)
        curve = CurveRequest(
            key=(choice.origin, state.primitive, state.demo, modalities, state.alpha_method),
            model=model, demo=demo, modalities=modalities, alpha_method=state.alpha_method,
            truth=state.primitive,
        )  # fmt: skip
        observation = demo_observation(model, demo, state.percent, modalities)
        result = inferred(model, observation, state.alpha_method, truth=demo, via_points=vias)
        return InferView(state, result, "", choice, curve)
    except ValueError as exc:
        return InferView(state, None, str(exc), choice, samples=samples)
