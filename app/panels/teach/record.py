"""The Teach tab's Record folder: the Record button (also Space, when the 3D view has the
focus), the recording's status, *Go to start*, *Discard last take*, and the take's options
(countdown, rate, trimming of the idle ends and its thresholds, back to the start after Stop).

The callbacks only record the press. :meth:`RecordSection.step`, on the studio's loop, hands it
to the take's controller (:class:`app.live.take_controller.TakeController`: the countdown, the
recorder, the save on a worker), notifies what the take came to, and writes the status line,
a pure function of the controller's state, the frame's snapshot and the options
(:func:`outcome_text`): the line says what happened to the latest take of the workspace shown,
with its typicality once the learner has scored it. The scene shows the ghost of the chosen
primitive's start (where its demonstrations begin, :func:`app.live.takes.mean_start`);
*Go to start* and, after Stop, the option *Back to start* put the hand there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import viser

from app.core.snapshot import Snapshot
from app.live.recorder import RECORD_RATE_HZ, Recording
from app.live.take_controller import (
    COUNTDOWN_S,
    MAX_COUNTDOWN_S,
    RATE_RANGE_HZ,
    Outcome,
    Phase,
    TakeController,
    refusal,
    workspace_refusal,
)
from app.live.takes import HAND_IDLE_M_S, HEAD_IDLE_RAD_S, TakeOptions, mean_start
from app.panels.teach.demos import NOTIFY_COLORS, TYPICALITY_COLORS, typicality_text
from app.scene.look import StartShown
from app.scene.workspace_layer import NO_COLOR
from app.ui.context import Frame, PanelContext, PanelGui
from app.ui.icons import icon_svg, set_icon
from app.ui.text import ORANGE, RED, colored, escape
from robots.icub.layout import HEAD

STATUS_PERIOD_S = 0.2  # the recording's status line
BUTTON = {  # the Record button in each phase: label, colour, icon
    Phase.IDLE: ("Record", "red", viser.Icon.PLAYER_RECORD_FILLED),
    Phase.COUNTDOWN: ("Cancel", "gray", viser.Icon.X),
    Phase.RECORDING: ("Stop", "red", viser.Icon.PLAYER_STOP_FILLED),
    Phase.SAVING: ("Saving...", "gray", viser.Icon.DEVICE_FLOPPY),
}
LIVE_PLOT_PERIOD_S = 0.25  # the prior plots with the demonstration being recorded
RECORD_HINT = (
    "Counts down (3-2-1; the time is under Take options), then records the hand and the "
    "partner's head until Stop (Space does the same while the 3D view has the focus)."
)


@dataclass(frozen=True, eq=False)
class RecordControls:
    """The handles of the Record folder."""

    status: viser.GuiMarkdownHandle
    button: viser.GuiButtonHandle
    start_button: viser.GuiButtonHandle
    discard_button: viser.GuiButtonHandle
    countdown: viser.GuiNumberHandle
    rate: viser.GuiNumberHandle
    trim: viser.GuiCheckboxHandle
    hand_idle: viser.GuiNumberHandle
    head_idle: viser.GuiNumberHandle
    back_to_start: viser.GuiCheckboxHandle
    hotkey: object

    def options(self, snapshot: Snapshot) -> TakeOptions:
        """How a take becomes a demonstration, as the Take options say."""
        return TakeOptions(
            snapshot.store.layout, bool(self.trim.value),
            float(self.hand_idle.value) / 100.0, math.radians(float(self.head_idle.value)),
        )  # fmt: skip

    def countdown_s(self) -> float:
        countdown = float(self.countdown.value)
        return COUNTDOWN_S if not math.isfinite(countdown) else min(max(countdown, 0.0),
                                                                      MAX_COUNTDOWN_S)


def build_controls(gui: PanelGui, countdown_s: float) -> RecordControls:
    with gui.add_folder("Record"):
        status = gui.add_markdown("")
        button = gui.add_button(
            "Record", color="red", icon=viser.Icon.PLAYER_RECORD_FILLED, hint=RECORD_HINT
        )
        start_button = gui.add_button(
            "Go to start", icon=viser.Icon.HOME,
            hint="Move the hand to where this primitive's demonstrations start (the ghost).",
        )  # fmt: skip
        discard_button = gui.add_button(
            "Discard last take", icon=viser.Icon.TRASH, color="gray", visible=False,
            hint="Move the demonstration just recorded to the trash (Undo delete, under "
            "Demonstrations, brings it back).",
        )  # fmt: skip
        with gui.add_folder("Take options", expand_by_default=False):
            countdown = gui.add_number(
                "Countdown (s)", countdown_s, min=0.0, max=MAX_COUNTDOWN_S, step=0.5,
                hint="The time between Record and the first sample: to reach the robot's "
                "hand, or 0 to record at once.",
            )  # fmt: skip
            low, high = RATE_RANGE_HZ
            rate = gui.add_number("Rate (Hz)", RECORD_RATE_HZ, min=low, max=high, step=1.0)
            trim = gui.add_checkbox(
                "Trim idle ends", True,
                hint="Cut the still time before and after the movement (the untrimmed take is "
                "kept in the workspace's raw/ folder).",
            )  # fmt: skip
            hand_idle = gui.add_number(
                "Hand idle below (cm/s)", round(100 * HAND_IDLE_M_S, 2), min=0.1, max=50.0,
                step=0.1, hint="The hand moves when it is faster than this.",
            )  # fmt: skip
            head_idle = gui.add_number(
                "Head idle below (°/s)", round(math.degrees(HEAD_IDLE_RAD_S), 1), min=0.5,
                max=180.0, step=0.5,
                hint="The partner's head moves when it turns faster than this.",
            )  # fmt: skip
            back_to_start = gui.add_checkbox(
                "Back to start after Stop", True,
                hint="After a take, put the hand back at the primitive's start.",
            )  # fmt: skip
        hotkey = gui.add_command(
            "Record / Stop", description="The Teach tab's Record button", hotkey="space"
        )
    return RecordControls(status, button, start_button, discard_button, countdown, rate, trim,
                          hand_idle, head_idle, back_to_start, hotkey)  # fmt: skip


def start_of(snapshot: Snapshot, primitive: str | None) -> np.ndarray | None:
    """Where ``primitive``'s demonstrations start, on average (None without any)."""
    demos = snapshot.store.demos.get(primitive, ()) if primitive is not None else ()
    return mean_start(demos, snapshot.store.layout)


