"""The Teach tab's Record folder: the Record button (also Space, when the 3D view has the
focus), the recording's status, *Go to start*, *Discard last take*, and the take's options
(rate, trimming of the idle ends and its thresholds, back to the start after Stop).

The callbacks only record the press; :meth:`RecordSection.step`, on the studio's loop, feeds it
with the time to the state machine (:mod:`app.live.take_machine`) and acts on what it
says: a refusal is a red line and a notification, the countdown shows its digit, the
:class:`app.live.recorder.Recorder` samples the hand and the head until Stop, the idle time at both
ends is trimmed (:func:`app.live.takes.active_span`; the untrimmed take is kept in the workspace's
``raw/`` folder) and the demonstration is saved by :meth:`app.core.session.Session.add_demo` (which
scores its typicality). The scene shows the ghost of the primitive's start (where its
demonstrations begin, :func:`app.live.takes.mean_start`); *Go to start* and, after Stop, the option
*Back to start* put the hand there.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable

import numpy as np
import viser

from app.live.recorder import RECORD_RATE_HZ, Recorder, Recording, unrecordable
from app.live.take_machine import (
    COUNTDOWN_S,
    HEAD_FAILED,
    MAX_COUNTDOWN_S,
    RATE_RANGE_HZ,
    Event,
    Phase,
    RecordingMachine,
    Take,
    refusal,
)
from app.live.takes import HAND_IDLE_M_S, HEAD_IDLE_RAD_S, Trim, active_span, mean_start
from app.panels.teach.demos import NOTIFY_COLORS, TYPICALITY_COLORS, typicality_text
from app.scene.workspace_layer import NO_COLOR
from app.ui.context import PanelContext
from app.ui.text import ORANGE, RED, colored, escape
from robots.icub.layout import HAND, HEAD

STATUS_PERIOD_S = 0.2  # the recording's status line
LIVE_PLOT_PERIOD_S = 0.25  # the prior plots with the demonstration being recorded


class RecordSection:
    """The Record folder (see the module docstring).

    Parameters
    ----------
    ctx : PanelContext
    selected : callable
        The selected primitive (None when there is none).
    select : callable
        ``select(name)``: select that primitive (after a save).
    redraw : callable
        Redraw the tab's plots and lists at the next step (a recording ended).
    live_plot : callable
        ``live_plot(primitive, recording)``: plot the recording so far.
    countdown_s : float
    """

    def __init__(
        self,
        ctx: PanelContext,
        selected: Callable[[], str | None],
        select: Callable[[str], None],
        redraw: Callable[[], None],
        live_plot: Callable[[str, Recording], None],
        countdown_s: float = COUNTDOWN_S,
    ):
        self.ctx = ctx
        self.selected = selected
        self.select = select
        self.redraw = redraw
        self.live_plot = live_plot
        self.machine = RecordingMachine(countdown_s)
        self.recorder: Recorder | None = None
        self.last_message = ""  # the latest outcome (also shown in the GUI)
        self._head_refusal = False  # last_message is a refusal because the head source failed
        self._pressed = False
        self._go_to_start = False
        self._discard: object | None = None  # the click's event, until the loop discards
        self.last_take: tuple[str, str] | None = None  # (primitive, demo) saved last, this run
        self._press_lock = threading.Lock()
        self._next_status = 0.0
        self._next_live_plot = 0.0
        gui = ctx.gui
        with gui.add_folder("Record"):
            self.status = gui.add_markdown("")
            self.button = gui.add_button(
                "Record",
                color="red",
                icon=viser.Icon.PLAYER_RECORD_FILLED,
                hint="Counts down (3-2-1; the time is under Take options), then records the "
                "hand and the partner's head until Stop (Space does the same while the 3D view "
                "has the focus).",
            )
            self.start_button = gui.add_button(
                "Go to start",
                icon=viser.Icon.HOME,
                hint="Move the hand to where this primitive's demonstrations start (the ghost).",
            )
            self.discard_button = gui.add_button(
                "Discard last take",
                icon=viser.Icon.TRASH,
                color="gray",
                visible=False,
                hint="Move the demonstration just recorded to the trash (Undo delete, under "
                "Demonstrations, brings it back).",
            )
            with gui.add_folder("Take options", expand_by_default=False):
                self.countdown = gui.add_number(
                    "Countdown (s)", countdown_s, min=0.0, max=MAX_COUNTDOWN_S, step=0.5,
                    hint="The time between Record and the first sample: to reach the robot's "
                    "hand, or 0 to record at once.",
                )  # fmt: skip
                low, high = RATE_RANGE_HZ
                self.rate = gui.add_number(
                    "Rate (Hz)", RECORD_RATE_HZ, min=low, max=high, step=1.0
                )
                self.trim = gui.add_checkbox(
                    "Trim idle ends", True,
                    hint="Cut the still time before and after the movement (the untrimmed take "
                    "is kept in the workspace's raw/ folder).",
                )  # fmt: skip
                self.hand_idle = gui.add_number(
                    "Hand idle below (cm/s)", round(100 * HAND_IDLE_M_S, 2), min=0.1,
                    max=50.0, step=0.1, hint="The hand moves when it is faster than this.",
                )  # fmt: skip
                self.head_idle = gui.add_number(
                    "Head idle below (°/s)", round(math.degrees(HEAD_IDLE_RAD_S), 1),
                    min=0.5, max=180.0, step=0.5,
                    hint="The partner's head moves when it turns faster than this.",
                )  # fmt: skip
                self.back_to_start = gui.add_checkbox(
                    "Back to start after Stop", True,
                    hint="After a take, put the hand back at the primitive's start.",
                )  # fmt: skip
            self.hotkey = gui.add_command(
                "Record / Stop", description="The Teach tab's Record button", hotkey="space"
            )
        self.button.on_click(lambda _event: self.press())
        self.hotkey.on_trigger(lambda _event: self.press())
        self.start_button.on_click(lambda _event: self.go_to_start())
        self.discard_button.on_click(lambda event: self.discard(event))
        for handle in (self.trim, self.hand_idle, self.head_idle):
            handle.on_update(lambda _event: self.show_idle_later())
        self._idle_dirty = False
        self.show_idle()

    @property
    def take(self) -> Take | None:
        """The recording under way or counting down (None when idle)."""
        return self.machine.take

    @property
    def sampling(self) -> bool:
        return self.machine.phase is Phase.RECORDING

    @property
    def idle(self) -> bool:
        return self.machine.phase is Phase.IDLE

    def press(self) -> None:
        """The button was pressed (Record, Cancel or Stop): recorded for the next step."""
        with self._press_lock:
            self._pressed = True

    def go_to_start(self) -> None:
        """Move the hand to the primitive's start at the next step."""
        self._go_to_start = True

    def discard(self, event=None) -> None:
        """Move the last take to the trash at the next step."""
        self._discard = event if event is not None else True

    def show_idle_later(self) -> None:
        self._idle_dirty = True

    # ------------------------------------------------------------------ the loop

    def step(self, now: float) -> None:
        with self._press_lock:
            pressed, self._pressed = self._pressed, False
        phase = self.machine.phase
        if phase is Phase.IDLE:
            self._run_idle_commands()
            if pressed:
                self._begin(now)
        elif phase is Phase.COUNTDOWN:
            self._count_down(now, pressed)
        elif pressed:
            self._stop(self.machine.press(now)[1])
        elif self.recorder.error is not None:
            self._stop(self.machine.fail()[1])
        else:
            self._show_progress(now)

    def _run_idle_commands(self) -> None:
        """Go to start, discard the last take, show new thresholds (between takes only)."""
        if self._go_to_start:
            self._go_to_start = False
            self._move_to_start(self.selected())
        event, self._discard = self._discard, None
        if event is not None and self.last_take is not None:
            primitive, demo = self.last_take
            if self.ctx.attempt(event, "discard the take",
                                lambda: self.ctx.session.delete_demo(primitive, demo)):  # fmt: skip
                self.last_take = None
                self.discard_button.visible = False
                self.last_message = f"Discarded **{demo}**: in the trash (*Undo delete* below)."
                self.show_idle()
                self.ctx.tell(event, "Take discarded",
                              f"{demo} moved to the workspace's trash (Undo delete brings it "
                              "back).", "gray")  # fmt: skip
        if self._idle_dirty:
            self._idle_dirty = False
            self.show_idle()

    def start_pose(self, primitive: str | None) -> np.ndarray | None:
        """Where ``primitive``'s demonstrations start, on average (None without any)."""
        session = self.ctx.session
        with session.lock:
            demos = list(session.demos.get(primitive, [])) if primitive is not None else []
            layout = session.layout
        return mean_start(demos, layout)

    def show_start(self) -> None:
        """The ghost of the selected primitive's start pose, in its colour."""
        name = self.selected()
        try:
            color = self.ctx.session.color(name) if name is not None else NO_COLOR
        except ValueError:
            color = NO_COLOR
        self.ctx.scene.show_start(self.start_pose(name), color)

    def _move_to_start(self, primitive: str | None) -> bool:
        start = self.start_pose(primitive)
        if start is None:
            return False
        self.ctx.arm.move_hand_to(start)
        return True

    def _begin(self, now: float) -> None:
        name, rate = self.selected(), float(self.rate.value)
        reason = refusal(name, self.ctx.session.layout, self.ctx.head.source.error, rate)
        countdown = float(self.countdown.value)
        if not math.isfinite(countdown):
            countdown = COUNTDOWN_S
        countdown = min(max(countdown, 0.0), MAX_COUNTDOWN_S)
        event, _ = self.machine.press(now, name, rate, refused=reason, countdown_s=countdown)
        if event is Event.REFUSED:
            self._report(reason, "Cannot record", "red")
            self._head_refusal = reason.startswith(HEAD_FAILED)
            return
        self.last_message, self._head_refusal = "", False
        self._set_button("Cancel", "gray", viser.Icon.X)

    def _count_down(self, now: float, pressed: bool) -> None:
        if pressed:
            self.machine.press(now)
            self._finish("Recording cancelled.")
            return
        event, take = self.machine.tick(now)
        if event is Event.STARTED:
            self.recorder = Recorder(self.ctx.hand_and_head, take.rate_hz)
            self.recorder.start()
            self._set_button("Stop", "red", viser.Icon.PLAYER_STOP_FILLED)
            self._show_recording(take)
            return
        self.status.content = (
            f'<div style="text-align:center;font-size:2.4em;font-weight:700;'
            f'color:{RED}">{self.machine.remaining(now)}</div>'
        )

    def _show_progress(self, now: float) -> None:
        take = self.machine.take
        if now >= self._next_status:
            self._next_status = now + STATUS_PERIOD_S
            self._show_recording(take)
        if now >= self._next_live_plot:
            self._next_live_plot = now + LIVE_PLOT_PERIOD_S
            self.live_plot(take.primitive, self.recorder.snapshot())

    def _stop(self, take: Take) -> None:
        """End the recording and save it (or say why not)."""
        recorder, self.recorder = self.recorder, None
        recording = recorder.stop()
        self._finish()
        if recorder.error is not None:
            self._report(f"The recording failed: {recorder.error}", "Nothing saved", "red")
            return
        self._save(take.primitive, recording)

    # ------------------------------------------------------------------ display

    def show_idle(self) -> None:
        self.status.content = self._idle_status()

    def _idle_status(self) -> str:
        name = self.selected()
        missing = unrecordable(self.ctx.session.layout)
        if missing:
            text = colored(
                f"Recording is off in this workspace: its demonstrations also hold "
                f"{', '.join(missing)}, which the studio cannot record.",
                ORANGE,
            )
        elif name is None:
            text = "Create a primitive to record into."
        else:
            text = f"Ready to record into **{name}**: drag the hand's gizmo while recording."
            if self.trim.value:
                text += (
                    f" Still ends are trimmed: hand below {float(self.hand_idle.value):g} cm/s"
                )
                if HEAD.name in self.ctx.session.layout.names:
                    text += f", head below {float(self.head_idle.value):g}°/s"
                text += "."
        if self.last_message:
            text += "  \n" + self.last_message
        return text

    def forget_head_refusal(self) -> None:
        """A new head source: a refusal because the previous one failed no longer holds."""
        if self._head_refusal:
            self.last_message, self._head_refusal = "", False
            self.show_idle()

    def _set_button(self, label: str, color: str, icon) -> None:
        self.button.label = label
        self.button.color = color
        self.button.icon = icon

    def _finish(self, message: str | None = None) -> None:
        self._set_button("Record", "red", viser.Icon.PLAYER_RECORD_FILLED)
        if message is not None:
            self.last_message = message
            self.show_idle()
        self.redraw()  # the plots without the live recording

    def _show_recording(self, take: Take) -> None:
        recording = self.recorder.snapshot()
        if recording.n_samples == 0:
            duration, n, face = 0.0, 0, 100.0
        else:
            duration, n = recording.duration, recording.n_samples
            face = 100.0 * float(recording.face.mean())
        face_text = f"face {face:.0f} %"
        if face < 100.0:
            face_text = colored(face_text, ORANGE)
        self.status.content = (
            colored("● Recording", RED, bold=True)
            + f" into **{take.primitive}**: {duration:.1f} s, {n} samples, {face_text}"
        )

    def trimmed(self, recording: Recording, values: np.ndarray) -> Trim | None:
        """What trimming keeps of ``values`` (the take's columns in the session's layout);
        None when nothing moves. All of it when trimming is off.

        Raises
        ------
        ValueError
            A threshold that is not positive.
        """
        n = recording.n_samples
        if not self.trim.value:
            return Trim(0, n, n)
        layout = self.ctx.session.layout
        head = values[:, layout.dims([HEAD.name])] if HEAD.name in layout.names else None
        return active_span(
            recording.times, values[:, layout.dims([HAND.name])], head,
            hand_threshold=float(self.hand_idle.value) / 100.0,
            head_threshold=math.radians(float(self.head_idle.value)),
        )  # fmt: skip

    def _save(self, primitive: str, recording: Recording) -> None:
        session = self.ctx.session
        try:
            values, fill = recording.values(session.layout)
            trim = self.trimmed(recording, values)
            if trim is None:
                raise ValueError(
                    "neither the hand nor the head moved faster than the idle thresholds "
                    f"({float(self.hand_idle.value):g} cm/s, {float(self.head_idle.value):g}°/s): "
                    "untick Trim idle ends (Take options) to keep a still take"
                )
            kept = slice(trim.start, trim.stop)
            raw = (recording.times, values) if trim.trimmed else None
            demo = session.add_demo(primitive, recording.times[kept], values[kept], raw=raw)
        except (ValueError, OSError) as exc:
            self._report(f"Nothing saved: {exc}", "Nothing saved", "red")  # escaped there
            return
        self.last_take = (primitive, demo.name)
        self.discard_button.visible = True
        typicality = session.typicality.get((primitive, demo.name))
        text = f"Saved **{demo.name}**: {demo.duration:.1f} s, {demo.n_samples} samples"
        if trim.trimmed:
            before, after = trim.seconds(recording.times)
            text += f" (still ends cut: {before:.1f} s before, {after:.1f} s after)"
        if typicality is not None:
            flag = "" if typicality.label == "typical" else "⚠ "
            text += ", " + colored(
                flag + typicality_text(typicality), TYPICALITY_COLORS[typicality.label], True
            )
        else:
            text += ", typicality: needs 3 earlier demonstrations"
        if fill.n_filled:
            text += f" ({fill.message})"
        findings = session.findings_of(primitive, demo.name)
        if findings:
            reasons = "; ".join(f.message for f in findings)
            text += "  \n" + colored(
                f"⚠ Left out of learning: {escape(reasons)}. *Keep* it in Demonstrations to "
                "learn from it anyway.",
                ORANGE,
                True,
            )
        self.select(primitive)
        color = NOTIFY_COLORS[typicality.label] if typicality is not None else "green"
        body = text.replace("**", "")
        if typicality is not None:
            body = f"{demo.name}: {typicality_text(typicality)} compared with the others"
        if findings:
            color = "yellow"
            body = f"{demo.name} is left out of learning: {reasons}"
        self.last_message = text
        self.show_idle()
        self.ctx.notify("Demonstration saved", body, color)
        if self.back_to_start.value:
            self._move_to_start(primitive)

    def _report(self, text: str, title: str, color: str) -> None:
        self.last_message = colored(escape(text), RED if color == "red" else ORANGE)
        self.show_idle()
        self.ctx.notify(title, text, color)
