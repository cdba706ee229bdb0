"""The Infer tab: from the early part of a movement, recognise the primitive and predict the rest.

The user picks what is observed (a test demonstration, held out from the model while inspected,
or the live stream of the partner's head and the dragged hand), which modalities and which
alpha method, and scrubs the observed percentage. Everything follows the slider: the posterior
tube, the predicted future path and its end point, the probability of each primitive, the
predicted and true durations, the errors, and the per-dimension charts (prior and posterior
bands, observed samples, truth; the paper's Figs. 4, 7 and 9). "Play" then lets the robot
finish the movement (:mod:`app.replay`).

Dirty-flag pattern: GUI callbacks only record that something changed; :meth:`InferPanel.step`,
run by the studio's loop, recomputes one scrub step (:func:`app.inference_view.scrub_step`)
and redraws, and measures that server-side time (shown in the tab).

Live stream: "Start observing" starts a buffer of (t, hand, head) samples taken at every loop
iteration (~60 Hz); the observation is the first p % of the buffer (100 %: all of it, as it
happens), recomputed at most ``LIVE_HZ`` times a second while observing. Samples without a
face are left out when the head is observed. The model is the session's (or the imported one).

Display units: those of :mod:`app.display` (the hand in centimetres, the head in degrees). The
observed-modality choices and the charts (one chart tab per modality) follow the workspace's
layout.
"""

from __future__ import annotations

import collections
import dataclasses
import html
import math
import statistics
import time
from typing import TYPE_CHECKING

import numpy as np

from app.display import observed_choices, quantities
from app.inference_view import (
    ALPHA_CHOICES,
    PATH_POINTS,
    TUBE_POINTS,
    HeldOutModels,
    LiveBuffer,
    ScrubResult,
    demo_observation,
    hand_dims,
    scrub_step,
)
from app.plots import Band, BandChart, Trace, add_band_chart, band_chart, update_band_chart
from app.replay import Replay
from app.tubes import resample, tube_faces, tube_vertices
from promp.data import Layout

if TYPE_CHECKING:
    from app.studio import Studio

TEST, LIVE = "Test demonstration", "Live stream"
SOURCES = (TEST, LIVE)
SESSION_MODES = ("shown", "faded", "hidden")
PRIOR_OPACITY = 0.25  # the prior tubes' own opacity (app.scene_view)
DIMMED_OPACITY = 0.07
POSTERIOR_OPACITY = 0.45
LIVE_HZ = 20.0
NONE = "(none)"
PRIOR_COLOR = (125, 125, 125)
OBSERVED_COLOR = (25, 25, 25)
TRUTH_COLOR = (70, 70, 70)
DEFAULT_COLOR = (120, 120, 120)
LEGEND_HTML = (
    '<div style="font-size:0.72em;color:#555;margin-top:4px">'
    'bands ±2σ: <b style="color:#7d7d7d">prior</b> · <b>posterior</b> (recognised primitive\'s '
    "colour) · ● observed · ╌ truth</div>"
)


def _darker(color, factor: float = 0.6) -> tuple[int, int, int]:
    return tuple(int(round(c * factor)) for c in color)  # type: ignore[return-value]


def _fmt(value: float, unit: str, scale: float = 1.0, digits: int = 1) -> str:
    return "—" if not math.isfinite(value) else f"{value * scale:.{digits}f} {unit}"


@dataclasses.dataclass(frozen=True)
class _FixedRangeChart(BandChart):
    """A band chart whose x (time) range is fixed too, in seconds."""

    x_range: tuple[float, float] = (0.0, 1.0)

    @property
    def scales(self) -> dict:
        return {"x": {"time": False, "range": self.x_range}, "y": {"range": self.y_range}}


