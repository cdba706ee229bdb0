"""The Infer tab's LSL streams folder: a lab's sensors as the observation.

Shown when the Source is *LSL streams (live)* (:data:`app.live.inference.LSL`, the folder's
title too): the streams found on the network (name, type,
rate, channels, host), the mapping from the workspace's modalities to streams and channels in
the rig syntax (``hand=MocapHand:0,1,2@mm``, one a line; guessed from the streams found until
the user edits it, *Guess* guesses again), how a movement starts (stillness, a marker stream
chosen among those found, or the Begin / End buttons), *Commit to a primitive* (the commit
rule on each movement, at the *Commit threshold*: :mod:`promp.live.commitment`), *Robot takes
over* (:mod:`app.panels.infer.takeover_section`), Start /
Stop, each input's condition and the session's news (a commitment among them), and
*Predictions out*: the same LSL streams as ``python -m promp.live`` (probabilities, timing,
the predicted remainder of a chosen modality at a stated rate, events), on while its checkbox
is.

The callbacks only record presses; :meth:`LiveSection.step`, on the studio's loop, acts on them
(:class:`app.live.lsl_source.LslSource`: a refused start is a notification and a red line,
nothing starts) and returns what the tab observes: an
:class:`app.panels.infer.lsl_view.LslObserved`, the same object until the session's prediction
or its message changes.
"""

from __future__ import annotations

import collections
import time
from dataclasses import dataclass

import viser

from app.core.snapshot import Snapshot
from app.live.inference import LSL
from app.live.lsl_mapping import guess_mapping, selector_text
from app.live.lsl_source import STARTS, LiveConfig, LslSource
from app.panels.infer.live_status import idle_html, outputs_html, session_html, streams_html
from app.panels.infer.lsl_view import LslObserved
from app.panels.infer.session_replay_section import SessionReplaySection
from app.panels.infer.takeover_section import TAKEOVER_HINT
from app.panels.infer.view_model import InferState
from app.ui.context import Frame, PanelContext, PanelGui
from promp.data import Layout
from promp.decision import WINDOW_S
from promp.live.options import DECIDE_THRESHOLD
from robots.icub.layout import HAND

__all__ = ["GuessedText", "LiveControls", "LiveSection", "STATUS_PERIOD_S"]

STATUS_PERIOD_S = 0.25
NONE = "(none)"
START_WORDS = {"still": " (by stillness: move)", "marker": " (by the marker stream: "
               "'start CLASS')", "call": " (press Begin)"}  # fmt: skip
MAPPING_HINT = (
    "One modality a line: NAME=STREAM:CHANNEL,...[@UNIT]. STREAM: a stream's name, type=TYPE "
    "or source_id=ID; CHANNELs: labels or indices 0,1,...; @mm, @cm, @deg are converted to "
    "metres and radians (a stream's own channel units are, when it states them)."
)


@dataclass(frozen=True, eq=False)
class LiveControls:
    """The handles of the LSL streams folder."""

    folder: viser.GuiFolderHandle
    streams: viser.GuiHtmlHandle
    mapping: viser.GuiTextHandle
    guess: viser.GuiButtonHandle
    start: viser.GuiDropdownHandle
    markers: viser.GuiDropdownHandle
    run: viser.GuiButtonHandle
    movement: viser.GuiButtonGroupHandle
    status: viser.GuiHtmlHandle
    publish: viser.GuiCheckboxHandle
    out: viser.GuiTextHandle
    remainder: viser.GuiDropdownHandle
    rate: viser.GuiNumberHandle
    outputs: viser.GuiHtmlHandle
    commit: viser.GuiCheckboxHandle
    threshold: viser.GuiNumberHandle
    takeover: viser.GuiCheckboxHandle
    takeover_status: viser.GuiHtmlHandle