def outcome_text(outcome: Outcome | None, frame: Frame) -> str:
    """What the latest take came to, if it concerns the workspace shown (and, for a refusal
    because the head source failed, while it still fails); a saved take's typicality once
    scored, and what the checks found in it."""
    store = frame.snapshot.store
    if outcome is None or outcome.root != store.workspace.root:
        return ""
    if outcome.kind == "head" and frame.head_error is None:
        return ""
    if outcome.kind in ("refused", "head", "failed"):
        return colored(escape(outcome.text), RED)
    text = outcome.text
    if outcome.kind != "saved" or outcome.saved is None:
        return text
    if not any(d.name == outcome.saved[1] for d in store.demos.get(outcome.saved[0], ())):
        return text
    score = frame.snapshot.typicality.get(outcome.saved)
    if score is not None:
        flag = "" if score.label == "typical" else "⚠ "
        text += ", " + colored(flag + typicality_text(score), TYPICALITY_COLORS[score.label], True)
    elif outcome.saved in frame.snapshot.scoring:
        text += ", typicality: scoring..."
    else:
        text += ", typicality: needs 3 earlier demonstrations"
    findings = store.findings_of(*outcome.saved)
    if findings:
        reasons = "; ".join(f.message for f in findings)
        text += "  \n" + colored(
            f"⚠ Left out of learning: {escape(reasons)}. *Keep* it in Demonstrations to learn "
            "from it anyway.", ORANGE, True,
        )  # fmt: skip
    return text


