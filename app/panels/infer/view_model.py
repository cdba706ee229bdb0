"""The Infer tab's view model: what its controls say (:class:`InferState`), the model an
inference uses (:func:`choose_model`) and what the tab shows (:class:`InferView`, computed by
:func:`compute`, pure: no viser, tested without a browser).

The model comes first (:func:`choose_model`): for a test demonstration, the model learned
without it (the learner fits it in the background: until then there is nothing to show, and
the view says so) or an imported one (which cannot be refitted without it); for the live
stream, the model inference uses. Then the early observation (the first samples of the
demonstration, :meth:`promp.inference.Observation.first`, or of the live stream's samples)
and one inference (:func:`app.live.inference.inferred`: a :class:`promp.evidence.Inference`,
as it is drawn, shaped by the snapshot's via-points).
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass

from app.core.groups import group_members
from app.core.learner import Learner
from app.core.snapshot import Snapshot
from app.live.inference import LIVE, LSL, InferResult, inferred
from app.live.recognition_curve import CurveRequest
from app.live.stream import StreamSamples
from promp.inference import Observation
from promp.model import ProMPModel

LIVE_SHOW_S = 0.1  # the LSL source's predictions drawn at most ten times a second


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
    hold_out: str | None = None  # the test demonstration's group held out too, by this rule

    @property
    def live(self) -> bool:
        """Observed as it happens (the dragged hand, or the LSL streams)."""
        return self.source in (LIVE, LSL)

    @property
    def lsl(self) -> bool:
        return self.source == LSL


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
        :class:`app.panels.infer.lsl_view.LslObserved`).
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


@dataclass(frozen=True, eq=False)
class ViewInputs:
    """What a view of the Infer tab is computed from, compared field by field by
    :meth:`same`: the controls and the model's message by value, the immutable rest (the
    workspace's demonstrations and primitives, the model, the live samples, the via-points)
    by identity.
    """

    state: InferState
    message: str
    demos: object
    primitives: object
    model: object
    samples: object
    via_points: tuple

    def same(self, old: ViewInputs | None) -> bool:
        """The view of ``old`` is the view of these inputs."""
        return self._same_but_samples(old) and self.samples is old.samples

    def _same_but_samples(self, old: ViewInputs | None) -> bool:
        return old is not None and (self.state, self.message) == (old.state, old.message) and (
            self.demos is old.demos and self.primitives is old.primitives
            and self.model is old.model and self.via_points is old.via_points
        )  # fmt: skip

    def newer_prediction(self, old: ViewInputs | None) -> bool:
        """Only the LSL source's prediction changed since ``old``: a newer one of the same
        movement, committed as the older was (or not), from the same model."""
        if not self._same_but_samples(old):
            return False
        new, shown = self.samples, old.samples
        if not self.state.lsl or new is None or shown is None:
            return False
        p, q = getattr(new, "prediction", None), getattr(shown, "prediction", None)
        return (p is not None and q is not None and new.movement == shown.movement
                and new.model is shown.model and (p.committed is None) == (q.committed is None)
                and (new.note, new.message) == (shown.note, shown.message))  # fmt: skip

    def waits(self, old: ViewInputs | None, elsewhere: bool, view: InferView | None) -> bool:
        """The new view may wait for the tab to be in use (``elsewhere``: another tab is):
        only the workspace, the model or the via-points changed (not the controls, not the
        live samples) and the view shown has a result; or the LSL source's new predictions,
        each of which would redraw the charts."""
        if not elsewhere or old is None or view is None or self.state != old.state:
            return False
        return self.state.lsl or (self.samples is old.samples and view.result is not None)


@dataclass(frozen=True)
class Drawn:
    """The inputs of the view the tab shows, and when it was computed (the frame's clock)."""

    inputs: ViewInputs | None = None
    at: float = -math.inf

    def redraw(self, inputs: ViewInputs, now: float, elsewhere: bool,
               view: InferView | None) -> bool:  # fmt: skip
        """Whether the view of ``inputs`` is to be computed at ``now``: they changed, the tab
        need not wait (:meth:`ViewInputs.waits`), and they are not only a newer prediction of
        the LSL source less than :data:`LIVE_SHOW_S` after the view shown."""
        old = self.inputs
        return not inputs.same(old) and not inputs.waits(old, elsewhere, view) and not (
            inputs.newer_prediction(old) and now - self.at < LIVE_SHOW_S
        )  # fmt: skip


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
        fitted = learner.held_out(snapshot.store, state.primitive, state.demo, state.hold_out)
        without = f"{state.demo} (held out)"
        if state.hold_out is not None:
            group, members = group_members(snapshot.store, state.primitive, state.demo,
                                           state.hold_out)  # fmt: skip
            without = f"{state.demo}'s group {group} ({len(members)} demonstrations held out)"
    except ValueError as exc:
        return ModelChoice(None, message=str(exc))
    if fitted is None:
        return ModelChoice(None, message=f"learning a model without {without}...")
    if fitted.model is None:
        return ModelChoice(None, message=fitted.error or "no model")
    # the settings the learner resolved once for this version (held_out waited for them)
    origin = ("held out", snapshot.store.learn_version, repr(snapshot.learner.settings),
              state.hold_out)  # fmt: skip
    return ModelChoice(
        fitted.model, f"learned without {without}", origin, 0.0 if fitted.reused else fitted.ms,
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
    ``samples``: the observation taken, then one inference."""
    model = choice.model
    if modalities is None:
        return InferView(state, None, "choose the observed modalities", choice, samples=samples)
    if model is None:
        return InferView(state, None, choice.message, choice, samples=samples)
    try:
        truth, curve = None, None
        if state.live:
            if samples is None:
                raise ValueError("nothing observed yet: press Start observing and move the hand")
            observation = samples.observation(state.percent, modalities, model.layout)
        else:
            truth = next(d for d in snapshot.store.demos[state.primitive] if d.name == state.demo)
            curve = CurveRequest(
                key=(choice.origin, state.primitive, state.demo, modalities, state.alpha_method),
                model=model, demo=truth, modalities=modalities, alpha_method=state.alpha_method,
                truth=state.primitive,
            )  # fmt: skip
            observation = Observation.first(model, truth, state.percent, modalities)
        result = inferred(model, observation, state.alpha_method, truth, snapshot.via_points)
        return InferView(state, result, "", choice, curve, samples=samples)
    except ValueError as exc:
        return InferView(state, None, str(exc), choice, samples=samples)