class GuessedText:
    """A text field the studio fills with a guess until the user edits it.

    The user has edited it when its value is not the text the studio last wrote. That is read
    from the value itself, not only from the field's ``on_update`` callback: viser sets a
    field's value when the page's message arrives and runs the callback later, on its thread
    pool, so a guess written in between (the streams found changed) would overwrite what the
    user has just typed (a plain CI run of 2026-11-30 timed out on such a lost edit)."""

    def __init__(self, handle) -> None:
        self.handle = handle
        self._written = handle.value  # the text the studio last wrote
        self._edited = False

    @property
    def edited(self) -> bool:
        if self.handle.value != self._written:
            self._edited = True  # (latched: typing the guess back keeps the user's choice)
        return self._edited

    def typed(self) -> None:
        """The field's ``on_update`` from a page: the user's (whatever the value)."""
        self._edited = True

    def offer(self, guess: str) -> None:
        """Write ``guess`` unless the user has edited the field."""
        if not self.edited and self.handle.value != guess:
            self._written = self.handle.value = guess

    def reset(self, guess: str) -> None:
        """Write ``guess`` and forget the user's edit (*Guess*, a new workspace layout)."""
        self._edited = False
        self._written = self.handle.value = guess


def build_controls(gui: PanelGui, layout: Layout) -> LiveControls:
    remainders = (NONE, *layout.names)
    with gui.add_folder(LSL, visible=False) as folder:
        streams = gui.add_html("")
        mapping = gui.add_text("Mapping", "", multiline=True, hint=MAPPING_HINT)
        guess = gui.add_button("Guess the mapping", color="gray",
                               hint="From the streams found: channels labelled after the "
                               "modality's columns, or a stream named after it")  # fmt: skip
        start = gui.add_dropdown("Movement start", tuple(STARTS), initial_value="stillness",
                                 hint="How a movement's start and end are found: the inputs in "
                                 "m or rad moving then still, a marker stream's 'start CLASS' "
                                 "and 'end CLASS', or the Begin / End buttons")  # fmt: skip
        markers = gui.add_dropdown("Marker stream", (NONE,), visible=False)
        commit = gui.add_checkbox("Commit to a primitive", False,
                                  hint="Run the commit rule (promp.CommitRule) on each "
                                  "movement: the moment the robot would act (set at Start)")
        threshold = gui.add_number("Commit threshold", DECIDE_THRESHOLD, min=0.01, max=0.99,
                                   step=0.01, hint="Commit once the leading primitive's "
                                   f"probability stays at or above this for {WINDOW_S:g} s",
                                   visible=False)  # fmt: skip
        takeover = gui.add_checkbox("Robot takes over", False, hint=TAKEOVER_HINT)
        takeover_status = gui.add_html("")
        run = gui.add_button("Start", color="green", icon=viser.Icon.PLAYER_PLAY)
        movement = gui.add_button_group("Movement", ("Begin", "End"), visible=False)
        status = gui.add_html("")
        with gui.add_folder("Predictions out (LSL)", expand_by_default=False):
            publish = gui.add_checkbox("Publish predictions", False,
                                       hint="The same streams as python -m promp.live: "
                                       "NAME-probabilities, -timing, -remainder, -events")
            out = gui.add_text("Streams' name", "studio")
            remainder = gui.add_dropdown(
                "Remainder of", remainders,
                initial_value=HAND.name if HAND.name in layout.names else NONE,
                hint="The modality whose predicted rest is published (set at Start)",
            )  # fmt: skip
            rate = gui.add_number("Remainder rate (Hz)", 50.0, min=1.0, max=1000.0, step=1.0)
            outputs = gui.add_html("")
    return LiveControls(folder, streams, mapping, guess, start, markers, run, movement, status,
                        publish, out, remainder, rate, outputs, commit, threshold, takeover,
                        takeover_status)  # fmt: skip