def idle_text(frame: Frame, controls: RecordControls) -> str:
    """The line between takes: what a take goes into, and how its still ends are trimmed."""
    store, name = frame.snapshot.store, frame.snapshot.primitive
    blocked = workspace_refusal(name, store.layout, store.frame.own)
    if blocked is not None:  # beside the disabled Record button
        return colored(escape(blocked), ORANGE)
    text = f"Ready to record into **{name}**: drag the hand's gizmo while recording."
    if controls.trim.value:
        text += f" Still ends are trimmed: hand below {float(controls.hand_idle.value):g} cm/s"
        if HEAD.name in store.layout.names:
            text += f", head below {float(controls.head_idle.value):g}°/s"
        text += "."
    return text


def recording_text(primitive: str, recording: Recording) -> str:
    """The line while recording: into what, for how long, how often the face was seen."""
    if recording.n_samples == 0:
        duration, n, face = 0.0, 0, 100.0
    else:
        duration, n = recording.duration, recording.n_samples
        face = 100.0 * float(recording.face.mean())
    face_text = f"face {face:.0f} %"
    if face < 100.0:
        face_text = colored(face_text, ORANGE)
    return (
        colored("● Recording", RED, bold=True)
        + f" into **{primitive}**: {duration:.1f} s, {n} samples, {face_text}"
    )


