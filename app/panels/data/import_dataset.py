"""The Data tab's "Import dataset": a zip of one's own recordings becomes a studio workspace.

Upload a zip of a dataset folder (:mod:`app.io.dataset_import`: CSV, lab records, or a rig's
recordings: YARP dumps, ROS bags, XDF, C3D), or a single session file (a bag, ``.xdf``,
``.c3d``); the studio extracts it into a temporary folder of its own, guesses the format and the
modalities from the files (the streams), and previews what it would create, with every
demonstration found and where it comes from. The user may change the format, the mapping of
columns (``hand=x,y,z``, one modality per line) or of streams
(``hand=/pose:pose.position.{x,y,z}``) to modalities (:mod:`app.panels.data.import_inputs`), and
for recordings how sessions are cut and the rate of the time base; each change re-reads and
re-previews. A hand mostly out of the iCub's reach is said so, and the user places it in the
iCub's frame or keeps it in its own (:mod:`app.panels.data.import_frame`). Then either

* **Create workspace** makes a new workspace folder beside the current one (named after the
  zip) and the studio serves it; the current workspace stays as it is on disk; or
* **Replace this workspace**, after a confirmation, puts the imported content in the current
  workspace, whose demonstrations go to its trash (restorable).

A refused upload or mapping is a notification naming the file and the problem, and changes
nothing (the notifications of refused files go when a later file is accepted); the preview
always shows the latest upload: a refused one is not previewed, nor is the one before it. A
dataset refused with guessed modalities gets the guess in the modalities' field all the same,
to edit.
"""

from __future__ import annotations

import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import viser

from app.io.dataset_import import (
    MAX_DATASET_UPLOAD_BYTES,
    SESSION_FILES,
    DatasetSummary,
    DatasetUpload,
    extract_dataset_zip,
    safe_name,
)
from app.io.dataset_import import placed as placed_data
from app.io.exchange import Limits, format_size
from app.io.hand_frame import hand_points
from app.io.workspace import WorkspaceData
from app.panels.data.import_frame import FrameChoice
from app.panels.data.import_inputs import ImportInputs, one_per_line, preview_text
from app.ui.context import PanelContext
from app.ui.dialogs import confirm
from app.ui.text import display_name, escape
from app.ui.upload_guard import UploadRefusals
from promp.datasets import format_modalities, guessed_mapping
from promp.progress import clock

Notify = Callable[[viser.ClientHandle | None, str, str, str], None]
CREATE, REPLACE = "Create workspace", "Replace this workspace"


def sibling_folder(root: Path, stem: str) -> Path:
    """An absent folder beside ``root`` named after ``stem`` (``stem``, ``stem-2``, ...)."""
    taken = {p.name for p in root.parent.iterdir()} if root.parent.is_dir() else set()
    return root.parent / safe_name(stem, taken)


@dataclass(frozen=True, eq=False)
class Pending:
    """An upload previewed, not imported yet: its files, and what they read as."""

    upload: DatasetUpload
    data: WorkspaceData | None = None
    summary: DatasetSummary | None = None


