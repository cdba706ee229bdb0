"""The Data tab: export and import models and workspaces, one's own recordings, the trash, and
the leave-one-out evaluation.

* **Export model** downloads the model learned from the demonstrations (``model-<time>.json``,
  :mod:`promp.io`'s format, what robot-side code loads); **Export workspace** downloads
  ``workspace-<time>.zip`` (studio.json, demos/<primitive>/<demo>.csv, model.json, the saved
  evaluation runs under runs/). Both wait for the model of the latest change (learning runs
  in the background). **Export to Rerun** and **Export to MCAP** download the workspace as
  the 3D view shows it, for Rerun, Foxglove and PlotJuggler
  (:mod:`app.panels.data.viewer_export`).
* **Import** takes either file. Everything is validated in memory first (:mod:`app.io.exchange`);
  a bad file gives a notification naming the file and the problem and changes nothing (closed
  when a later file from the same browser tab is accepted). A model becomes the model inference
  uses (:meth:`app.core.view_state.View.use_imported`) until the demonstrations or settings
  change or "Use the learned model" is clicked; it is not written to the workspace. A
  workspace replaces the current one after a confirmation, and its evaluation runs join the
  saved runs (:func:`app.io.runs_folder.add_runs`: never over an existing run).
  Uploads over :data:`app.io.exchange.MAX_UPLOAD_BYTES` are refused as soon as they start
  (:mod:`app.ui.upload_guard`).
* **Import dataset** (:mod:`app.panels.data.import_dataset`), **Recently deleted**
  (:mod:`app.panels.data.trash_list`), the **Leave-one-out evaluation**
  (:mod:`app.panels.data.evaluation_section`) and its **Saved runs**
  (:mod:`app.panels.data.runs_section`) are sections of their own.

Callbacks run on viser's thread pool and only make one mutation (the store's, the view
state's) or start a job; :meth:`DataPanel.step`, on the studio's loop, shows the frame's
snapshot: the model status and the sections.
"""

from __future__ import annotations

import time
import traceback

import viser

from app.core.store_state import workspace_data
from app.io import exchange, runs_folder
from app.panels.data.evaluation_section import EvaluationSection
from app.panels.data.import_dataset import DatasetImport
from app.panels.data.model_status import ModelStatus
from app.panels.data.runs_section import RunsSection
from app.panels.data.trash_list import RecentlyDeleted
from app.panels.data.viewer_export import ViewerExport
from app.scene.look import Shown
from app.ui.context import Frame, PanelContext
from app.ui.dialogs import confirm
from app.ui.text import display_name
from app.ui.upload_guard import UploadRefusals
from promp.progress import clock

ERROR_SECONDS, NOTICE_SECONDS = 20.0, 10.0  # how long a notification to one client stays


def too_large(size: int, limit: int) -> str:
    """Why a file over the upload limit is refused."""
    return (
        f"The file is {exchange.format_size(size)}, over the {exchange.format_size(limit)} "
        "upload limit. Nothing was changed."
    )