class RecordSection:
    """The Record folder (see the module docstring).

    Parameters
    ----------
    ctx : PanelContext
    live_plot : callable
        ``live_plot(primitive, recording or None)``: plot the recording so far (None: the
        recording ended).
    countdown_s : float
    """

    def __init__(self, ctx: PanelContext, live_plot, countdown_s: float = COUNTDOWN_S):
        self.ctx = ctx
        self.live_plot = live_plot
        self.takes = TakeController(ctx.hand_and_head, ctx.store, countdown_s)
        self.controls = c = build_controls(ctx.gui, countdown_s)
        for _, _, icon in BUTTON.values():
            icon_svg(icon)  # read once, now: not on the loop during a take
        self._pressed: list[object] = []  # "record", "start", or a Discard click's event
        self._scored: tuple | None = None  # the saved take whose score was notified
        self._back_to_start: str | None = None  # a primitive saved into: to its start, once on
        self._next = (0.0, 0.0)  # when the recording's status and live plot are due
        c.button.on_click(lambda _event: self.press())
        c.hotkey.on_trigger(lambda _event: self.press())
        c.start_button.on_click(lambda _event: self._pressed.append("start"))
        c.discard_button.on_click(lambda event: self._pressed.append(event))

    @property
    def take(self):
        """The take under way (counting down, recording or being saved); None when idle."""
        return self.takes.take

    def press(self) -> None:
        """The button was pressed (Record, Cancel or Stop): acted on at the next step."""
        self._pressed.append("record")

    # ------------------------------------------------------------------ the frame

    def step(self, frame: Frame) -> StartShown:
        """Act on the presses, move the take on, show its status; the ghost of the start."""
        snapshot, c = frame.snapshot, self.controls
        pressed, self._pressed = self._pressed, []
        for press in pressed:
            self._act(press, frame)
        event, outcome = self.takes.step(frame.now, c.options(snapshot))
        if outcome is not None:
            self._told(outcome)
        phase = self.takes.phase
        self._show_button(phase, snapshot)
        if phase is Phase.COUNTDOWN:
            c.status.content = (
                f'<div style="text-align:center;font-size:2.4em;font-weight:700;'
                f'color:{RED}">{self.takes.machine.remaining(frame.now)}</div>'
            )
        elif phase is Phase.RECORDING:
            self._show_recording(frame)
        elif phase is Phase.IDLE:
            self._show_idle(frame)
        else:
            c.status.content = "Saving the take..."
        name = snapshot.primitive
        color = snapshot.store.color(name) if name is not None else NO_COLOR
        return StartShown(start_of(snapshot, name), color)

    def _act(self, press: object, frame: Frame) -> None:
        snapshot = frame.snapshot
        if press == "record":
            if self.takes.phase is Phase.IDLE:
                self._begin(frame)
            else:
                self.takes.press(frame.now, None, 0.0, 0.0, None)
        elif self.takes.phase is not Phase.IDLE:
            return  # Go to start and Discard wait between takes
        elif press == "start":
            self._move_to_start(snapshot, snapshot.primitive)
        else:
            try:
                self._told(self.takes.discard(), client=getattr(press, "client", None))
            except (ValueError, OSError) as exc:
                self.ctx.tell(press, "Cannot discard the take", str(exc))

    def _begin(self, frame: Frame) -> None:
        name, c = frame.snapshot.primitive, self.controls
        rate = float(c.rate.value)
        store = frame.snapshot.store
        reason = refusal(name, store.layout, frame.head_error, rate, store.frame.own)
        self.takes.press(frame.now, name, rate, c.countdown_s(), reason)
        outcome = self.takes.outcome
        if outcome is not None and outcome.kind in ("refused", "head"):
            self._told(outcome)

    def _told(self, outcome: Outcome, client=None) -> None:
        """Notify what a take came to; after a save, the hand back to the start (option)."""
        if outcome.title:
            self.ctx.notify(outcome.title, outcome.body, outcome.color, client=client)
        if outcome.kind in ("saved", "failed", "cancelled"):
            self.live_plot(None, None)  # the plots without the recording
        if outcome.kind == "saved" and self.controls.back_to_start.value:
            self._back_to_start = outcome.saved[0]

    def _move_to_start(self, snapshot: Snapshot, primitive: str | None) -> None:
        start = start_of(snapshot, primitive)
        if start is not None:
            self.ctx.arm.move_hand_to(start)

    # ------------------------------------------------------------------ display

    def _show_button(self, phase: Phase, snapshot: Snapshot) -> None:
        """The button of the phase; between takes, disabled where nothing can be recorded
        (:func:`app.live.take_controller.workspace_refusal`, said in the status beside it)."""
        label, color, icon = BUTTON.get(phase, BUTTON[Phase.IDLE])
        button = self.controls.button
        if button.label != label:
            button.label, button.color = label, color
            set_icon(button, icon)
        store = snapshot.store
        reason = workspace_refusal(snapshot.primitive, store.layout, store.frame.own)
        off = phase is Phase.IDLE and reason is not None
        if button.disabled != off:
            button.disabled = off
            button.hint = reason if off else RECORD_HINT

    def _show_recording(self, frame: Frame) -> None:
        next_status, next_plot = self._next
        recording = self.takes.recording()
        primitive = self.takes.take.primitive
        if frame.now >= next_status:
            next_status = frame.now + STATUS_PERIOD_S
            self.controls.status.content = recording_text(primitive, recording)
        if frame.now >= next_plot:
            next_plot = frame.now + LIVE_PLOT_PERIOD_S
            self.live_plot(primitive, recording)
        self._next = (next_status, next_plot)

    def _show_idle(self, frame: Frame) -> None:
        snapshot, outcome = frame.snapshot, self.takes.outcome
        text = outcome_text(outcome, frame)
        self.controls.status.content = idle_text(frame, self.controls) + (
            "  \n" + text if text else ""
        )
        saved = outcome.saved if outcome is not None and outcome.kind == "saved" else None
        present = bool(text) and saved is not None and any(
            d.name == saved[1] for d in snapshot.store.demos.get(saved[0], ())
        )
        if self.controls.discard_button.visible != present:
            self.controls.discard_button.visible = present
        if present and self._back_to_start is not None:  # the take is in this frame's state
            self._move_to_start(snapshot, self._back_to_start)
            self._back_to_start = None
        score = snapshot.typicality.get(saved) if present else None
        if score is not None and self._scored != saved:
            self._scored = saved
            if score.label != "typical":
                self.ctx.notify(
                    "Take to check",
                    f"{saved[1]}: {typicality_text(score)} compared with the others",
                    NOTIFY_COLORS[score.label],
                )

    def close(self) -> None:
        self.takes.close()
