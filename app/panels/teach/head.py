"""The Teach tab's Head source folder: where the partner's head pose comes from.

A simulated partner, a camera (by index), a video file on the server, or a video uploaded from
the browser (processed in the background into a head-pose track by
:func:`app.headpose.track_video`). Choosing one makes it the studio's head source
(:meth:`app.live.head.HeadInput.use`), except during a recording, whose source stays. The
Source shown is the one in use whichever way it came (a video uploaded, a camera or a video
given on the command line): :meth:`HeadSection.step` sets the dropdown, the camera index or
the video's path to it whenever the source in use changes, and the status line names it. A
source that fails is a red message and a notification; the rest of the studio keeps working.
Cameras and videos get a live preview and *Calibrate neutral*. The folder is shown only when
the workspace has a ``head`` modality.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import viser

from app.io.exchange import format_size
from app.live.head import HeadSource, SimulatedPartner, StreamHeadSource, TrackHeadSource
from app.ui.context import Frame, PanelContext, PanelGui
from app.ui.display import shown
from app.ui.text import GREEN, ORANGE, RED, colored, escape
from robots.icub.layout import HEAD

STATUS_PERIOD_S = 0.2  # the head's status line
PREVIEW_PERIOD_S = 0.1  # camera preview, 10 Hz
PREVIEW_WIDTH = 320
MAX_VIDEO_BYTES = 500 * 2**20  # an uploaded video is held in memory while it is processed
SIMULATED, CAMERA, VIDEO, UPLOAD = "Simulated partner", "Camera", "Video file", "Uploaded video"
SOURCES = (SIMULATED, CAMERA, VIDEO, UPLOAD)


def source_kind(source: HeadSource) -> str:
    """Which entry of the Source dropdown ``source`` is."""
    if isinstance(source, StreamHeadSource):
        return CAMERA if source.name.startswith("camera ") else VIDEO
    if isinstance(source, TrackHeadSource):
        return UPLOAD
    return SIMULATED


def angles_text(angles: np.ndarray) -> str:
    """E.g. ``roll +3°, pitch -2°, yaw +10°`` (angles in radians)."""
    return ", ".join(
        f"{name} {shown(float(value), HEAD, digits=0, signed=True)}"
        for name, value in zip(HEAD.columns, angles, strict=True)
    )


@dataclass(frozen=True, eq=False)
class HeadControls:
    """The handles of the Head source folder."""

    folder: viser.GuiFolderHandle
    source: viser.GuiDropdownHandle
    camera_index: viser.GuiNumberHandle
    video_path: viser.GuiTextHandle
    connect: viser.GuiButtonHandle
    upload: viser.GuiUploadButtonHandle
    status: viser.GuiMarkdownHandle
    calibrate: viser.GuiButtonHandle
    preview: viser.GuiImageHandle

    def show_inputs(self) -> None:
        """The inputs of the source kind chosen. (viser's page shows an upload button whatever
        its ``visible``: it is disabled too.)"""
        kind = self.source.value
        self.camera_index.visible = kind == CAMERA
        self.video_path.visible = kind == VIDEO
        self.connect.visible = kind in (CAMERA, VIDEO)
        self.upload.visible = kind == UPLOAD
        self.upload.disabled = kind != UPLOAD

    def follow(self, source: HeadSource) -> None:
        """Show ``source``, the one now in use: its kind, its camera's index or its video's
        path."""
        kind = source_kind(source)
        if kind == CAMERA:
            self.camera_index.value = int(source.name.removeprefix("camera "))
        elif kind == VIDEO:
            self.video_path.value = source.name.removeprefix("video ")
        if self.source.value != kind:
            self.source.value = kind  # its callback shows the kind's inputs


def build_controls(gui: PanelGui, source: HeadSource) -> HeadControls:
    initial = source_kind(source)
    folder = gui.add_folder("Head source")
    with folder:
        controls = HeadControls(
            folder=folder,
            source=gui.add_dropdown(
                "Source", SOURCES, initial_value=initial,
                hint="Where the partner's head pose comes from while recording.",
            ),
            camera_index=gui.add_number("Camera index", 0, min=0, max=63, step=1),
            video_path=gui.add_text("Video file", "", hint="Path on the server."),
            connect=gui.add_button("Connect", icon=viser.Icon.PLUG),
            upload=gui.add_upload_button(
                "Upload a video", icon=viser.Icon.UPLOAD, mime_type="video/*",
                hint=f"Up to {format_size(MAX_VIDEO_BYTES)}; processed on the server.",
            ),
            status=gui.add_markdown(""),
            calibrate=gui.add_button(
                "Calibrate neutral", icon=viser.Icon.FOCUS_CENTERED, visible=False,
                hint="The partner looks at the robot's eyes: this head pose becomes zero.",
            ),
            preview=gui.add_image(
                np.zeros((240, PREVIEW_WIDTH, 3), np.uint8), label="Camera", jpeg_quality=75,
                visible=False,
            ),
        )  # fmt: skip
    controls.follow(source)
    controls.show_inputs()
    return controls


class VideoTracks:
    """Uploaded videos tracked into head-pose tracks, one at a time, in the background."""

    def __init__(self) -> None:
        self._pool: ThreadPoolExecutor | None = None
        self.job: Future | None = None

    @property
    def processing(self) -> bool:
        return self.job is not None and not self.job.done()

    def process(self, job: Callable[[], None]) -> None:
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="upload-video")
        self.job = self._pool.submit(job)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)


class HeadSection:
    """The Head source folder (see the module docstring).

    Parameters
    ----------
    ctx : PanelContext
    recording : callable
        True while a recording is under way (its head source must stay).
    """

    def __init__(self, ctx: PanelContext, recording: Callable[[], bool]):
        self.ctx = ctx
        self.recording = recording
        self.tracks = VideoTracks()
        self._shown_error: tuple[int, str] | None = None
        self._followed: HeadSource = ctx.head.source  # the source the controls show
        self._next = (0.0, 0.0)  # when the status line and the preview are due
        self.controls = c = build_controls(ctx.gui, ctx.head.source)
        self.video_guard = ctx.guard_upload(c.upload, MAX_VIDEO_BYTES, self._refused)
        c.source.on_update(self._source_chosen)
        c.connect.on_click(self._connect)
        c.upload.on_upload(self._uploaded)
        c.calibrate.on_click(self._calibrate)

    # ------------------------------------------------------------------ callbacks

    def _refuse_while_recording(self, event) -> bool:
        """True (and a notification) while a recording is under way: its head source stays."""
        if not self.recording():
            return False
        self.ctx.tell(event, "Recording", "Stop the recording before changing the head source.")
        return True

    def _source_chosen(self, event) -> None:
        c, current = self.controls, source_kind(self.ctx.head.source)
        if c.source.value != current and self._refuse_while_recording(event):
            c.source.value = current  # runs this callback again, which changes nothing
            return
        c.show_inputs()
        if c.source.value == SIMULATED and current != SIMULATED:
            self._use(SimulatedPartner())

    def _connect(self, event) -> None:
        if self._refuse_while_recording(event):
            return
        c = self.controls
        if c.source.value == CAMERA:
            self._use(StreamHeadSource(int(c.camera_index.value)))
            return
        path = c.video_path.value.strip()
        if not path:
            self.ctx.tell(event, "No video file", "Type the path of a video file first.")
            return
        self._use(StreamHeadSource(str(Path(path).expanduser())))

    def _uploaded(self, event) -> None:
        if self._refuse_while_recording(event):
            return
        upload = event.target.value
        if len(upload.content) > self.video_guard.max_bytes:  # the guard was bypassed
            self.video_guard.dismiss(event.client)
            self._refused(event.client, upload.name, len(upload.content))
            return
        self.process(upload.name, upload.content, event.client)

    def process(self, name: str, content: bytes, client=None) -> None:
        """Track the head in an uploaded video in the background, then use the track."""
        if self.tracks.processing:
            self.ctx.notify("Busy", "Another video is still being processed.", "yellow")
            return
        self.controls.status.content = f"Processing **{escape(name)}**..."
        self.tracks.process(lambda: self._track(name, content, client))

    def _calibrate(self, event) -> None:
        source = self.ctx.head.source
        if isinstance(source, StreamHeadSource) and source.error is None:
            source.calibrate_neutral()
            self.ctx.tell(event, "Neutral pose set", "The current head pose is now zero.", "green")

    def _use(self, source: HeadSource) -> None:
        self.ctx.head.use(source)
        self._shown_error = None
        self._next = (0.0, 0.0)

    def _refused(self, client, filename: str, size: int) -> None:
        title = f"Cannot use the video {filename}"
        body = (
            f"The file is {format_size(size)}, over the {format_size(self.video_guard.max_bytes)} "
            "limit for an uploaded video. Trim it, or give its path as a video file."
        )
        self.ctx.notify(title, body, "red", client=client)

    def _track(self, name: str, content: bytes, client=None) -> None:
        """Track the head in an uploaded video (a worker), then use the track."""
        from app.headpose import track_video  # OpenCV's DNN models: loaded when first needed

        status = self.controls.status

        def progress(fraction: float) -> None:
            status.content = f"Processing **{escape(name)}**: {100 * fraction:.0f} %"

        try:
            track = track_video(content, progress=progress, suffix=Path(name).suffix or ".mp4")
            if not track.face_found.any():
                raise ValueError(f"no face found in {name}")
            source = TrackHeadSource(track.t, track.angles, track.face_found, name)
        except Exception as exc:  # any decoding failure is a message, not a crash
            message = f"uploaded video {name}: {exc}"
            status.content = colored(escape(message), RED)
            self.video_guard.dismiss(client)  # not under an "uploaded successfully" toast
            self.ctx.notify("Video not usable", message, "red")
            return
        self._use(source)
        found = 100 * float(np.mean(track.face_found))
        self.ctx.notify(
            "Video ready", f"{name}: {len(track)} frames, face in {found:.0f} %", "green"
        )

    # ------------------------------------------------------------------ the frame

    def step(self, frame: Frame) -> None:
        c, source, error = self.controls, self.ctx.head.source, frame.head_error
        if source is not self._followed:  # a new source in use, whoever chose it
            self._followed = source
            c.follow(source)
        visible = HEAD.name in frame.snapshot.store.layout.names  # a workspace with a head
        if c.folder.visible != visible:
            c.folder.visible = visible
        if error is not None and (id(source), error) != self._shown_error:
            self._shown_error = (id(source), error)
            self.ctx.notify(
                "Head source failed",
                f"{error}. The rest of the studio keeps working; choose another source.",
                "red",
            )
        next_status, next_preview = self._next
        is_stream = isinstance(source, StreamHeadSource)
        c.calibrate.visible = is_stream and error is None
        if is_stream and error is None and frame.now >= next_preview:
            next_preview = frame.now + PREVIEW_PERIOD_S
            image = source.preview()
            if image is not None:
                height = max(1, round(image.shape[0] * PREVIEW_WIDTH / image.shape[1]))
                c.preview.image = cv2.resize(image, (PREVIEW_WIDTH, height))
                c.preview.visible = True
        elif not is_stream or error is not None:
            c.preview.visible = False
        if frame.now >= next_status and not self.tracks.processing:
            next_status = frame.now + STATUS_PERIOD_S
            c.status.content = self._status(source, error, frame.head)
        self._next = (next_status, next_preview)

    def _status(self, source: HeadSource, error: str | None, angles) -> str:
        if error is not None:
            return colored(f"⚠ {escape(error)}", RED, bold=True) + (
                "  \nThe rest of the studio keeps working: choose another source."
            )
        if angles is None:
            return f"**{escape(source.name)}**: " + colored("no face", ORANGE)
        return (
            f"**{escape(source.name)}**: " + colored("tracking", GREEN)
            + f" ({angles_text(angles)})"
        )  # fmt: skip

    def close(self) -> None:
        self.video_guard.close()
        self.tracks.close()