class DatasetImport:
    """The "Import dataset" folder of the Data tab (see the module docstring)."""

    def __init__(
        self,
        ctx: PanelContext,
        notify: Notify,
        max_upload_bytes: int = MAX_DATASET_UPLOAD_BYTES,
    ):
        self.store = ctx.store
        self.notify = notify
        self.refusals = UploadRefusals(ctx.notify)
        self._lock = threading.RLock()
        self.pending: Pending | None = None
        gui = ctx.gui
        with gui.add_folder("Import dataset"):
            gui.add_markdown(
                "Your own recordings, as a **zip of their folder**: `<primitive>/<demo>.csv` "
                "(a header row: `t` in seconds, then named columns), lab records "
                "`<class>/.../<record>.txt`, or a rig's recordings in `<class>/` folders "
                "(YARP `data.log` dumps, ROS bags, `.xdf`, `.c3d`); or **one session file** "
                "cut by its markers (`start CLASS` ... `end CLASS`). Only read."
            )
            self.upload_button = gui.add_upload_button(
                "Upload dataset",
                icon=viser.Icon.UPLOAD,
                mime_type=",".join((".zip", *SESSION_FILES)),
                hint=f"A .zip or a session file ({', '.join(SESSION_FILES)}), up to "
                f"{format_size(max_upload_bytes)}",
            )
            self.inputs = ImportInputs(gui)
            self.preview = gui.add_markdown("")
            self.frame = FrameChoice(gui)
            self.actions = gui.add_button_group("", (CREATE, REPLACE), visible=False)
        self.guard = ctx.guard_upload(
            self.upload_button, max_upload_bytes,
            lambda client, filename, size: self._refuse(
                client, display_name(filename),
                f"The file is {format_size(size)}, over the {format_size(self.guard.max_bytes)} "
                "limit for a dataset. Nothing was changed.",
            ),
        )  # fmt: skip
        self.upload_button.on_upload(
            lambda event: self.receive(
                event.client, event.target.value.name, event.target.value.content
            )
        )
        for handle in self.inputs.handles:
            handle.on_update(lambda event: None if self.inputs.quiet else self.reread(event.client))
        for handle in self.frame.handles:
            handle.on_update(lambda event: None if self.frame.quiet else self.reframe(event.client))
        self.actions.on_click(lambda event: self.act(event.client, event.target.value))

    # ------------------------------------------------------------------ steps

    def _refuse(self, client, name: str, why: str) -> None:
        """A file refused: the preview of the one before goes (the latest upload is the one
        shown), the reason comes."""
        with self._lock:
            self._discard()
            self.preview.content = f"**Cannot import {escape(name)}:** {escape(why)}"
        self.refusals.refuse(client, f"Cannot import {name}", why)

    def receive(self, client, filename: str, content: bytes) -> DatasetSummary | None:
        """Extract and preview an uploaded dataset zip or session file (None when refused)."""
        name = display_name(filename)
        try:
            upload = extract_dataset_zip(
                content, name, Limits(max_upload_bytes=self.guard.max_bytes)
            )
        except ValueError as exc:
            self.guard.dismiss(client)  # no "uploaded successfully" under the refusal
            self._refuse(client, name, f"{exc}. Nothing was changed.")
            return None
        with self._lock:
            self._discard()
            self.pending = Pending(upload)
            self.inputs.set(upload.format, "", reset=True)
        summary = self.reread(client)
        if summary is None:
            self.guard.dismiss(client)
        return summary

    def reread(self, client) -> DatasetSummary | None:
        """Read the uploaded dataset with the chosen format and modalities; preview it."""
        with self._lock:
            if self.pending is None:
                return None
            upload, inputs = self.pending.upload, self.inputs
            inputs.show(True)
            files = sum(1 for p in upload.root.rglob("*") if p.is_file())
            self.preview.content = (  # the stage, while it reads (sent at once)
                f"Reading {escape(upload.filename)} ({inputs.format.value}, {files} files) "
                "and checking its demonstrations..."
            )
            started = time.monotonic()
            try:
                modalities, options = inputs.options()
                data, summary = upload.read(inputs.format.value, modalities, options)
            except ValueError as exc:
                self.pending = Pending(upload)
                self.actions.visible = False
                self.frame.hide()
                self.preview.content = f"**Cannot import:** {escape(str(exc))}" + (
                    self._show_guess(upload)
                )
                self.refusals.refuse(client, f"Cannot import {upload.filename}", str(exc))
                return None
            except Exception as exc:  # an unforeseen reader failure is still a refusal
                traceback.print_exc()
                self.pending = Pending(upload)
                self.actions.visible = False
                self.frame.hide()
                self.preview.content = f"**Cannot import:** {escape(type(exc).__name__)}"
                return None
            self.pending = Pending(upload, data, summary)
            self.refusals.accepted(client)
            if not inputs.modalities.value.strip():  # show the guess
                guess = summary.mapping or format_modalities(summary.layout)
                inputs.set(inputs.format.value, one_per_line(guess))
            self.preview.content = preview_text(upload, summary) + (
                f"  \nRead and checked in {clock(time.monotonic() - started)}."
            )
            self.frame.reset(hand_points(data.demos, data.layout))
            self.actions.visible = True
            return summary

    def _show_guess(self, upload: DatasetUpload) -> str:
        """After a refusal with guessed modalities: the guess put in the Modalities field to
        edit (a change reads the dataset again), and a line of the preview saying so (markdown;
        '' when the modalities were given, or nothing can be guessed). Lock held."""
        if self.inputs.modalities.value.strip():
            return ""
        guess = guessed_mapping(upload.root, self.inputs.format.value)
        if not guess:
            return ""
        self.inputs.set(self.inputs.format.value, one_per_line(guess))
        return (
            "  \nThe modalities guessed are in **Modalities**, one a line: edit them (a stream "
            "or field to leave out, a unit such as `@m`) and the dataset is read again."
        )

    def reframe(self, client) -> None:
        """The hand's frame or placement changed: the preview says where it is now."""
        with self._lock:
            if self.pending is None or self.pending.data is None:
                return
            refused = self.frame.update()
        if refused is not None:
            self.refusals.refuse(client, "Cannot place the hand", refused)

    def act(self, client, action: str) -> None:
        with self._lock:
            pending = self.pending
        if pending is None or pending.data is None:
            self.notify(client, "Nothing to import", "Upload a dataset zip first.", "red")
            return
        if action == CREATE:
            self.create(client)
        elif client is None:
            self.replace(None)
        else:
            self._confirm_replace(client, pending.summary)

    def create(self, client) -> Path | None:
        """Make a new workspace beside the current one from the previewed dataset, and serve
        it. Returns its folder (None when refused)."""
        target = None

        def apply(upload: DatasetUpload, data: WorkspaceData) -> str:
            nonlocal target
            target = sibling_folder(self.store.state.workspace.root, Path(upload.filename).stem)
            self.store.switch(target, data)
            return (
                f"{target.resolve()}: {data.n_demos} demonstrations of {len(data.primitives)} "
                f"primitives. The studio now serves it (reopen it with --workspace {target}); "
                "the previous workspace is unchanged on disk."
            )

        return target if self._apply(client, "Workspace created", apply) else None

    def _confirm_replace(self, client: viser.ClientHandle, summary: DatasetSummary) -> None:
        confirm(
            client,
            "Replace this workspace?",
            f"Import **{escape(summary.source)}** ({summary.n_demos} demonstrations) into the "
            "current workspace? Its demonstrations move to the workspace's trash (*Recently "
            "deleted* restores them).",
            "Replace this workspace",
            lambda: self.replace(client),
        )

    def replace(self, client) -> bool:
        """Put the previewed dataset in the current workspace (its content to the trash)."""

        def apply(upload: DatasetUpload, data: WorkspaceData) -> str:
            self.store.replace(data, f"replaced by the dataset {upload.filename}")
            return (
                f"{upload.filename}: {data.n_demos} demonstrations. The previous content is "
                "in the trash (Recently deleted)."
            )

        return self._apply(client, "Workspace replaced", apply)

    def _apply(
        self,
        client,
        title: str,
        apply: Callable[[DatasetUpload, WorkspaceData], str],
    ) -> bool:
        """Run ``apply`` on the previewed dataset, then forget it; notify the outcome."""
        with self._lock:
            pending = self.pending
            if pending is None or pending.data is None:
                return False
            try:
                message = apply(pending.upload, placed_data(pending.data, self.frame.frame()))
            except (ValueError, OSError) as exc:
                self.notify(client, f"Cannot import {pending.upload.filename}", f"{exc}.", "red")
                return False
            self._discard()
        self.notify(client, title, message, "green")
        return True

    def _discard(self) -> None:
        """Forget the pending upload and remove its temporary folder (lock held)."""
        if self.pending is not None:
            self.pending.upload.close()
        self.pending = None
        self.actions.visible = False
        self.inputs.show(False)
        self.frame.hide()
        self.preview.content = ""

    def close(self) -> None:
        with self._lock:
            if self.pending is not None:
                self.pending.upload.close()
        self.guard.close()
