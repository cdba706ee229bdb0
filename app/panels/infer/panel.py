"""The Infer tab: from the early part of a movement, recognise the primitive and predict the rest.

The user picks what is observed (a test demonstration, held out from the model while inspected,
or the live stream of the partner's head and the dragged hand), which modalities and which
alpha method, and scrubs the observed percentage. Everything follows the slider: the posterior
tube, the predicted future path and its end point (drawn by the scene), the probability of each
primitive, the predicted and true durations, the errors (:mod:`app.panels.infer.readout`), and
the per-dimension charts (:mod:`app.panels.infer.charts`). "Play" then lets the robot finish the
movement (:mod:`app.live.replay`).

The Data tab's "Open in Infer" comes through the studio as :meth:`InferPanel.open`: a test
demonstration at one percentage, modalities and alpha method (an evaluation's failed trial).

GUI callbacks only record that something changed; :meth:`InferPanel.step`, run by the studio's
loop, recomputes one scrub step (:func:`app.live.inference.scrub_step`) and redraws, and
measures that
server-side time (shown in the tab).

Live stream: "Start observing" starts a buffer (:class:`app.live.stream.LiveBuffer`) of
(t, hand, head) samples taken at every loop iteration (~60 Hz); the observation is the first
p % of the buffer (100 %: all of it, as it happens), recomputed at most ``LIVE_HZ`` times a
second while observing. The model is the session's (or the imported one).
"""

from __future__ import annotations

import collections
import math
import time

import numpy as np

from app.live.inference import (
    HeldOutModels,
    ScrubResult,
    demo_observation,
    scrub_step,
)
from app.live.replay import Replay
from app.live.stream import LiveBuffer
from app.panels.infer.charts import InferCharts
from app.panels.infer.readout import (
    LEGEND_HTML,
    failure_html,
    probabilities_html,
    status_html,
    timing_text,
)
from app.panels.infer.recognition import (
    LIVE_NOTE,
    TITLE,
    X_RANGE,
    CurveRequest,
    RecognitionChart,
)
from app.scene.inference_layer import DEFAULT_COLOR
from app.scene.look import FADED, PRIOR_MODES
from app.ui.context import InferRequest, PanelContext
from app.ui.display import ALPHA_HINT, INFER_ALPHAS, observed_choices
from app.ui.page_script import ChartSlider

TEST, LIVE = "Test demonstration", "Live stream"
SOURCES = (TEST, LIVE)
LIVE_HZ = 20.0
NONE = "(none)"


