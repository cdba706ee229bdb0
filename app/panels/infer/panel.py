"""The Infer tab: from the early part of a movement, recognise the primitive and predict the rest.

The user picks what is observed (a test demonstration, held out from the model while inspected,
or the live stream of the partner's head and the dragged hand), which modalities and which
alpha method, and scrubs the observed percentage. Everything follows the slider: the posterior
tube, the predicted future path and its end point (drawn by the scene), the probability of each
primitive, the predicted and true durations, the errors (:mod:`app.panels.infer.readout`), and
the per-dimension charts. "Play" then lets the robot finish the
movement (:mod:`app.panels.infer.replay_section`), and, live, the robot takes over a committed
movement (:mod:`app.panels.infer.takeover_section`); "Export view to" Rerun or MCAP downloads
what the tab shows (:mod:`app.panels.infer.viewer_export`).

The panel is a view: at every frame :meth:`InferPanel.step` reads its controls into an
:class:`~app.panels.infer.view_model.InferState`, and when that state, the workspace, the model
or the live samples changed since the view it shows, computes the new one
(:func:`app.panels.infer.view_model.compute`, pure), writes it to its controls and measures that
server-side time (shown in the tab). It hands the inference to the scene's Infer layer
(:class:`app.scene.inference_layer.InferenceLayer`, which says what it draws) itself, and
returns only its display options (:class:`app.scene.look.InferenceShown`) and via-points for
the scene's look. Button callbacks only record the press.

The Data tab's "Open in Infer" comes through the studio as :meth:`InferPanel.open`: a test
demonstration at one percentage, modalities and alpha method (an evaluation's failed trial).

Studio's hand + head (live): "Start observing" starts :class:`app.live.stream.LiveStream`,
which samples the hand and the head at every frame (~60 Hz); the observation is the first p %
of its samples (100 %: all of it, as it happens), taken at most 20 times a second while
observing.

The LSL source's predictions (30 to 100 a second) are drawn at most every
:data:`~app.panels.infer.view_model.LIVE_SHOW_S` (:class:`~app.panels.infer.view_model.Drawn`):
a newer prediction of the movement drawn waits until then, and the latest is always drawn at
the first frame past it; a new movement, a commitment or anything else that changed is drawn
at once. Drawing each one took most of the loop's time and held the interpreter's lock from
the session's threads (the prediction and the robot's take-over waited on it).
"""

from __future__ import annotations

import collections
import statistics
import time
from dataclasses import dataclass, field

from app.core.groups import rule_of
from app.core.snapshot import Snapshot
from app.live.stream import LiveStream, StreamSamples
from app.panels.infer.controls import (
    HOLD_PREFIX,
    InferControls,
    build_display,
    build_observation,
)
from app.panels.infer.live_section import LiveSection
from app.panels.infer.lsl_view import lsl_view
from app.panels.infer.readout import (
    LEGEND_HTML,
    InferCharts,
    failure_html,
    probabilities_html,
    status_html,
)
from app.panels.infer.recognition import LIVE_NOTE, TITLE, X_RANGE, RecognitionChart
from app.panels.infer.replay_section import ReplaySection
from app.panels.infer.shaping import InferShaping
from app.panels.infer.takeover_section import TakeOverSection
from app.panels.infer.view_model import (
    Drawn,
    InferState,
    InferView,
    ModelChoice,
    ViewInputs,
    choose_model,
    compute,
)
from app.panels.infer.viewer_export import InferExport
from app.scene.inference_layer import DEFAULT_COLOR
from app.scene.look import INFER, InferenceShown, Shown
from app.ui.context import Frame, InferRequest, PanelContext
from app.ui.display import INFER_ALPHAS, observed_choices
from app.ui.element_id import element_id
from app.ui.page_script import ChartSlider


@dataclass
class StepTimes:
    """The server-side time of the latest views (compute and write), in ms."""

    count: int = 0
    last_ms: float = 0.0
    recent: collections.deque = field(default_factory=lambda: collections.deque(maxlen=30))

    def add(self, ms: float) -> None:
        self.count, self.last_ms = self.count + 1, ms
        self.recent.append(ms)

    def text(self, fit_ms: float) -> str:
        """The latest step's time (and a held-out fit it waited for)."""
        text = (
            f"step {self.last_ms:.1f} ms (server; median of the last {len(self.recent)}: "
            f"{statistics.median(self.recent):.1f} ms)"
        )
        return text + (f" · held-out fit {fit_ms:.0f} ms" if fit_ms > 0 else "")


