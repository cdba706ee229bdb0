"""The Teach tab's Record folder: the Record button, the recording's status and its rate.

The button's callback only records the press; :meth:`RecordSection.step`, on the studio's
loop, feeds it with the time to the state machine (:mod:`app.panels.teach.recording`) and acts
on what it says: a refusal is a red line and a notification, the countdown shows its digit, the
:class:`app.recorder.Recorder` samples the hand and the head until Stop, and the demonstration
is then saved by :meth:`app.session.Session.add_demo` (which scores its typicality).
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import viser

from app.context import PanelContext
from app.gui_text import ORANGE, RED, colored, escape
from app.panels.teach.demos import NOTIFY_COLORS, TYPICALITY_COLORS, typicality_text
from app.panels.teach.recording import (
    COUNTDOWN_S,
    HEAD_FAILED,
    RATE_RANGE_HZ,
    Event,
    Phase,
    RecordingMachine,
    Take,
    refusal,
)
from app.recorder import DEFAULT_RATE_HZ, Recorder, Recording, unrecordable

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
                hint="Counts down 3-2-1, then records the hand and the partner's head until Stop.",
            )
            low, high = RATE_RANGE_HZ
            self.rate = gui.add_number("Rate (Hz)", DEFAULT_RATE_HZ, min=low, max=high, step=1.0)
        self.button.on_click(lambda _event: self.press())
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

    # ------------------------------------------------------------------ the loop

    def step(self, now: float) -> None:
        with self._press_lock:
            pressed, self._pressed = self._pressed, False
        phase = self.machine.phase
        if phase is Phase.IDLE:
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

    def _begin(self, now: float) -> None:
        name, rate = self.selected(), float(self.rate.value)
        reason = refusal(name, self.ctx.session.layout, self.ctx.head.source.error, rate)
        event, _ = self.machine.press(now, name, rate, refused=reason)
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

    def _save(self, primitive: str, recording: Recording) -> None:
        session = self.ctx.session
        try:
            values, fill = recording.values(session.layout)
            demo = session.add_demo(primitive, recording.times, values)
        except (ValueError, OSError) as exc:
            self._report(f"Nothing saved: {exc}", "Nothing saved", "red")  # escaped there
            return
        typicality = session.typicality.get((primitive, demo.name))
        text = f"Saved **{demo.name}**: {recording.duration:.1f} s, {recording.n_samples} samples"
        if typicality is not None:
            flag = "" if typicality.label == "typical" else "⚠ "
            text += ", " + colored(
                flag + typicality_text(typicality), TYPICALITY_COLORS[typicality.label], True
            )
        else:
            text += ", typicality: needs 3 earlier demonstrations"
        if fill.n_filled:
            text += f" ({fill.message})"
        self.select(primitive)
        color = NOTIFY_COLORS[typicality.label] if typicality is not None else "green"
        body = text.replace("**", "")
        if typicality is not None:
            body = f"{demo.name}: {typicality_text(typicality)} compared with the others"
        self.last_message = text
        self.show_idle()
        self.ctx.notify("Demonstration saved", body, color)

    def _report(self, text: str, title: str, color: str) -> None:
        self.last_message = colored(escape(text), RED if color == "red" else ORANGE)
        self.show_idle()
        self.ctx.notify(title, text, color)