class InferPanel:
    """The Infer tab (see the module docstring). Built inside its tab's container."""

    def __init__(self, ctx: PanelContext) -> None:
        self.ctx = ctx
        self.models = HeldOutModels()
        self.live = LiveBuffer()
        self.clock = time.monotonic  # the live stream's time stamps [s] (tests drive a manual one)
        self.observing = False
        self.replay = Replay(ctx.arm.move_hand_to)
        self.result: ScrubResult | None = None
        self.message = ""
        self.scrub_ms = 0.0  # server-side time of the latest scrub step (recompute + redraw)
        self.recent_ms: collections.deque[float] = collections.deque(maxlen=30)
        self.fit_ms = 0.0  # held-out fit of the latest step, 0 when the cache had it
        self.model_note = ""  # which model the latest inference used
        self.scrub_count = 0
        self._dirty = True
        self._synced_version = -1
        self._demos_for = ""
        self._live_command: str | None = None
        self._replay_command: str | None = None
        self._last_live_scrub = 0.0
        self._live_epoch = 0
        self._curve_request: CurveRequest | None = None  # what the recognition chart shows
        self._build_gui()

    # ------------------------------------------------------------------ building

    def _build_gui(self) -> None:
        gui, layout = self.ctx.gui, self.ctx.session.layout
        with gui.add_folder("Observation"):
            self.source = gui.add_dropdown(
                "Source", SOURCES, initial_value=TEST,
                hint="A demonstration held out from the model, or the live hand and head",
            )  # fmt: skip
            self.primitive = gui.add_dropdown("Primitive", (NONE,))
            self.demo = gui.add_dropdown(
                "Test demo", (NONE,), hint="Inferred with a model learned without it"
            )
            self._choices = observed_choices(layout)
            self.observed = gui.add_dropdown("Observed", tuple(self._choices))
            self.alpha = gui.add_dropdown(
                "Alpha", tuple(INFER_ALPHAS), initial_value="ML",
                hint=ALPHA_HINT,
            )  # fmt: skip
            self.live_button = gui.add_button("Start observing", visible=False)
            self.live_clear = gui.add_button("Clear observation", visible=False)
        self.percent = gui.add_slider(
            "Observed %", min=1, max=100, step=1, initial_value=40,
            hint="How much of the movement is seen (live: of the buffer)",
        )  # fmt: skip
        self.probabilities = gui.add_html("")
        self.recognition = RecognitionChart(self.ctx, self._color)
        self.status = gui.add_html("")
        self.replay_buttons = gui.add_button_group("Replay", ("Play", "Pause", "Reset"))
        self.replay_bar = gui.add_progress_bar(0.0, color="gray")
        gui.add_html(LEGEND_HTML)
        slot = gui.add_folder("Charts", expand_by_default=True)
        self.charts = InferCharts(self.ctx, slot, layout)
        with gui.add_folder("Display", expand_by_default=False):
            self.show_3d = gui.add_checkbox("Show in 3D", True)
            self.session_mode = gui.add_dropdown(
                "Session priors", PRIOR_MODES, initial_value=FADED,
                hint="While an inference is shown, the session's prior tubes and demonstration "
                "lines are shown; faded: tubes dimmed, lines hidden; hidden: both hidden",
            )  # fmt: skip

        def dirty(_event) -> None:
            self._dirty = True

        for handle in (self.source, self.primitive, self.demo, self.observed, self.alpha):
            handle.on_update(dirty)
        self.percent.on_update(dirty)
        self.show_3d.on_update(dirty)

        @self.live_button.on_click
        def _(_event) -> None:
            self._live_command = "toggle"

        @self.live_clear.on_click
        def _(_event) -> None:
            self._live_command = "clear"

        @self.replay_buttons.on_click
        def _(event) -> None:
            self._replay_command = str(event.target.value)

    # ------------------------------------------------------------------ loop

    def step(self) -> None:
        """Called by the studio's loop at every iteration."""
        self._sync_choices()
        self._run_live_command()
        if self.observing:
            self._sample_live()
        commanded = self._run_replay_command()
        if self.replay.playing and self.ctx.arm.dragging:
            self.replay.pause()  # the user took the hand
        if self.replay.step() or commanded:
            self.replay_bar.value = 100.0 * self.replay.progress
        if self._dirty:
            self._dirty = False
            self.scrub()
        self.recognition.show(self.percent.value)
        self.ctx.scene.set_inference_options(self.show_3d.value, self.session_mode.value)

    def _sync_choices(self) -> None:
        session = self.ctx.session
        with session.lock:
            version = session.version
            demos = {name: [d.name for d in items] for name, items in session.demos.items()}
            layout = session.layout
        if version != self._synced_version:
            self._synced_version = version
            self.primitive.options = tuple(demos) or (NONE,)
            self._demos_for = ""
            self._dirty = True
            if layout != self.charts.layout:
                self._choices = observed_choices(layout)
                self.observed.options = tuple(self._choices)
                self.charts.build(layout)
        live = self.source.value == LIVE
        for handle in (self.primitive, self.demo):
            if handle.visible == live:
                handle.visible = not live
        for handle in (self.live_button, self.live_clear):
            if handle.visible != live:
                handle.visible = live
        if self.primitive.value != self._demos_for:
            self._demos_for = self.primitive.value
            self.demo.options = tuple(demos.get(self.primitive.value, ())) or (NONE,)
            self._dirty = True

    def open(self, request: InferRequest) -> int:
        """Show ``request``: its demonstration as the test one (held out), its modalities and
        alpha method, the slider at its percentage rounded to the slider's whole percents
        (returned). Loop thread.

        Raises
        ------
        ValueError
            If the session has no such demonstration (any more), or the modalities or the
            alpha method are not among the tab's choices.
        """
        self._sync_choices()
        session = self.ctx.session
        with session.lock:
            names = [d.name for d in session.demos.get(request.primitive, [])]
        if request.demo not in names:
            raise ValueError(
                f"the workspace has no demonstration {request.demo!r} of {request.primitive!r} "
                "(deleted since the evaluation?)"
            )
        observed = next(
            (label for label, modalities in self._choices.items()
             if tuple(modalities) == tuple(request.observed)), None,
        )  # fmt: skip
        alpha = next((k for k, v in INFER_ALPHAS.items() if v == request.alpha_method), None)
        if observed is None or alpha is None:
            raise ValueError(
                f"the Infer tab cannot observe {'+'.join(request.observed)} with alpha "
                f"{request.alpha_method!r}"
            )
        percent = int(min(self.percent.max, max(self.percent.min, round(request.percent))))
        if self.observing:
            self.set_observing(False)
        self.source.value = TEST
        self.primitive.value = request.primitive
        self._demos_for = request.primitive
        self.demo.options = tuple(names)
        self.demo.value = request.demo
        self.observed.value = observed
        self.alpha.value = alpha
        self.percent.value = percent
        self._dirty = True
        return percent

    # ------------------------------------------------------------------ live stream

    def _run_live_command(self) -> None:
        command, self._live_command = self._live_command, None
        if command == "toggle":
            self.set_observing(not self.observing)
        elif command == "clear":
            self.live.clear()
            self._live_epoch += 1
            self._dirty = True

    def set_observing(self, on: bool) -> None:
        """Start (from an empty buffer) or stop observing the live stream."""
        if on:
            self.replay.pause()
            self.live.clear()
            self._live_epoch += 1
            self._last_live_scrub = -math.inf  # a new stream is scrubbed from its first sample
        self.observing = on
        self.live_button.label = "Stop observing" if on else "Start observing"
        self._dirty = True

    def _sample_live(self) -> None:
        hand, head = self.ctx.hand_and_head()
        now = self.clock()
        if not self.live.append(now, hand, head):
            self.set_observing(False)
            self.ctx.notify(
                "Observation stopped",
                f"The live buffer is full ({self.live.max_seconds:.0f} s).",
                color="yellow",
            )
            return
        if self.source.value == LIVE and now - self._last_live_scrub >= 1.0 / LIVE_HZ:
            self._last_live_scrub = now
            self._dirty = True

    # ------------------------------------------------------------------ replay

    def _run_replay_command(self) -> bool:
        command = self._replay_command
        if command is None:
            return False
        try:
            if command == "Play":
                if self.observing:
                    self.set_observing(False)  # the replay moves the hand: stop recording it
                self.replay.play()
            elif command == "Pause":
                self.replay.pause()
            elif command == "Reset":
                self.replay.reset()
        except ValueError as exc:
            self.ctx.notify("Nothing to replay", str(exc), color="yellow")
        finally:
            self._replay_command = None
        return True

    def _load_replay(self, result: ScrubResult) -> None:
        times = result.future_times - result.future_times[0]
        if (
            result.future_hand is None
            or result.remaining < 1e-3
            or not np.all(np.diff(times) > 0)
        ):
            self.replay.clear()
            return
        # A new prediction during a replay (a refit landed) is followed from where it was.
        self.replay.load(times, result.future_hand, resume=self.replay.playing)

    # ------------------------------------------------------------------ scrub step

    def compute(self) -> ScrubResult:
        """One inference for the current choices (raises ValueError with the reason)."""
        modalities = self._choices.get(self.observed.value)
        if modalities is None:
            raise ValueError("choose the observed modalities")
        alpha_method = INFER_ALPHAS[self.alpha.value]
        percent = float(self.percent.value)
        session = self.ctx.session
        self._curve_request = None
        if self.source.value == LIVE:
            model = session.inference_model()
            if model is None:
                raise ValueError(f"no model yet: {session.fit_error or 'teach some primitives'}")
            self.model_note = (
                f"imported ({session.imported_from})"
                if session.imported_model is not None
                else "the session's, all demonstrations"
            )
            observation = self.live.observation(percent, modalities, model.layout)
            return scrub_step(model, observation, alpha_method)
        with session.lock:
            version = session.learn_version  # what the held-out model depends on
            imported = session.imported_model
            demos = {name: list(items) for name, items in session.demos.items()}
            # The workspace fit's choice of the automatic settings: a held-out model is then a
            # fit of fixed settings (milliseconds), not a new choice (a second or more).
            settings = session.resolved_settings()
            layout = session.layout
        name, demo_name = self.primitive.value, self.demo.value
        demo = next((d for d in demos.get(name, []) if d.name == demo_name), None)
        if demo is None:
            raise ValueError("choose a test demonstration (the session has none yet)")
        if imported is not None:
            model = imported  # inferred as is: an imported model cannot be refitted without it
            self.model_note = "imported, so NOT held out"
        else:
            self.model_note = f"learned without {demo_name} (held out)"
            cached = self.models.has(version, name, demo_name, settings)
            start = time.perf_counter()
            model = self.models.get(version, demos, name, demo_name, settings, layout)
            if not cached:
                self.fit_ms = 1e3 * (time.perf_counter() - start)
        origin = ("imported", id(imported)) if imported is not None else ("held out", version)
        self._curve_request = CurveRequest(
            key=(origin, name, demo_name, repr(settings), tuple(modalities), alpha_method),
            model=model, demo=demo, modalities=tuple(modalities), alpha_method=alpha_method,
            truth=name,
        )  # fmt: skip
        return scrub_step(
            model, demo_observation(model, demo, percent, modalities), alpha_method, truth=demo
        )

    def scrub(self) -> None:
        """Recompute and redraw everything that follows the slider; time it."""
        start = time.perf_counter()
        self.fit_ms = 0.0
        try:
            result, message = self.compute(), ""
        except ValueError as exc:
            result, message = None, str(exc)
            if message != self.message and self.source.value == TEST:
                self.ctx.notify("Cannot infer", message, color="yellow")
        self.result, self.message = result, message
        if self.source.value == LIVE:
            self.recognition.request(None, LIVE_NOTE)
        else:
            self.recognition.request(self._curve_request if result is not None else None)
        # One group of messages: the browser applies tube, bars and charts together, and the
        # websocket thread is woken once rather than once per update.
        with self.ctx.atomic():
            color = self._color(result.primitive) if result is not None else DEFAULT_COLOR
            self.ctx.scene.show_inference(
                result, color, self.show_3d.value, self.session_mode.value
            )
            if result is not None:
                self.probabilities.content = probabilities_html(result, self._color)
                self.charts.draw(result, self._movement(result), color)
                self._load_replay(result)
            else:
                self.probabilities.content = ""
                self.replay.clear()
            self.replay_bar.value = 0.0
            self.scrub_ms = 1e3 * (time.perf_counter() - start) - self.fit_ms
            self.recent_ms.append(self.scrub_ms)
            self.scrub_count += 1
            timing = timing_text(self.scrub_ms, self.recent_ms, self.fit_ms)
            self.status.content = (
                failure_html(message, timing)
                if result is None
                else status_html(result, self._truth_primitive(), self.model_note, timing)
            )

    def _color(self, name: str) -> tuple[int, int, int]:
        try:
            return self.ctx.session.color(name)
        except ValueError:
            return DEFAULT_COLOR

    def _truth_primitive(self) -> str | None:
        return self.primitive.value if self.source.value == TEST else None

    def _movement(self, result: ScrubResult) -> tuple:
        """What is inspected: a test demonstration, or the live stream since its last clear."""
        if result.truth is not None:
            return (TEST, self.primitive.value, self.demo.value)
        return (LIVE, self._live_epoch)

    def chart_sliders(self) -> dict[str, ChartSlider]:
        """A click on the recognition chart moves the Observed % slider (the page's script)."""
        slider = self.percent
        return {TITLE: ChartSlider(slider._impl.uuid, slider.min, slider.max, X_RANGE)}

    def close(self) -> None:
        """Stop the recognition chart's worker."""
        self.recognition.close()