class InferPanel:
    """The Infer tab (see the module docstring). Built inside its tab's container."""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.server = studio.server
        self.models = HeldOutModels()
        self.live = LiveBuffer()
        self.observing = False
        self.replay = Replay(studio.arm.move_hand_to)
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
        self._range_key: tuple | None = None
        self._ranges: dict[int, tuple[float, float, float]] = {}
        self._session_faded = False
        self._build_gui()
        self._build_scene()

    # ------------------------------------------------------------------ building

    def _build_gui(self) -> None:
        gui = self.server.gui
        with gui.add_folder("Observation"):
            self.source = gui.add_dropdown(
                "Source", SOURCES, initial_value=TEST,
                hint="A demonstration held out from the model, or the live hand and head",
            )  # fmt: skip
            self.primitive = gui.add_dropdown("Primitive", (NONE,))
            self.demo = gui.add_dropdown(
                "Test demo", (NONE,), hint="Inferred with a model learned without it"
            )
            self._choices = observed_choices(self.studio.session.layout)
            self.observed = gui.add_dropdown("Observed", tuple(self._choices))
            self.alpha = gui.add_dropdown(
                "Alpha", tuple(ALPHA_CHOICES), initial_value="ML",
                hint="ML: most likely training speed; model: regression on the early motion",
            )  # fmt: skip
            self.live_button = gui.add_button("Start observing", visible=False)
            self.live_clear = gui.add_button("Clear observation", visible=False)
        self.percent = gui.add_slider(
            "Observed %", min=1, max=100, step=1, initial_value=40,
            hint="How much of the movement is seen (live: of the buffer)",
        )  # fmt: skip
        self.probabilities = gui.add_html("")
        self.status = gui.add_html("")
        self.replay_buttons = gui.add_button_group("Replay", ("Play", "Pause", "Reset"))
        self.replay_bar = gui.add_progress_bar(0.0, color="gray")
        gui.add_html(LEGEND_HTML)
        self.charts: list = []
        self._chart_tabs = None
        self._charts_layout: Layout | None = None
        self._chart_slot = gui.add_folder("Charts", expand_by_default=True)
        self._build_charts(self.studio.session.layout)
        with gui.add_folder("Display", expand_by_default=False):
            self.show_3d = gui.add_checkbox("Show in 3D", True)
            self.session_mode = gui.add_dropdown(
                "Session priors", SESSION_MODES, initial_value="shown",
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

    def _build_charts(self, layout: Layout) -> None:
        """One chart tab per modality of ``layout``, one chart per dimension."""
        if self._chart_tabs is not None:
            self._chart_tabs.remove()
        gui = self.server.gui
        placeholder = band_chart([], [Trace("", np.array([0.0, 1.0]), np.zeros(2), (0, 0, 0))])
        self.quantities = quantities(layout)
        self.charts = []
        with self._chart_slot:
            self._chart_tabs = gui.add_tab_group()
            for modality in layout.modalities:
                with self._chart_tabs.add_tab(modality.name.capitalize()):
                    for q in self.quantities:
                        if q.modality == modality.name:
                            self.charts.append(
                                add_band_chart(gui, placeholder, title=q.title, aspect=3.3)
                            )
        self._charts_layout = layout
        self._range_key = None

    def _build_scene(self) -> None:
        scene = self.server.scene
        line = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]])
        straight = np.linspace([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], TUBE_POINTS)
        self.tube = scene.add_mesh_simple(
            "/infer/posterior",
            vertices=tube_vertices(straight, np.full((TUBE_POINTS, 3), 0.01)),
            faces=tube_faces(TUBE_POINTS),
            color=DEFAULT_COLOR,
            opacity=POSTERIOR_OPACITY,
            flat_shading=False,
            side="double",
            visible=False,
        )
        self.future = scene.add_spline_catmull_rom(
            "/infer/future", points=line, thickness=5.0, thickness_units="screen",
            color=DEFAULT_COLOR, visible=False,
        )  # fmt: skip
        self.observed_line = scene.add_spline_catmull_rom(
            "/infer/observed", points=line, thickness=4.0, thickness_units="screen",
            color=OBSERVED_COLOR, visible=False,
        )  # fmt: skip
        self.truth_line = scene.add_spline_catmull_rom(
            "/infer/truth", points=line, thickness=2.0, thickness_units="screen",
            color=TRUTH_COLOR, visible=False,
        )  # fmt: skip
        self.end_point = scene.add_icosphere(
            "/infer/end", radius=0.02, color=DEFAULT_COLOR, visible=False
        )
        self.now_point = scene.add_icosphere(
            "/infer/now", radius=0.012, color=(250, 250, 250), visible=False
        )
        self.nodes = (
            self.tube, self.future, self.observed_line, self.truth_line, self.end_point,
            self.now_point,
        )  # fmt: skip

    # ------------------------------------------------------------------ loop

    def step(self) -> None:
        """Called by the studio's loop at every iteration."""
        self._sync_choices()
        self._run_live_command()
        if self.observing:
            self._sample_live()
        commanded = self._run_replay_command()
        if self.replay.playing and self.studio.arm.dragging:
            self.replay.pause()  # the user took the hand
        if self.replay.step() or commanded:
            self.replay_bar.value = 100.0 * self.replay.progress
        if self._dirty:
            self._dirty = False
            self.scrub()
        self._apply_session_mode()

    def _sync_choices(self) -> None:
        session = self.studio.session
        with session.lock:
            version = session.version
            demos = {name: [d.name for d in items] for name, items in session.demos.items()}
        if version != self._synced_version:
            self._synced_version = version
            self.primitive.options = tuple(demos) or (NONE,)
            self._demos_for = ""
            self._dirty = True
            layout = session.layout
            if layout != self._charts_layout:
                self._choices = observed_choices(layout)
                self.observed.options = tuple(self._choices)
                self._build_charts(layout)
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
        self.observing = on
        self.live_button.label = "Stop observing" if on else "Start observing"
        self._dirty = True

    def _sample_live(self) -> None:
        hand, head = self.studio.hand_and_head()
        now = time.monotonic()
        if not self.live.append(now, hand, head):
            self.set_observing(False)
            self.studio.notify(
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
            self.studio.notify("Nothing to replay", str(exc), color="yellow")
        finally:
            self._replay_command = None
        return True

    # ------------------------------------------------------------------ scrub step

    def compute(self) -> ScrubResult:
        """One inference for the current choices (raises ValueError with the reason)."""
        modalities = self._choices.get(self.observed.value)
        if modalities is None:
            raise ValueError("choose the observed modalities")
        alpha_method = ALPHA_CHOICES[self.alpha.value]
        percent = float(self.percent.value)
        session = self.studio.session
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
            version = session.version
            imported = session.imported_model
            demos = {name: list(items) for name, items in session.demos.items()}
            settings = session.learning_settings()
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
            cached = (version, name, demo_name) in self.models
            start = time.perf_counter()
            model = self.models.get(version, demos, name, demo_name, settings, layout)
            if not cached:
                self.fit_ms = 1e3 * (time.perf_counter() - start)
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
                self.studio.notify("Cannot infer", message, color="yellow")
        self.result, self.message = result, message
        # One group of messages: the browser applies tube, bars and charts together, and the
        # websocket thread is woken once rather than once per update.
        with self.server.atomic():
            self._draw_scene(result)
            self._draw_probabilities(result)
            if result is not None:
                self._draw_charts(result)
                self._load_replay(result)
            else:
                self.replay.clear()
            self.replay_bar.value = 0.0
            self.scrub_ms = 1e3 * (time.perf_counter() - start) - self.fit_ms
            self.recent_ms.append(self.scrub_ms)
            self.scrub_count += 1
            self._draw_status(result, message)

    def _color(self, name: str) -> tuple[int, int, int]:
        try:
            return self.studio.session.color(name)
        except ValueError:
            return DEFAULT_COLOR

    def _draw_scene(self, result: ScrubResult | None) -> None:
        hand = hand_dims(result.layout) if result is not None else None
        if result is None or not self.show_3d.value or hand is None:
            for node in self.nodes:
                if node.visible:
                    node.visible = False
            return
        color = self._color(result.primitive)
        post = result.posterior
        self.tube.vertices = tube_vertices(post.mean[:, hand], post.std[:, hand])
        self.tube.color = color
        self.future.points = result.future_hand.astype(np.float32)
        self.future.color = _darker(color)
        self.end_point.position = result.future_hand[-1]
        self.end_point.color = color
        self.now_point.position = result.future_hand[0]
        obs = result.observation
        if "hand" in obs.modalities and obs.n_observed >= 2:
            cols = np.flatnonzero(np.isin(result.layout.dims(obs.modalities), hand))
            points = resample(obs.values[:, cols], min(obs.n_observed, PATH_POINTS))
            self.observed_line.points = points.astype(np.float32)
            if not self.observed_line.visible:
                self.observed_line.visible = True
        elif self.observed_line.visible:
            self.observed_line.visible = False
        if result.truth is not None:
            true_hand = result.layout.extract(result.truth)[:, hand]
            rest = true_hand[max(obs.n_observed - 1, 0) :]
            if rest.shape[0] >= 2:
                self.truth_line.points = resample(rest, min(rest.shape[0], PATH_POINTS)).astype(
                    np.float32
                )
            if self.truth_line.visible != (rest.shape[0] >= 2):
                self.truth_line.visible = rest.shape[0] >= 2
        elif self.truth_line.visible:
            self.truth_line.visible = False
        for node in (self.tube, self.future, self.end_point, self.now_point):
            if not node.visible:
                node.visible = True

    def _draw_probabilities(self, result: ScrubResult | None) -> None:
        if result is None:
            self.probabilities.content = ""
            return
        rows = []
        for k, (name, p) in enumerate(zip(result.names, result.probabilities, strict=True)):
            r, g, b = self._color(name)
            weight = "700" if k == result.recognition.index else "400"
            rows.append(
                f'<div data-primitive="{html.escape(name)}" data-p="{p:.6f}" '
                'style="display:flex;align-items:center;gap:6px;margin:3px 0">'
                f'<span style="width:92px;overflow:hidden;text-overflow:ellipsis;'
                f'white-space:nowrap;font-weight:{weight}">{html.escape(name)}</span>'
                '<span style="flex:1;height:11px;background:#e9ecef;border-radius:3px;'
                'overflow:hidden">'
                f'<span style="display:block;width:{100 * p:.1f}%;height:100%;'
                f'background:rgb({r},{g},{b})"></span></span>'
                '<span style="width:48px;text-align:right;font-variant-numeric:tabular-nums">'
                f"{100 * p:.1f} %</span></div>"
            )
        self.probabilities.content = (
            '<div style="font-size:0.8em;margin:2px 0 4px 0">' + "".join(rows) + "</div>"
        )

    def _draw_status(self, result: ScrubResult | None, message: str) -> None:
        timing = (
            f"step {self.scrub_ms:.1f} ms (server; median of the last {len(self.recent_ms)}: "
            f"{statistics.median(self.recent_ms):.1f} ms)"
        )
        if self.fit_ms > 0:
            timing += f" · held-out fit {self.fit_ms:.0f} ms"
        if result is None:
            self.status.content = (
                f'<div style="font-size:0.8em;color:#a33">{html.escape(message)}</div>'
                f'<div style="font-size:0.72em;color:#777">{timing}</div>'
            )
            return
        obs = result.observation
        truth = result.truth
        if truth is not None:
            verdict = self._truth_primitive()
            mark = (
                ""
                if verdict is None
                else (' <span style="color:#2b8a3e">✓</span>' if verdict == result.primitive
                      else f' <span style="color:#c92a2a">✗ (truth: {html.escape(verdict)})</span>')
            )  # fmt: skip
            seen = f"{obs.n_observed} / {truth.n_samples} samples, {result.observed_until:.2f} s"
        else:
            mark = ""
            seen = f"{obs.n_observed} samples, {result.observed_until:.2f} s"
        lines = [
            f"<b>Recognised: {html.escape(result.primitive)}</b>{mark} · α = {result.alpha:.3f}",
            f"Observed: {seen} ({' + '.join(obs.modalities)})",
            f"Model: {html.escape(self.model_note)}",
            f"Duration: predicted {result.duration:.2f} s · true "
            f"{_fmt(result.true_duration, 's', digits=2)}",
            f"Errors: remainder {_fmt(result.position_error_m, 'cm', 100)} · goal "
            f"{_fmt(result.goal_error_m, 'cm', 100)} · duration "
            f"{_fmt(result.duration_error_s, 's', digits=2)}",
        ]
        self.status.content = (
            '<div style="font-size:0.8em;line-height:1.55">' + "<br>".join(lines) + "</div>"
            f'<div style="font-size:0.72em;color:#777">{timing}</div>'
        )

    def _truth_primitive(self) -> str | None:
        return self.primitive.value if self.source.value == TEST else None

    def _draw_charts(self, result: ScrubResult) -> None:
        key = (
            (TEST, self.primitive.value, self.demo.value)
            if result.truth is not None
            else (LIVE, self._live_epoch)
        )
        if key != self._range_key:
            self._range_key, self._ranges = key, {}
        color = self._color(result.primitive)
        obs = result.observation
        layout = result.layout
        if layout != self._charts_layout:
            return  # an imported model of other modalities: no charts to draw into
        observed = list(layout.dims(obs.modalities))
        truth = layout.extract(result.truth) if result.truth is not None else None
        for i, (handle, q) in enumerate(zip(self.charts, self.quantities, strict=True)):
            dim, scale = q.column, q.scale
            prior, post = result.prior, result.posterior
            bands = [
                Band("prior", prior.times, scale * prior.mean[:, dim], scale * prior.std[:, dim],
                     PRIOR_COLOR),
                Band("posterior", post.times, scale * post.mean[:, dim], scale * post.std[:, dim],
                     color),
            ]  # fmt: skip
            traces = []
            if truth is not None:
                traces.append(
                    Trace("truth", result.truth.times, scale * truth[:, dim], TRUTH_COLOR,
                          width=1.5, dash=(5.0, 4.0))
                )  # fmt: skip
            if dim in observed:
                column = obs.values[:, observed.index(dim)]
                traces.append(
                    Trace("observed", obs.elapsed, scale * column, OBSERVED_COLOR, points=True)
                )
            chart = band_chart(bands, traces)
            update_band_chart(self.server, handle, self._sticky(i, chart))

    def _sticky(self, index: int, chart: BandChart) -> BandChart:
        """The chart with fixed x and y ranges that only grow while the same movement is
        inspected: scrubbing neither rescales (and so rebuilds) the chart at every step nor
        leaves uPlot's automatic x range to the browser (viser rescales it relative to the
        previous data, which a rebuild can leave undefined: an empty chart)."""
        lo, hi = chart.y_range
        x_hi = float(chart.grid[-1])
        if index in self._ranges:
            old_lo, old_hi, old_x = self._ranges[index]
            lo, hi, x_hi = min(lo, old_lo), max(hi, old_hi), max(x_hi, old_x)
        self._ranges[index] = (lo, hi, x_hi)
        fields = {f.name: getattr(chart, f.name) for f in dataclasses.fields(chart)}
        return _FixedRangeChart(**{**fields, "y_range": (lo, hi)}, x_range=(0.0, x_hi))

    def _load_replay(self, result: ScrubResult) -> None:
        times = result.future_times - result.future_times[0]
        if (
            result.future_hand is None
            or result.remaining < 1e-3
            or not np.all(np.diff(times) > 0)
        ):
            self.replay.clear()
            return
        self.replay.load(times, result.future_hand)

    # ------------------------------------------------------------------ session drawing

    def _apply_session_mode(self) -> None:
        """Fade or hide the session's prior tubes and demonstration lines (drawn by
        :class:`app.scene_view.SceneView`) while an inference is shown, and put them back as
        the scene view draws them otherwise."""
        mode = self.session_mode.value
        active = mode != "shown" and self.result is not None and self.show_3d.value
        view = self.studio.view
        if not active:
            if self._session_faded:
                self._session_faded = False
                with self.studio.session.lock:
                    hidden = set(self.studio.session.hidden)
                for tube in list(view.tubes.values()):
                    tube.visible, tube.opacity = True, PRIOR_OPACITY
                for key, line in list(view.lines.items()):
                    line.visible = key not in hidden
            return
        self._session_faded = True
        for tube in list(view.tubes.values()):
            if tube.visible != (mode != "hidden"):
                tube.visible = mode != "hidden"
            if tube.opacity != DIMMED_OPACITY:
                tube.opacity = DIMMED_OPACITY
        for line in list(view.lines.values()):
            if line.visible:
                line.visible = False
