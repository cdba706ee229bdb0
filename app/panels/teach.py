"""The Teach tab (issue 7): primitives, the head source, recording, demonstrations, learning.

Top to bottom: **Primitive** (select; create, rename, recolour; delete after a confirm step),
**Record** (Record / Stop with a 3-2-1 countdown; a :class:`app.recorder.Recorder` samples the
hand and the head at a fixed rate; the demonstration is written to the workspace when it
stops, then scored for typicality), **Head source** (simulated partner, camera, video file or
an uploaded video; a failing source is a red message while the rest keeps working; neutral-pose
calibration and a live preview for cameras), **Demonstrations** of the selected primitive
(newest first: show/hide, delete, typicality), **Learn** (basis functions, width, covariance
shrinkage, fit time) and the **prior** of the selected primitive, one uPlot chart per dimension
(mean +- 2 sd), with the newest demonstration, or the one being recorded, drawn over it.

Threading follows STYLE.md's dirty-flag pattern: a GUI callback either makes one session
mutation (validated and written to disk by the session, shared by every tab; a bad input is a
notification to the client who made it and changes nothing) or records an intent (Record
clicked, a slider moved). :meth:`TeachPanel.step`, run by the studio's loop, is the only place
that rebuilds widgets, drives the recording and redraws the plots, so every tab shows the same
state.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
import viser

from app.display import quantities
from app.exchange import format_size
from app.gui_text import GREEN, ORANGE, RED, colored, escape
from app.head_sources import HeadSource, SimulatedPartner, StreamHeadSource, TrackHeadSource
from app.plots import Band, Trace, add_band_chart, band_chart, update_band_chart
from app.recorder import DEFAULT_RATE_HZ, Recorder, Recording, unrecordable
from app.upload_guard import UploadGuard
from promp.data import Layout
from promp.inference import predict
from promp.model import Settings
from promp.pipeline import Typicality

if TYPE_CHECKING:
    from app.studio import Studio

COUNTDOWN_S = 3.0
STATUS_PERIOD_S = 0.2  # recording / head status text
LIVE_PLOT_PERIOD_S = 0.25  # prior plots with the demonstration being recorded
PREVIEW_PERIOD_S = 0.1  # camera preview, 10 Hz
PREVIEW_WIDTH = 320
MAX_VIDEO_BYTES = 500 * 2**20  # an uploaded video is held in memory while it is processed
LEARN_DEBOUNCE_S = 0.15  # a slider being dragged refits once it pauses
PLOT_POINTS = 100
NO_PRIMITIVE = "(no primitive)"
SIMULATED, CAMERA, VIDEO, UPLOAD = "Simulated partner", "Camera", "Video file", "Uploaded video"
SOURCES = (SIMULATED, CAMERA, VIDEO, UPLOAD)
SHRINKAGE_CHOICES: dict[str, float | None] = {
    "automatic (pooled prior)": None,
    "1e-6 (span of the demos)": 1e-6,
    "1e-4": 1e-4,
    "1e-3": 1e-3,
    "0.01": 0.01,
    "0.1": 0.1,
    "0.3": 0.3,
}
TYPICALITY_COLORS = {"typical": GREEN, "unusual": ORANGE, "outlier": RED}
NOTIFY_COLORS = {"typical": "green", "unusual": "yellow", "outlier": "red"}


def typicality_text(typicality: Typicality | None) -> str:
    """E.g. ``typical (64th pct)``; '' without a score."""
    if typicality is None:
        return ""
    return f"{typicality.label} ({100 * typicality.percentile:.0f}th pct)"


def shrinkage_label(value: float | None) -> str:
    for label, choice in SHRINKAGE_CHOICES.items():
        if choice is None and value is None:
            return label
        if choice is not None and value is not None and math.isclose(choice, value):
            return label
    return f"{value:g}"


def source_kind(source: HeadSource) -> str:
    """Which entry of the Source dropdown ``source`` is."""
    if isinstance(source, StreamHeadSource):
        return CAMERA if source.name.startswith("camera ") else VIDEO
    if isinstance(source, TrackHeadSource):
        return UPLOAD
    return SIMULATED


@dataclass
class Take:
    """A recording in progress: counting down until ``starts_at``, then ``recorder`` runs."""

    primitive: str
    starts_at: float
    rate_hz: float
    recorder: Recorder | None = None


class TeachPanel:
    """The Teach tab's widgets and logic (see the module docstring)."""

    def __init__(self, studio: Studio, countdown_s: float = COUNTDOWN_S) -> None:
        self.studio = studio
        self.session = studio.session
        self.server = studio.server
        self.countdown_s = countdown_s
        self._intents = threading.Lock()
        self._record_clicked = False
        self._select: str | None = None  # primitive to select at the next refresh
        self._selection_dirty = True
        self._learn_changed_at: float | None = None
        self._pending_delete: str | None = None
        self._pending_demo_delete: tuple[str, str] | None = None
        self.take: Take | None = None
        self.last_message = ""  # the latest recording outcome (also shown in the GUI)
        self._head_refusal = False  # last_message is a refusal because the head source failed
        self._drawn_version = -1
        self._drawn_selection: str | None = None
        self._demo_rows: list[tuple[tuple[str, str], viser.GuiButtonGroupHandle]] = []
        self._demo_signature: tuple | None = None
        self._shown_error: tuple[int, str] | None = None
        self._next_status = 0.0
        self._next_head_status = 0.0
        self._next_live_plot = 0.0
        self._next_preview = 0.0
        self._upload_thread: threading.Thread | None = None
        gui = self.server.gui
        self._build_primitive(gui)
        self._build_record(gui)
        self._build_head(gui)
        self._build_demos(gui)
        self._build_learn(gui)
        self._build_plots(gui)

    # ================================================================== building

    def _build_primitive(self, gui: viser.GuiApi) -> None:
        names = self.session.names()
        with gui.add_folder("Primitive"):
            self.primitive = gui.add_dropdown(
                "Primitive",
                tuple(names) or (NO_PRIMITIVE,),
                hint="The movement being taught; recordings go into it.",
            )
            self.color = gui.add_rgb(
                "Colour", self.session.color(names[0]) if names else (128, 128, 128)
            )
            self.new_name = gui.add_text(
                "Name", "", hint="1-40 letters, digits, '_' or '-', e.g. to_bin_2"
            )
            self.name_actions = gui.add_button_group("", ("Create", "Rename"))
            self.delete = gui.add_button("Delete primitive", color="gray", icon=viser.Icon.TRASH)
            self.confirm_text = gui.add_markdown("", visible=False)
            self.confirm = gui.add_button_group("", ("Yes, delete", "Cancel"), visible=False)

        @self.primitive.on_update
        def _(event) -> None:
            self._selection_dirty = True

        @self.color.on_update
        def _(event) -> None:
            name = self.selected()
            rgb = tuple(int(c) for c in self.color.value)
            if name is None or name not in self.session.names():
                return
            if rgb != tuple(self.session.color(name)):
                self._mutate(event, "recolour", lambda: self.session.recolor_primitive(name, rgb))

        @self.name_actions.on_click
        def _(event) -> None:
            new = self.new_name.value.strip()
            if event.target.value == "Create":
                if self._mutate(event, "create", lambda: self.session.create_primitive(new)):
                    self._select = new
                    self.new_name.value = ""
                return
            old = self.selected()
            if old is None:
                self._tell(event, "Nothing to rename", "Create a primitive first.")
            elif self._mutate(event, "rename", lambda: self.session.rename_primitive(old, new)):
                self._select = new
                self.new_name.value = ""

        @self.delete.on_click
        def _(event) -> None:
            name = self.selected()
            if name is None:
                self._tell(event, "Nothing to delete", "There is no primitive.")
                return
            n = len(self.session.demos.get(name, []))
            self._pending_delete = name
            self.confirm_text.content = (
                f"Delete **{name}** and its {n} demonstration(s)? They move to the "
                "workspace's trash: *Undo delete* brings them back."
            )
            self.confirm_text.visible = True
            self.confirm.visible = True

        @self.confirm.on_click
        def _(event) -> None:
            name, self._pending_delete = self._pending_delete, None
            self.confirm_text.visible = False
            self.confirm.visible = False
            if event.target.value.startswith("Yes") and name is not None:
                self._mutate(event, "delete", lambda: self.session.delete_primitive(name))

    def _build_record(self, gui: viser.GuiApi) -> None:
        with gui.add_folder("Record"):
            self.record_status = gui.add_markdown(self._idle_status())
            self.record = gui.add_button(
                "Record",
                color="red",
                icon=viser.Icon.PLAYER_RECORD_FILLED,
                hint="Counts down 3-2-1, then records the hand and the partner's head until Stop.",
            )
            self.rate = gui.add_number("Rate (Hz)", DEFAULT_RATE_HZ, min=10.0, max=100.0, step=1.0)

        @self.record.on_click
        def _(event) -> None:
            with self._intents:
                self._record_clicked = True

    def _build_head(self, gui: viser.GuiApi) -> None:
        source = self.studio.head_source
        initial, index, path = source_kind(source), 0, ""
        if initial == CAMERA:
            index = int(source.name.removeprefix("camera "))
        elif initial == VIDEO:
            path = source.name.removeprefix("video ")
        self.head_folder = gui.add_folder("Head source")
        with self.head_folder:
            self.source = gui.add_dropdown(
                "Source",
                SOURCES,
                initial_value=initial,
                hint="Where the partner's head pose comes from while recording.",
            )
            self.camera_index = gui.add_number("Camera index", index, min=0, max=63, step=1)
            self.video_path = gui.add_text("Video file", path, hint="Path on the server.")
            self.connect = gui.add_button("Connect", icon=viser.Icon.PLUG)
            self.upload = gui.add_upload_button(
                "Upload a video",
                icon=viser.Icon.UPLOAD,
                mime_type="video/*",
                hint=f"Up to {format_size(MAX_VIDEO_BYTES)}; processed on the server.",
            )
            self._max_video_bytes = MAX_VIDEO_BYTES
            self.video_guard = UploadGuard(
                self.server, self.upload, MAX_VIDEO_BYTES, self._video_refused
            )
            self.head_status = gui.add_markdown("")
            self.calibrate = gui.add_button(
                "Calibrate neutral",
                icon=viser.Icon.FOCUS_CENTERED,
                hint="The partner looks at the robot's eyes: this head pose becomes zero.",
                visible=False,
            )
            self.preview = gui.add_image(
                np.zeros((240, PREVIEW_WIDTH, 3), np.uint8),
                label="Camera",
                jpeg_quality=75,
                visible=False,
            )
        self._show_source_inputs()

        @self.source.on_update
        def _(event) -> None:
            current = source_kind(self.studio.head_source)
            if self.source.value != current and self._recording(event):
                self.source.value = current  # runs this callback again, which changes nothing
                return
            self._show_source_inputs()
            if self.source.value == SIMULATED and current != SIMULATED:
                self._use_source(SimulatedPartner())

        @self.connect.on_click
        def _(event) -> None:
            if self._recording(event):
                return
            if self.source.value == CAMERA:
                self._use_source(StreamHeadSource(int(self.camera_index.value)))
                return
            path = self.video_path.value.strip()
            if not path:
                self._tell(event, "No video file", "Type the path of a video file first.")
                return
            self._use_source(StreamHeadSource(str(Path(path).expanduser())))

        @self.upload.on_upload
        def _(event) -> None:
            if self._recording(event):
                return
            upload = event.target.value
            if len(upload.content) > self.max_video_bytes:  # the guard was bypassed
                self._video_refused(event.client, upload.name, len(upload.content))
                return
            self._start_upload(upload.name, upload.content)

        @self.calibrate.on_click
        def _(event) -> None:
            source = self.studio.head_source
            if isinstance(source, StreamHeadSource) and source.error is None:
                source.calibrate_neutral()
                self._tell(event, "Neutral pose set", "The current head pose is now zero.", "green")

    def _build_demos(self, gui: viser.GuiApi) -> None:
        self.demo_folder = gui.add_folder("Demonstrations")
        with self.demo_folder:
            self.demo_summary = gui.add_markdown("")
            self.undo_delete = gui.add_button(
                "Undo delete",
                icon=viser.Icon.ARROW_BACK_UP,
                visible=False,
                hint="Bring back the latest deleted demonstration or primitive from the trash",
            )
            self.demo_confirm_text = gui.add_markdown("", visible=False)
            self.demo_confirm = gui.add_button_group(
                "", ("Delete demonstration", "Keep it"), visible=False
            )

        @self.undo_delete.on_click
        def _(event) -> None:
            def undo() -> None:
                entry = self.session.undo_delete()
                self._tell(event, "Restored", f"{entry.label} is back.", "green")

            self._mutate(event, "undo", undo)

        @self.demo_confirm.on_click
        def _(event) -> None:
            pending, self._pending_demo_delete = self._pending_demo_delete, None
            self.demo_confirm_text.visible = self.demo_confirm.visible = False
            if pending is None or event.target.value != "Delete demonstration":
                return
            primitive, demo = pending
            if self._mutate(event, "delete", lambda: self.session.delete_demo(primitive, demo)):
                self._tell(
                    event, "Deleted",
                    f"{demo} moved to the workspace's trash (Undo delete brings it back).",
                    "gray",
                )  # fmt: skip

    def _build_learn(self, gui: viser.GuiApi) -> None:
        settings = self.session.learning_settings()
        with gui.add_folder("Learn"):
            self.n_basis = gui.add_slider(
                "Basis functions", 4, 30, 1, int(settings.n_basis), hint="M per dimension"
            )
            self.width = gui.add_slider(
                "Width",
                0.5,
                3.0,
                0.1,
                float(settings.width),
                hint="RBF width, in multiples of the spacing of the centres",
            )
            label = shrinkage_label(settings.shrinkage)
            options = tuple(SHRINKAGE_CHOICES)
            self.shrinkage = gui.add_dropdown(
                "Shrinkage",
                options if label in options else (*options, label),
                initial_value=label,
                hint="Regularisation of the weight covariance (towards a scaled identity)",
            )
            self.fit_status = gui.add_markdown("")

        for handle in (self.n_basis, self.width, self.shrinkage):

            @handle.on_update
            def _(event) -> None:
                self._learn_changed_at = time.monotonic()

    def _build_plots(self, gui: viser.GuiApi) -> None:
        self.plot_folder = gui.add_folder("Prior")
        self.plots: list[viser.GuiUplotHandle] = []
        self._plots_layout: Layout | None = None
        with self.plot_folder:
            self.plot_note = gui.add_markdown("")
        self._build_charts(self.session.layout)

    def _build_charts(self, layout: Layout) -> None:
        """One prior chart per dimension of ``layout`` (rebuilt when the workspace changes)."""
        for plot in self.plots:
            plot.remove()
        placeholder = band_chart([], [Trace("", np.array([0.0, 1.0]), np.zeros(2), (0, 0, 0))])
        with self.plot_folder:
            self.plots = [
                add_band_chart(self.server.gui, placeholder, title=q.title)
                for q in quantities(layout)
            ]
        self._plots_layout = layout
        self._show_recordable(layout)

    def _show_recordable(self, layout: Layout) -> None:
        """The head source only matters when the workspace has a head; recording only when
        the studio can sample every modality."""
        self.head_folder.visible = "head" in layout.names

    # ================================================================== callbacks' helpers

    def selected(self) -> str | None:
        """The selected primitive's name (None when there is none)."""
        value = self.primitive.value
        return None if value == NO_PRIMITIVE else value

    def _tell(self, event, title: str, body: str, color: str = "red") -> None:
        """A notification to the client behind ``event`` (every client when unknown)."""
        self.studio.notify(title, body, color, client=getattr(event, "client", None))

    def _mutate(self, event, what: str, action) -> bool:
        """Run one session mutation; a refusal is a notification, and nothing changes."""
        try:
            action()
        except (ValueError, OSError) as exc:
            self._tell(event, f"Cannot {what}", str(exc))
            return False
        return True

    def _recording(self, event) -> bool:
        """True (and a notification) while a recording is under way: its head source stays."""
        if self.take is None:
            return False
        self._tell(event, "Recording", "Stop the recording before changing the head source.")
        return True

    def _use_source(self, source: HeadSource) -> None:
        self.studio.set_head_source(source)
        if self._head_refusal:  # "the head source failed" no longer holds
            self.last_message, self._head_refusal = "", False
            self.record_status.content = self._idle_status()
        self._shown_error = None
        self._next_head_status = 0.0

    def _show_source_inputs(self) -> None:
        kind = self.source.value
        self.camera_index.visible = kind == CAMERA
        self.video_path.visible = kind == VIDEO
        self.connect.visible = kind in (CAMERA, VIDEO)
        self.upload.visible = kind == UPLOAD

    def _video_refused(self, client, filename: str, size: int) -> None:
        title = f"Cannot use the video {filename}"
        body = (
            f"The file is {format_size(size)}, over the {format_size(self.max_video_bytes)} "
            "limit for an uploaded video. Trim it, or give its path as a video file."
        )
        self.studio.notify(title, body, "red", client=client)

    @property
    def max_video_bytes(self) -> int:
        return self._max_video_bytes

    @max_video_bytes.setter
    def max_video_bytes(self, value: int) -> None:
        self._max_video_bytes = self.video_guard.max_bytes = int(value)

    def close(self) -> None:
        self.video_guard.close()

    def _start_upload(self, name: str, content: bytes) -> None:
        if self._upload_thread is not None and self._upload_thread.is_alive():
            self.studio.notify("Busy", "Another video is still being processed.", "yellow")
            return
        suffix = Path(name).suffix or ".mp4"

        def work() -> None:
            from app.headpose import track_video

            def progress(fraction: float) -> None:
                self.head_status.content = f"Processing **{escape(name)}**: {100 * fraction:.0f} %"

            try:
                track = track_video(content, progress=progress, suffix=suffix)
                if not track.face_found.any():
                    raise ValueError(f"no face found in {name}")
                source = TrackHeadSource(track.t, track.angles, track.face_found, name)
            except Exception as exc:  # any decoding failure is a message, not a crash
                message = f"uploaded video {name}: {exc}"
                self.head_status.content = colored(escape(message), RED)
                self.studio.notify("Video not usable", message, "red")
                return
            self._use_source(source)
            found = 100 * float(np.mean(track.face_found))
            self.studio.notify(
                "Video ready", f"{name}: {len(track)} frames, face in {found:.0f} %", "green"
            )

        self.head_status.content = f"Processing **{escape(name)}**..."
        self._upload_thread = threading.Thread(target=work, name="upload-video", daemon=True)
        self._upload_thread.start()

    # ================================================================== the loop

    def step(self) -> None:
        """Recompute what changed (called by the studio's loop at every iteration)."""
        now = time.monotonic()
        self._step_record(now)
        self._step_head(now)
        self._step_learn(now)
        self._refresh()

    # ------------------------------------------------------------------ recording

    def _idle_status(self) -> str:
        name = self.selected() if hasattr(self, "primitive") else None
        missing = unrecordable(self.session.layout)
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

    def _set_record_button(self, label: str, color: str, icon) -> None:
        self.record.label = label
        self.record.color = color
        self.record.icon = icon

    def _step_record(self, now: float) -> None:
        with self._intents:
            clicked, self._record_clicked = self._record_clicked, False
        take = self.take
        if take is None:
            if clicked:
                self._begin(now)
            return
        if take.recorder is None:  # counting down
            if clicked:
                self.take = None
                self._finish_ui("Recording cancelled.")
            elif now >= take.starts_at:
                take.recorder = Recorder(self.studio.hand_and_head, take.rate_hz)
                take.recorder.start()
                self._set_record_button("Stop", "red", viser.Icon.PLAYER_STOP_FILLED)
                self._show_recording(take)
            else:
                remaining = math.ceil(take.starts_at - now)
                self.record_status.content = (
                    f'<div style="text-align:center;font-size:2.4em;font-weight:700;'
                    f'color:{RED}">{remaining}</div>'
                )
            return
        if clicked or take.recorder.error is not None:
            self._stop(take)
            return
        if now >= self._next_status:
            self._next_status = now + STATUS_PERIOD_S
            self._show_recording(take)
        if now >= self._next_live_plot:
            self._next_live_plot = now + LIVE_PLOT_PERIOD_S
            self._draw_plots(take.primitive, live=take.recorder.snapshot())

    def _begin(self, now: float) -> None:
        name = self.selected()
        error = None
        missing = unrecordable(self.session.layout)
        if name is None:
            error = "Create a primitive first: a demonstration belongs to one."
        elif missing:
            error = (
                f"This workspace's demonstrations also hold {', '.join(missing)}, which the "
                "studio cannot record: a new demonstration would lack them. Record in a "
                "workspace of hand and head demonstrations."
            )
        elif "head" in self.session.layout.names and self.studio.head_source.error is not None:
            error = (
                f"The head source failed ({self.studio.head_source.error}). Choose another "
                "head source (e.g. the simulated partner) to record."
            )
        rate = float(self.rate.value)
        if error is None and not 10.0 <= rate <= 100.0:
            error = f"The rate must be within 10-100 Hz, got {rate:g}."
        if error is not None:
            self._report(error, "Cannot record", "red")
            self._head_refusal = error.startswith("The head source failed")
            return
        self.last_message, self._head_refusal = "", False
        self.take = Take(name, now + self.countdown_s, rate)
        self._set_record_button("Cancel", "gray", viser.Icon.X)

    def _show_recording(self, take: Take) -> None:
        recording = take.recorder.snapshot() if take.recorder is not None else None
        if recording is None or recording.n_samples == 0:
            duration, n, face = 0.0, 0, 100.0
        else:
            duration, n = recording.duration, recording.n_samples
            face = 100.0 * float(recording.face.mean())
        face_text = f"face {face:.0f} %"
        if face < 100.0:
            face_text = colored(face_text, ORANGE)
        self.record_status.content = (
            colored("● Recording", RED, bold=True)
            + f" into **{take.primitive}**: {duration:.1f} s, {n} samples, {face_text}"
        )

    def _stop(self, take: Take) -> None:
        """End the recording and save it (or say why not)."""
        recording = take.recorder.stop()
        self.take = None
        if take.recorder.error is not None:
            self._finish_ui()
            self._report(f"The recording failed: {take.recorder.error}", "Nothing saved", "red")
            return
        self._finish_ui()
        self._save(take.primitive, recording)

    def _finish_ui(self, message: str | None = None) -> None:
        self._set_record_button("Record", "red", viser.Icon.PLAYER_RECORD_FILLED)
        if message is not None:
            self.last_message = message
            self.record_status.content = self._idle_status()
        self._selection_dirty = True  # redraw the plots without the live recording

    def _save(self, primitive: str, recording: Recording) -> None:
        try:
            values, fill = recording.values(self.session.layout)
            demo = self.session.add_demo(primitive, recording.times, values)
        except (ValueError, OSError) as exc:
            self._report(f"Nothing saved: {exc}", "Nothing saved", "red")  # escaped there
            return
        typicality = self.session.typicality.get((primitive, demo.name))
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
        self._select = primitive
        color = NOTIFY_COLORS[typicality.label] if typicality is not None else "green"
        body = text.replace("**", "")
        if typicality is not None:
            body = f"{demo.name}: {typicality_text(typicality)} compared with the others"
        self.last_message = text
        self.record_status.content = self._idle_status()
        self.studio.notify("Demonstration saved", body, color)

    def _report(self, text: str, title: str, color: str) -> None:
        self.last_message = colored(escape(text), RED if color == "red" else ORANGE)
        self.record_status.content = self._idle_status()
        self.studio.notify(title, text, color)

    # ------------------------------------------------------------------ head source

    def _step_head(self, now: float) -> None:
        source = self.studio.head_source
        error = source.error
        if error is not None and (id(source), error) != self._shown_error:
            self._shown_error = (id(source), error)
            self.studio.notify(
                "Head source failed",
                f"{error}. The rest of the studio keeps working; choose another source.",
                "red",
            )
        is_stream = isinstance(source, StreamHeadSource)
        self.calibrate.visible = is_stream and error is None
        if is_stream and error is None and now >= self._next_preview:
            self._next_preview = now + PREVIEW_PERIOD_S
            image = source.preview()
            if image is not None:
                height = max(1, round(image.shape[0] * PREVIEW_WIDTH / image.shape[1]))
                self.preview.image = cv2.resize(image, (PREVIEW_WIDTH, height))
                self.preview.visible = True
        elif not is_stream or error is not None:
            self.preview.visible = False
        busy = self._upload_thread is not None and self._upload_thread.is_alive()
        if now < self._next_head_status or busy:
            return
        self._next_head_status = now + STATUS_PERIOD_S
        if error is not None:
            text = colored(f"⚠ {escape(error)}", RED, bold=True) + (
                "  \nThe rest of the studio keeps working: choose another source."
            )
        elif self.studio.head.angles is None:
            text = f"**{escape(source.name)}**: " + colored("no face", ORANGE)
        else:
            roll, pitch, yaw = np.degrees(self.studio.head.angles)
            text = (
                f"**{escape(source.name)}**: "
                + colored("tracking", GREEN)
                + f" (roll {roll:+.0f}°, pitch {pitch:+.0f}°, yaw {yaw:+.0f}°)"
            )
        self.head_status.content = text

    # ------------------------------------------------------------------ learning

    def _step_learn(self, now: float) -> None:
        changed = self._learn_changed_at
        if changed is None or now - changed < LEARN_DEBOUNCE_S:
            return
        self._learn_changed_at = None
        current = self.session.learning_settings()
        n_basis = int(self.n_basis.value)
        width = round(float(self.width.value), 3)
        shrinkage = SHRINKAGE_CHOICES.get(self.shrinkage.value, current.shrinkage)
        same = (
            n_basis == current.n_basis
            and math.isclose(width, current.width)
            and (
                shrinkage == current.shrinkage
                or (shrinkage is not None and current.shrinkage is not None
                    and math.isclose(shrinkage, current.shrinkage))
            )
        )  # fmt: skip
        if same:
            return
        try:
            self.session.set_learning(n_basis, width, shrinkage=shrinkage)
        except (ValueError, OSError) as exc:
            self.studio.notify("Cannot change the learning settings", str(exc), "red")
            self._show_learning(self.session.learning_settings())

    def _show_learning(self, settings: Settings) -> None:
        self.n_basis.value = int(settings.n_basis)
        self.width.value = float(settings.width)
        label = shrinkage_label(settings.shrinkage)
        if label not in self.shrinkage.options:
            self.shrinkage.options = (*self.shrinkage.options, label)
        self.shrinkage.value = label
        self._learn_changed_at = None  # these assignments ran the callbacks

    # ------------------------------------------------------------------ redrawing

    def _refresh(self) -> None:
        session = self.session
        version = session.version
        if version == self._drawn_version and not self._selection_dirty and self._select is None:
            return
        self._selection_dirty = False
        with session.lock:
            names = session.names()
            select, self._select = self._select, None
        options = tuple(names) or (NO_PRIMITIVE,)
        if tuple(self.primitive.options) != options:
            self.primitive.options = options
        if select is not None and select in names:
            self.primitive.value = select
        name = self.selected()
        if name != self._drawn_selection and self._pending_delete is not None:
            self._pending_delete = None
            self.confirm.visible = self.confirm_text.visible = False
        if name is not None and name in names:
            self.color.value = session.color(name)
        if version != self._drawn_version:
            if session.layout != self._plots_layout:
                self._build_charts(session.layout)
            if self._learn_changed_at is None:  # never undo a slider the user is moving
                self._show_learning(session.learning_settings())
            self._show_fit()
            self.undo_delete.visible = bool(session.deleted)
            if session.deleted:
                self.undo_delete.label = f"Undo delete ({session.deleted[-1].label})"
        self._drawn_version = version
        self._drawn_selection = name
        self._show_demos(name)
        if self.take is None or self.take.recorder is None:
            self._draw_plots(name)
        if self.take is None:
            self.record_status.content = self._idle_status()

    def _show_fit(self) -> None:
        session = self.session
        n_demos = sum(len(d) for d in session.demos.values())
        if session.fit_error is not None and session.model is None:
            self.fit_status.content = colored(f"Not learned: {escape(session.fit_error)}", ORANGE)
            return
        color = GREEN if session.fit_ms < 100.0 else ORANGE
        text = colored(f"Fit in {session.fit_ms:.0f} ms", color, bold=True)
        n_learned = len(session.model.names) if session.model is not None else 0
        self.fit_status.content = (
            f"{text}: {n_learned} primitive(s) learned from {n_demos} demonstrations."
        )
        if session.fit_error is not None:
            self.fit_status.content += "  \n" + colored(escape(session.fit_error), ORANGE)

    def _show_demos(self, name: str | None) -> None:
        session = self.session
        with session.lock:
            demos = list(session.demos.get(name, [])) if name is not None else []
            rows = tuple(
                (
                    d.name,
                    d.duration,
                    (name, d.name) in session.hidden,
                    session.typicality.get((name, d.name)),
                )
                for d in reversed(demos)  # newest first
            )
        signature = (name, rows)
        if signature == self._demo_signature:
            return
        self._demo_signature = signature
        flagged = [r[0] for r in rows if r[3] is not None and r[3].label != "typical"]
        if name is None:
            summary = "No primitive."
        elif not rows:
            summary = f"No demonstration of **{name}** yet: press Record."
        else:
            summary = f"{len(rows)} demonstration(s) of **{name}**, newest first."
            if flagged:
                summary += "  \n" + colored("⚠ To check: " + ", ".join(flagged), ORANGE, True)
        self.demo_summary.content = summary
        # Same demonstrations in the same order: update the rows in place (a click on a row
        # being rebuilt would be lost); otherwise rebuild the list.
        keys = [(name, r[0]) for r in rows]
        if keys != [key for key, _ in self._demo_rows]:
            for _, handle in self._demo_rows:
                handle.remove()
            self._demo_rows = []
            with self.demo_folder:
                for demo_name, duration, *_ in rows:
                    handle = self.server.gui.add_button_group(
                        demo_name,
                        ("Hide", "Delete"),
                        hint=f"{demo_name}: {duration:.1f} s. Show or hide its line in the 3D "
                        "view, or delete it from the workspace.",
                    )
                    handle.on_click(self._demo_action(name, demo_name))
                    self._demo_rows.append(((name, demo_name), handle))
        for (demo_name, _, hidden, typicality), (_, handle) in zip(
            rows, self._demo_rows, strict=True
        ):
            label = demo_name
            if typicality is not None:
                flag = "" if typicality.label == "typical" else "⚠ "
                label += f" · {flag}{typicality_text(typicality)}"
            if hidden:
                label += " · hidden"
            handle.label = label
            handle.options = ("Show" if hidden else "Hide", "Delete")

    def _demo_action(self, primitive: str, demo: str):
        def action(event) -> None:
            choice = event.target.value
            if choice == "Delete":
                self._pending_demo_delete = (primitive, demo)
                self.demo_confirm_text.content = (
                    f"Delete **{demo}** of **{primitive}**? It moves to the workspace's trash: "
                    "*Undo delete* brings it back."
                )
                self.demo_confirm_text.visible = self.demo_confirm.visible = True
            else:
                hide = choice == "Hide"
                self._mutate(event, "hide", lambda: self.session.set_hidden(primitive, demo, hide))

        return action

    def _draw_plots(self, name: str | None, live: Recording | None = None) -> None:
        """The prior of ``name`` per dimension, with its newest demonstration (or ``live``)."""
        session = self.session
        with session.lock:
            model = session.model
            demos = list(session.demos.get(name, [])) if name is not None else []
            color = session.color(name) if name in session.names() else (128, 128, 128)
        prediction = None
        if model is not None and name in model.names:
            prim = model.primitive(name)
            prediction = predict(model, prim, float(np.exp(prim.log_alpha_mean)), PLOT_POINTS)
        layout = session.layout
        if layout != self._plots_layout:
            self._build_charts(layout)
        traces: list[tuple[str, np.ndarray, np.ndarray, tuple[int, int, int]]] = []
        if live is not None and live.n_samples >= 2:
            blocks = {"hand": live.hand, "head": live.head}
            columns = np.column_stack([blocks[m] for m in layout.names if m in blocks])
            traces.append(("the recording", live.times, columns, (20, 20, 20)))
        elif demos:
            newest = demos[-1]
            traces.append((newest.name, newest.times, layout.extract(newest), (70, 70, 70)))
        if prediction is None and not traces:
            self.plot_folder.label = "Prior"
            self.plot_note.content = (
                "Record at least two demonstrations to learn a prior."
                if name is not None
                else "No primitive."
            )
            for plot in self.plots:
                plot.visible = False
            return
        self.plot_folder.label = f"Prior of {name}: mean ± 2σ"
        if prediction is None:
            self.plot_note.content = "Record at least two demonstrations to learn a prior."
        elif traces:
            self.plot_note.content = f"Band: the prior. Line: {traces[0][0]}."
        else:
            self.plot_note.content = "Band: the prior."
        for dim, plot in zip(quantities(layout), self.plots, strict=True):
            bands = []
            if prediction is not None:
                bands.append(
                    Band(
                        name,
                        prediction.times,
                        dim.scale * prediction.mean[:, dim.column],
                        dim.scale * prediction.std[:, dim.column],
                        color,
                    )
                )
            lines = []
            for label, times, columns, line_color in traces:
                if dim.column >= columns.shape[1]:
                    continue
                values = dim.scale * columns[:, dim.column]
                ok = np.isfinite(values)  # a live head column has no angle without a face
                if ok.sum() >= 1:
                    lines.append(Trace(label, times[ok], values[ok], line_color, width=1.5))
            if not bands and not lines:
                plot.visible = False
                continue
            update_band_chart(self.server, plot, band_chart(bands, lines))
            plot.visible = True