class LiveSection:
    """The LSL streams folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext, layout: Layout):
        self.ctx = ctx
        self.source: LslSource = ctx.live
        self.controls = c = build_controls(ctx.gui, layout)
        with c.folder:
            self.replay = SessionReplaySection(ctx, self.source)
        self._layout = layout
        self._pressed: list[str] = []
        self._mapping = GuessedText(c.mapping)  # the user's typed mapping: no guess over it
        self._found: tuple = ()
        self._outputs: tuple[str, ...] = ()  # the studio's own streams, as listed
        self._refused = ""
        self._published: tuple[bool, str] | None = None  # what the outlets were set to
        self._observed = LslObserved(None, None)
        self._rates: collections.deque = collections.deque(maxlen=120)
        self._next_status = 0.0
        c.run.on_click(lambda _: self._pressed.append("run"))
        c.guess.on_click(lambda _: self._pressed.append("guess"))
        c.movement.on_click(lambda event: self._pressed.append(str(event.target.value)))
        c.mapping.on_update(lambda event: self._typed(event))

    def _typed(self, event) -> None:
        if event.client is not None:
            self._mapping.typed()

    # ------------------------------------------------------------------ the frame

    def step(self, frame: Frame, state: InferState) -> LslObserved | None:
        """Show the folder for the Source ``state`` says; act on the presses; what the tab
        observes (None when the Source is not the LSL one)."""
        c = self.controls
        if c.folder.visible != state.lsl:
            c.folder.visible = state.lsl
        if not state.lsl:
            return None
        self.source.watch()
        snapshot = frame.snapshot
        self._follow(snapshot.store.layout)
        pressed, self._pressed = self._pressed, []
        for press in pressed:
            self._act(press, snapshot, state)
        self._show_found()
        self._publish()
        self.replay.step(snapshot)
        running = self.source.running is not None
        label = "Stop" if running else "Start"
        if c.run.label != label:
            c.run.label, c.run.color = label, "red" if running else "green"
            c.run.icon = viser.Icon.PLAYER_STOP_FILLED if running else viser.Icon.PLAYER_PLAY
        current = self.source.running
        live = current is not None and current.replay is None  # (a replay's are recorded)
        for handle, wanted in ((c.movement, live),
                               (c.markers, STARTS[c.start.value] == "marker"),
                               (c.threshold, bool(c.commit.value))):  # fmt: skip
            if handle.visible != wanted:
                handle.visible = wanted
        if frame.now >= self._next_status:
            self._next_status = frame.now + STATUS_PERIOD_S
            self._show_status()
        return self._observe(snapshot)

    def _follow(self, layout: Layout) -> None:
        if layout == self._layout:
            return
        self._layout = layout
        self.controls.remainder.options = (NONE, *layout.names)
        self._mapping.reset(guess_mapping(layout, self._found))

    def _act(self, press: str, snapshot: Snapshot, state: InferState) -> None:
        if press == "run":
            if self.source.running is not None:
                self.source.stop()
            else:
                self._start(snapshot, state)
        elif press == "guess":
            self._mapping.reset(guess_mapping(self._layout, self.source.found()))
        elif press == "Begin":
            self.source.begin()
        elif press == "End":
            self.source.end()

    def config(self, state: InferState) -> LiveConfig:
        """What the controls say a session is started with."""
        c = self.controls
        start = STARTS[c.start.value]
        # the dropdown (hidden unless movements start by markers) holds a stream all the same
        markers = c.markers.value if start == "marker" and c.markers.value != NONE else ""
        remainder = c.remainder.value if c.remainder.value != NONE else None
        commit = float(c.threshold.value) if c.commit.value else None
        return LiveConfig(c.mapping.value, start, markers, state.alpha_method,
                          bool(c.publish.value), c.out.value, remainder,
                          float(c.rate.value), commit)  # fmt: skip

    def _start(self, snapshot: Snapshot, state: InferState) -> None:
        model, store = snapshot.inference_model, snapshot.store
        try:
            if model is None:
                error = snapshot.learner.error or "teach some primitives"
                raise ValueError(f"no model yet: {error}")
            config = self.config(state)
            self.source.start(model, config, store.frame.placement, store.workspace.root,
                              lambda: self.ctx.store.state.names)  # fmt: skip
        except ValueError as exc:
            self._refused = f"Not started: {exc}"
            self.ctx.notify("Cannot start the live source", str(exc), color="red")
            return
        self._refused = ""
        self._published = (config.publish, config.out)

    def _publish(self) -> None:
        """Publishing switched on or off (or renamed) while the session runs."""
        c = self.controls
        wanted = (bool(c.publish.value), str(c.out.value))
        running = self.source.running
        if running is None or running.replay is not None or wanted == self._published:
            return  # (a replay publishes nothing)
        self._published = wanted
        try:
            self.source.publish(*wanted)
        except ValueError as exc:
            self.ctx.notify("Cannot publish the predictions", str(exc), color="red")
            c.publish.value = False
            self._published = (False, wanted[1])

    # ------------------------------------------------------------------ display

    def _show_found(self) -> None:
        found = self.source.found()
        if found == self._found and self.controls.streams.content and \
                self._outputs == self.source.outlets.names:  # fmt: skip
            return
        self._outputs = self.source.outlets.names
        self._found = found
        c = self.controls
        html = streams_html(self.source.unavailable, found, self.source.available,
                            self.source.outlets.names)  # fmt: skip
        if c.streams.content != html:
            c.streams.content = html
        markers = tuple(selector_text(s, found) for s in found if s.is_markers) or (NONE,)
        if tuple(c.markers.options) != markers:
            c.markers.options = markers
        if self.source.running is None and not self._mapping.edited:
            self._mapping.offer(guess_mapping(self._layout, found))

    def _show_status(self) -> None:
        c, running = self.controls, self.source.running
        snap = running.session.snapshot() if running is not None else None
        if running is None or snap is None:
            html = idle_html(self._refused)
        else:
            now = time.monotonic()
            self._rates.append((now, snap.predictions))
            while len(self._rates) > 2 and now - self._rates[0][0] > 2.0:
                self._rates.popleft()
            t0, n0 = self._rates[0]
            rate = (snap.predictions - n0) / (now - t0) if now > t0 else 0.0
            # a replay's clock is the recorded one, at its latest step
            now = snap.time if running.replay is not None else self.source.transport().clock()
            html = session_html(snap, now, rate, self._refused,
                                START_WORDS[running.config.start])  # fmt: skip
        if c.status.content != html:
            c.status.content = html
        outputs = outputs_html(self.source.outlets.names)
        if c.outputs.content != outputs:
            c.outputs.content = outputs

    def _observe(self, snapshot: Snapshot) -> LslObserved:
        running = self.source.running
        if running is None:
            prediction, model, note = None, None, ""
            message = "the live source is not started: map the streams and press Start"
            movement: tuple = ()
        else:
            snap = running.session.snapshot()
            prediction, model = snap.prediction, running.model
            note = ("the session file's (recorded with it)" if running.replay is not None
                    else "the session's at Start")  # fmt: skip
            if running.replay is None and snapshot.inference_model is not model:
                note += " (the workspace's has changed since: Stop and Start to use it)"
            message = "" if prediction is not None else _waiting(snap)
            movement = (running.number, prediction.movement if prediction else 0)
        old = self._observed
        if (prediction is not old.prediction or message != old.message or note != old.note
                or model is not old.model):  # fmt: skip
            self._observed = LslObserved(prediction, model, note, message, movement)
        return self._observed


def _waiting(snap) -> str:
    waiting = [s.stream for s in snap.statuses if not s.healthy]
    if waiting:
        return f"waiting for the stream(s) {', '.join(waiting)}"
    if snap.movement is None:
        return "waiting for a movement to start"
    return f"movement {snap.movement.number} under way: the first prediction comes next"