def read_state(c: InferControls) -> InferState:
    """What the controls say now."""
    return InferState(
        source=c.source.value, primitive=c.primitive.value, demo=c.demo.value,
        observed=c.observed.value, alpha_method=INFER_ALPHAS[c.alpha.value],
        percent=int(c.percent.value), show_3d=bool(c.show_3d.value),
        priors=c.session_mode.value, hold_out=rule_of(c.hold_out.value, HOLD_PREFIX),
    )  # fmt: skip


class InferPanel:
    """The Infer tab (see the module docstring). Built inside its tab's container."""

    def __init__(self, ctx: PanelContext) -> None:
        self.ctx = ctx
        self.live = LiveStream()
        self.view: InferView | None = None
        self.steps = StepTimes()
        self._drawn = Drawn()  # what the shown view was computed from, and when
        self._snapshot: Snapshot | None = None  # of the frame being shown (colours)
        self._shown = InferenceShown(None, DEFAULT_COLOR)
        self._pressed: list[str] = []  # live and replay buttons, until the next frame
        layout = ctx.store.state.layout
        gui = ctx.gui
        handles = build_observation(gui, tuple(observed_choices(layout)))
        self.lsl = LiveSection(ctx, layout)
        handles["probabilities"] = gui.add_html("")
        self.recognition = RecognitionChart(ctx, self._color)
        handles["status"] = gui.add_html("")
        handles["replay_buttons"] = gui.add_button_group("Replay", ("Play", "Pause", "Reset"))
        handles["replay_bar"] = gui.add_progress_bar(0.0, color="gray")
        gui.add_html(LEGEND_HTML)
        InferExport(ctx, lambda: (self.view, self.recognition.curve()), self._color)
        self.shaping = InferShaping(ctx)  # what the tube is; the via-points
        self.charts = InferCharts(ctx, gui.add_folder("Charts", expand_by_default=True), layout)
        self.controls = InferControls(**handles, **build_display(gui, ctx.view))
        c = self.controls
        self.playback = ReplaySection(ctx, c.replay_bar)
        live = self.lsl.controls
        self.takeover = TakeOverSection(ctx.live, live.takeover, live.takeover_status,
                                        self.playback)  # fmt: skip
        c.live_button.on_click(lambda _: self._pressed.append("live"))
        c.live_clear.on_click(lambda _: self._pressed.append("clear"))
        c.replay_buttons.on_click(lambda event: self._pressed.append(str(event.target.value)))

    # ------------------------------------------------------------------ the frame

    def step(self, frame: Frame) -> Shown:
        """Show ``frame`` (see the module docstring)."""
        snapshot = self._snapshot = frame.snapshot
        if self.controls.follow(snapshot.store):
            self.charts.build(snapshot.store.layout)
        self.controls.tubes.step(snapshot)
        state = read_state(self.controls)
        self._run_pressed(state)
        observed = self.lsl.step(frame, state)
        self.takeover.step(observed, tuple(snapshot.store.layout.names))  # before the drawing
        samples = observed if state.lsl else self._observe(frame, state)
        choice = choose_model(state, snapshot, self.ctx.learner)
        # The view is computed again when one of its inputs changed (ViewInputs.same); a
        # change of the workspace or of the model alone waits, while another tab is in use,
        # until this one is (ViewInputs.waits).
        inputs = ViewInputs(state, choice.message, snapshot.store.demos,
                            snapshot.store.primitives, choice.model, samples,
                            snapshot.view.via_points)  # fmt: skip
        if self._drawn.redraw(inputs, frame.now, frame.panel != INFER, self.view):
            self._drawn = Drawn(inputs, frame.now)
            self._show(frame, state, choice, samples)
        self.playback.step()
        self.recognition.show(state.percent)
        self.recognition.live.step(state.lsl, self.ctx.live.running)
        shown, style = self._shown, snapshot.view.tube_style
        drawn = shown.result if shown.in_3d else None
        layer = self.ctx.inference_layer  # the one that says what it draws (.drawn)
        if not layer.drawn.shows(drawn, shown.color, style):
            layer.draw(drawn, shown.color, style)
        vias = self.shaping.step(snapshot, self.view, shown.color)
        return Shown(inference=shown, vias=(vias,))

    def _show(self, frame: Frame, state: InferState, choice: ModelChoice, samples) -> None:
        """Compute the view of ``state`` and write it; time it."""
        start = time.perf_counter()
        modalities = observed_choices(frame.snapshot.store.layout).get(state.observed)
        view = (lsl_view(state, samples) if state.lsl
                else compute(state, frame.snapshot, modalities, choice, samples))  # fmt: skip
        self.recognition.worker.busy()  # the curve's worker gives way while the slider moves
        previous, self.view = self.view, view
        if view.result is None and view.message and not state.live and (
            previous is None or previous.message != view.message
        ) and not view.message.startswith("learning a model"):
            self.ctx.notify("Cannot infer", view.message, color="yellow")
        self.recognition.request(view.curve, LIVE_NOTE if state.live and not state.lsl else "")
        result, c = view.result, self.controls
        color = self._color(result.inference.primitive) if result is not None else DEFAULT_COLOR
        # One group of messages: the browser applies bars, charts and status together.
        with self.ctx.atomic():
            if result is not None:
                c.probabilities.content = probabilities_html(result, self._color)
                self.charts.draw(result, view.movement, color)
            else:
                c.probabilities.content = ""
            self.playback.load(result)
            self.steps.add(1e3 * (time.perf_counter() - start))
            timing = self.steps.text(view.model.fit_ms)
            truth = None if state.live else state.primitive
            c.status.content = (
                failure_html(view.message, timing) if result is None
                else status_html(result, truth, view.model.note, timing)
            )  # fmt: skip
        self._shown = InferenceShown(result, color, state.show_3d, state.priors)

    # ------------------------------------------------------------------ buttons, live stream

    def _run_pressed(self, state: InferState) -> None:
        pressed, self._pressed = self._pressed, []
        for button in pressed:
            if button == "live":
                self.set_observing(not self.live.observing)
            elif button == "clear":
                self.live.clear()
            else:
                if button == "Play" and self.live.observing:
                    self.set_observing(False)  # the replay moves the hand: stop recording it
                self.playback.press(button)

    def set_observing(self, on: bool) -> None:
        """Start (from an empty buffer) or stop observing the live stream."""
        if on:
            self.playback.replay.release()
            self.live.start()
        else:
            self.live.stop()
        self.controls.live_button.label = "Stop observing" if on else "Start observing"

    def _observe(self, frame: Frame, state: InferState) -> StreamSamples | None:
        """Sample the live stream while observing; the samples an inference observes (None
        for a test demonstration)."""
        if not self.live.observe(frame.hand, frame.head):
            self.set_observing(False)
            self.ctx.notify("Observation stopped",
                            f"The live buffer is full ({self.live.max_seconds:.0f} s).",
                            color="yellow")  # fmt: skip
        return self.live.shown(time.monotonic()) if state.live else None

    # ------------------------------------------------------------------ between panels

    def open(self, request: InferRequest, snapshot: Snapshot) -> int:
        """Show ``request`` (:meth:`~app.panels.infer.controls.InferControls.show`), the live
        stream stopped; returns the slider's percentage. Loop thread.

        Raises
        ------
        ValueError
            If the workspace has no such demonstration (any more), or the modalities or the
            alpha method are not among the tab's choices.
        """
        percent = self.controls.show(request, snapshot.store)
        if self.live.observing:
            self.set_observing(False)
        return percent

    def _color(self, name: str) -> tuple[int, int, int]:
        try:
            return self._snapshot.store.color(name)
        except (ValueError, AttributeError):
            return DEFAULT_COLOR

    def chart_sliders(self) -> dict[str, ChartSlider]:
        """A click on the recognition chart moves the Observed % slider (the page's script)."""
        slider = self.controls.percent
        return {TITLE: ChartSlider(element_id(slider), slider.min, slider.max, X_RANGE)}

    def close(self) -> None:
        """Stop the recognition chart's worker."""
        self.recognition.close()