class DataPanel:
    """The Data tab (see the module docstring)."""

    def __init__(self, ctx: PanelContext, max_upload_bytes: int = exchange.MAX_UPLOAD_BYTES):
        self.ctx = ctx
        self.uploads_received = 0  # uploads that reached the callback (the guard stops others)
        self.refusals = UploadRefusals(ctx.notify, ERROR_SECONDS)
        gui = ctx.gui
        gui.add_markdown("**Export**")
        self.export_model_button = gui.add_button(
            "Export model",
            icon=viser.Icon.DOWNLOAD,
            hint="Download the model learned from the demonstrations (JSON, for robot-side code)",
        )
        self.export_workspace_button = gui.add_button(
            "Export workspace",
            icon=viser.Icon.FILE_ZIP,
            hint="Download every primitive, demonstration, saved evaluation run and the "
            "model as one zip",
        )
        self.viewers = ViewerExport(ctx, self._notify, self._model_for_export)
        gui.add_markdown("**Import**")
        self.upload_button = gui.add_upload_button(
            "Import model or workspace",
            icon=viser.Icon.UPLOAD,
            mime_type=".json,.zip",
            hint="A model (.json) to infer with, or a workspace (.zip) to replace this one",
        )
        self.model_status = ModelStatus(ctx, self._notify)
        self.importer = DatasetImport(ctx, self._notify)
        self.trash = RecentlyDeleted(ctx, self._notify)
        self.evaluation = EvaluationSection(ctx, self._notify)
        self.runs = RunsSection(ctx, self._notify, self.evaluation)
        self.guard = ctx.guard_upload(
            self.upload_button, max_upload_bytes,
            lambda client, filename, size: self.refusals.refuse(
                client, f"Cannot import {display_name(filename)}",
                too_large(size, self.guard.max_bytes),
            ),
        )  # fmt: skip

        self.export_model_button.on_click(lambda event: self.export_model(event.client))
        self.export_workspace_button.on_click(lambda event: self.export_workspace(event.client))
        self.upload_button.on_upload(
            lambda event: self.import_file(
                event.client, event.target.value.name, event.target.value.content
            )
        )

    def _notify(
        self, client: viser.ClientHandle | None, title: str, body: str, color: str = "blue"
    ) -> None:
        """To the client that acted (every tab when unknown); errors stay longer."""
        if client is None:
            self.ctx.notify(title, body, color=color)
        else:
            seconds = ERROR_SECONDS if color == "red" else NOTICE_SECONDS
            self.ctx.notify(title, body, color, client=client, auto_close_seconds=seconds)

    # ------------------------------------------------------------------ export

    def _model_for_export(self, client: viser.ClientHandle | None, what: str):
        """The model of the workspace as it is now, once learned, and how long that was waited
        for (s); while it is learned again, ``client`` is told what the export waits for."""
        store, learner = self.ctx.store.state, self.ctx.learner.state
        if learner.learn_version != store.learn_version:
            n_demos = sum(len(d) for d in store.learned.values())
            last = learner.fit_ms / 1000.0
            took = f" (the last fit took {clock(last)})" if learner.model is not None else ""
            self._notify(
                client,
                f"{what}: waiting for the model",
                f"Learning again from {n_demos} demonstrations{took}; the file follows once "
                "it is learned.",
            )
        start = time.monotonic()
        model = self.ctx.wait_for_model()
        return model, time.monotonic() - start

    def export_model(self, client: viser.ClientHandle | None) -> bytes | None:
        """Send the learned model to ``client`` as ``model-<time>.json``; returns the bytes."""
        model, _ = self._model_for_export(client, "Export model")
        if model is None:
            reason = self.ctx.learner.state.error
            self._notify(client, "No model to export", f"The studio has no model: {reason}.", "red")
            return None
        content = exchange.model_bytes(model)
        filename = exchange.export_filename("model", "json")
        if client is not None:
            client.send_file_download(filename, content, save_immediately=True)
        names = ", ".join(p.name for p in model.primitives)
        self._notify(
            client,
            "Model exported",
            f"{filename} ({exchange.format_size(len(content))}): the model learned from the "
            f"demonstrations, primitives {names}.",
        )
        return content

    def export_workspace(self, client: viser.ClientHandle | None) -> bytes:
        """Send the workspace to ``client`` as ``workspace-<time>.zip``; returns the bytes."""
        model, waited = self._model_for_export(client, "Export workspace")
        state = self.ctx.store.state
        data = workspace_data(state)
        runs, unreadable = runs_folder.run_files(state.workspace.root)
        content = exchange.workspace_zip(data, model, runs=runs)
        filename = exchange.export_filename("workspace", "zip")
        if client is not None:
            client.send_file_download(filename, content, save_immediately=True)
        n_demos = sum(len(v) for v in data.demos.values())
        size, limit = len(content), self.guard.max_bytes
        self._notify(
            client,
            "Workspace exported",
            f"{filename} ({exchange.format_size(size)}): {len(data.primitives)} "
            f"primitives, {n_demos} demonstrations, {len(runs)} evaluation run(s)"
            + (", the model." if model else ".")
            + (f" Left out, unreadable: {'; '.join(unreadable)}." if unreadable else "")
            + (f" Waited {clock(waited)} for the model." if waited >= 1.0 else "")
            + (f" It is over the {exchange.format_size(limit)} a studio imports: delete "
               "runs you no longer need to share it whole." if size > limit else ""),
            "yellow" if unreadable or size > limit else "blue",
        )  # fmt: skip
        return content

    # ------------------------------------------------------------------ import

    def _refuse_upload(self, client: viser.ClientHandle | None, name: str, why: str) -> None:
        """A file refused after it was read: its "uploaded successfully" toast goes, the
        reason comes."""
        self.guard.dismiss(client)
        self.refusals.refuse(client, f"Cannot import {name}", why)

    def import_file(self, client: viser.ClientHandle | None, filename: str, content: bytes):
        """Validate an uploaded file and import it (a workspace after a confirmation).

        Returns the validated upload, or None when it was refused.
        """
        self.uploads_received += 1
        name = display_name(filename)
        limits = exchange.Limits(max_upload_bytes=self.guard.max_bytes)
        try:
            upload = exchange.read_upload(filename, content, limits)
        except ValueError as exc:
            self._refuse_upload(client, name, f"{exc}. Nothing was changed.")
            return None
        except Exception as exc:  # an unforeseen parser failure is still a refused file
            traceback.print_exc()
            self._refuse_upload(
                client, name, f"unreadable file ({type(exc).__name__}: {exc}). Nothing was changed."
            )
            return None
        if isinstance(upload, exchange.ModelUpload):
            try:
                self.ctx.view.use_imported(upload.model, name, self.ctx.store.state)
            except ValueError as exc:
                self._refuse_upload(client, name, f"{exc}. Nothing was changed.")
                return None
            self.refusals.accepted(client)
            names = ", ".join(p.name for p in upload.model.primitives)
            self._notify(
                client,
                "Model imported",
                f"{name}: primitives {names}. Inference uses it until the demonstrations change "
                "(or 'Use the learned model').",
                "green",
            )
            return upload
        self.refusals.accepted(client)
        if client is None:
            self.replace_workspace(None, upload)
        else:
            self._confirm_replace(client, upload)
        return upload

    def _confirm_replace(
        self, client: viser.ClientHandle, upload: exchange.WorkspaceUpload
    ) -> None:
        name = display_name(upload.filename)
        store = self.ctx.store.state
        current_p = len(store.primitives)
        current_d = sum(len(v) for v in store.demos.values())
        names = ", ".join(p.name for p in upload.data.primitives) or "none"
        confirm(
            client,
            "Replace the workspace?",
            f"**{name}** holds {len(upload.data.primitives)} primitives ({names}) and "
            f"{upload.n_demos} demonstrations"
            + (f", with {len(upload.runs)} evaluation run(s)" if upload.runs else "")
            + ".\n\nImporting it replaces the current "
            f"workspace ({current_p} primitives, {current_d} demonstrations), which moves "
            "to the workspace's trash (*Recently deleted* restores it)"
            + ("; its runs join the saved runs, none overwritten." if upload.runs else "."),
            "Replace the workspace",
            lambda: self.replace_workspace(client, upload),
            lambda: self._notify(client, "Import cancelled", f"{name}: nothing was changed."),
        )

    def replace_workspace(
        self, client: viser.ClientHandle | None, upload: exchange.WorkspaceUpload
    ) -> bool:
        """Swap the workspace for a validated workspace archive."""
        name = display_name(upload.filename)
        try:
            self.ctx.store.replace(upload.data, f"replaced by the import of {name}")
        except (ValueError, OSError) as exc:
            self._notify(client, f"Cannot import {name}", f"{exc}. Nothing was changed.", "red")
            return False
        skipped = f" (ignored: {', '.join(upload.ignored)})" if upload.ignored else ""
        try:
            added, present = runs_folder.add_runs(self.ctx.store.state.workspace.root,
                                                  upload.runs)  # fmt: skip
        except (ValueError, OSError) as exc:
            self._notify(client, f"{name}: evaluation runs not imported",
                         f"{exc}. The demonstrations were imported.", "red")  # fmt: skip
            added, present = [], []
        self.runs.rescan()
        runs = [f"{len(added)} evaluation run(s) added to the saved runs"] if added else []
        if present:
            runs.append(f"{len(present)} run(s) already there, left as they were")
        self._notify(
            client,
            "Workspace imported",
            f"{name}: {len(upload.data.primitives)} primitives, {upload.n_demos} "
            f"demonstrations{skipped}{'; ' + ', '.join(runs) if runs else ''}. The previous "
            "workspace is in the trash (Recently deleted).",
            "green",
        )
        return True

    # ------------------------------------------------------------------ loop

    def step(self, frame: Frame) -> Shown | None:
        self.model_status.step(frame.snapshot)
        self.trash.step(frame.snapshot)
        self.evaluation.step(frame.snapshot)
        self.runs.step(frame.snapshot)
        return None

    def close(self) -> None:
        self.evaluation.close()
        self.runs.close()
        self.guard.close()
        self.importer.close()
