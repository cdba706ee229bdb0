"""The Data tab: export and import models and workspaces, and the leave-one-out evaluation.

* **Export model** downloads the model learned from the demonstrations (``model-<time>.json``,
  :mod:`promp.io`'s format, what robot-side code loads); **Export workspace** downloads
  ``workspace-<time>.zip`` (studio.json, demos/<primitive>/<demo>.csv, model.json).
* **Import** takes either file. Everything is validated in memory first (:mod:`app.exchange`);
  a bad file gives a notification naming the file and the problem and changes nothing. A
  model becomes the model inference uses (:meth:`app.session.Session.use_imported_model`)
  until the demonstrations or settings change or "Use the learned model" is clicked; it is not
  written to the workspace. A workspace replaces the current one after a confirmation.
  Uploads over :data:`app.exchange.MAX_UPLOAD_BYTES` are refused as soon as they start
  (:mod:`app.upload_guard`).
* **Leave-one-out evaluation** runs the sweep of ``python -m promp.evaluate`` on the current
  demonstrations (primitives with at least 3) in a background thread, with a progress bar,
  then shows the recognition errors and the position error of the remainder against the
  percentage observed, and a table.

Callbacks run on viser's thread pool and only act on the session (which has its own lock) or
record what the loop must redraw; :meth:`DataPanel.step`, on the studio's loop, updates the
progress bar and draws the results.
"""

from __future__ import annotations

import re
import threading
import time
import traceback
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import viser

from app import exchange
from app.dialogs import confirm
from app.display import observed_choices
from app.gui_text import display_name, escape
from app.panels.import_dataset import DatasetImport
from app.panels.trash_list import RecentlyDeleted
from app.upload_guard import UploadGuard
from app.workspace import WorkspaceData
from promp.data import Demonstration, Layout
from promp.evaluate.cli import DEFAULT_PERCENTS
from promp.evaluate.methods import ProMPEngine
from promp.evaluate.sweep import SweepResult, run_sweep
from promp.model import Settings

if TYPE_CHECKING:
    from app.studio import Studio

MIN_DEMOS = 3  # leave-one-out needs two demonstrations left to learn from
COMPARE = "compare each"


def observe_choices(layout: Layout) -> dict[str, list[list[str]]]:
    """The evaluation's observed-modality choices: those of the Infer tab (all together, each
    alone) and, with several modalities, all of them compared in one sweep."""
    choices = {label: [list(names)] for label, names in observed_choices(layout).items()}
    if len(layout.names) > 1:
        choices[COMPARE] = [[name] for name in layout.names] + [list(layout.names)]
    return choices

ALPHA_CHOICES: dict[str, list[str]] = {
    "ml": ["ml"],
    "model": ["model"],
    "both": ["ml", "model"],
}
SERIES_COLORS = {"hand": "#e4572e", "head": "#2980b9", "hand+head": "#27ae60"}


# ------------------------------------------------------------------------------ pure helpers


def parse_percents(text: str) -> list[float]:
    """Percentages of the movement observed, from ``"10 20 30"`` or ``"10, 20, 30"``.

    Raises
    ------
    ValueError
        Nothing given, a non-number, a value outside (0, 100], or more than 20 values.
    """
    tokens = [t for t in re.split(r"[\s,;]+", text.strip()) if t]
    if not tokens:
        raise ValueError("give at least one percentage, e.g. 10 20 30 40 50 60 70 80 90")
    try:
        values = sorted({float(t) for t in tokens})
    except ValueError:
        raise ValueError(f"percentages must be numbers, got {text.strip()!r}") from None
    if any(not (0.0 < v <= 100.0) or not np.isfinite(v) for v in values):
        raise ValueError(f"percentages must be in (0, 100], got {text.strip()!r}")
    if len(values) > 20:
        raise ValueError(f"at most 20 percentages, got {len(values)}")
    return values


def evaluation_dataset(
    order: Sequence[str], demos: Mapping[str, Sequence[Demonstration]]
) -> tuple[dict[str, list[Demonstration]], dict[str, int]]:
    """The primitives with at least :data:`MIN_DEMOS` demonstrations, in ``order``, and the
    demonstration counts of those left out."""
    dataset = {n: list(demos.get(n, [])) for n in order if len(demos.get(n, [])) >= MIN_DEMOS}
    skipped = {n: len(demos.get(n, [])) for n in order if n not in dataset}
    return dataset, skipped


def series_label(observed: Sequence[str], alpha_method: str) -> str:
    return f"{'+'.join(observed)}, alpha {alpha_method}"


def _series_order(row: Mapping) -> tuple:
    """hand, head, hand+head (then anything else), ml before model, then by percent."""
    known = ["hand"], ["head"], ["hand", "head"]
    observed = list(row["observed"])
    rank = known.index(observed) if observed in known else len(known)
    return rank, "+".join(observed), row["alpha_method"], row["percent"]


def curves(rows: Sequence[Mapping]) -> dict[str, dict[str, np.ndarray]]:
    """Per (observed, alpha) series: ``percent``, ``recognition_errors``, ``trials``,
    ``position_cm``, ``duration_s``, arrays of shape (n_percents,), sorted by percent."""
    groups: dict[str, list[Mapping]] = {}
    for row in sorted(rows, key=_series_order):
        label = series_label(row["observed"], row["alpha_method"])
        groups.setdefault(label, []).append(row)
    out = {}
    for label, group in groups.items():
        group = sorted(group, key=lambda r: r["percent"])
        out[label] = {
            "percent": np.array([r["percent"] for r in group], dtype=float),
            "recognition_errors": np.array([r["recognition_errors"] for r in group], dtype=float),
            "trials": np.array([r["trials"] for r in group], dtype=float),
            "position_cm": 100.0 * np.array([r["position_error_m"] for r in group], dtype=float),
            "duration_s": np.array([r["duration_error_s"] for r in group], dtype=float),
        }
    return out


def results_table(rows: Sequence[Mapping]) -> str:
    """Markdown: one row per percentage, one column per (observed, alpha) series, the
    recognition errors then the position error of the remainder (cm)."""
    series = curves(rows)
    if not series:
        return ""
    labels = list(series)
    header = " | ".join(label.replace(", alpha ", " ") for label in labels)
    trials = int(next(iter(series.values()))["trials"][0])
    percents = sorted({float(p) for s in series.values() for p in s["percent"]})

    def table(key: str, title: str, fmt: str) -> list[str]:
        lines = [f"| {title} | {header} |", "|---:|" + "---:|" * len(labels)]
        for p in percents:
            cells = []
            for label in labels:
                i = np.flatnonzero(series[label]["percent"] == p)
                cells.append(format(series[label][key][i[0]], fmt) if i.size else "")
            lines.append(f"| {p:g} % | " + " | ".join(cells) + " |")
        return lines

    return "\n".join(
        [
            *table("recognition_errors", f"errors (of {trials})", ".0f"),
            "",
            *table("position_cm", "position (cm)", ".1f"),
        ]
    )


# ------------------------------------------------------------------------------ evaluation job


class _Cancelled(Exception):
    pass


@dataclass
class EvaluationJob:
    """A leave-one-out sweep running in a background thread; the loop reads it."""

    dataset: dict[str, list[Demonstration]]
    skipped: dict[str, int]
    percents: list[float]
    observe_sets: list[list[str]]
    alpha_methods: list[str]
    settings: Settings
    layout: Layout
    total: int = 0
    done: int = 0
    result: SweepResult | None = None
    error: str | None = None
    cancelled: bool = False
    finished: bool = False
    elapsed_s: float = 0.0
    cancel: threading.Event = field(default_factory=threading.Event)

    def run(self) -> None:
        """The sweep (blocking); sets ``result``, ``error`` or ``cancelled``, then
        ``finished``."""
        start = time.perf_counter()

        def progress(done: int, total: int) -> None:
            self.done, self.total = done, total
            if self.cancel.is_set():
                raise _Cancelled

        settings, layout = self.settings, self.layout
        try:
            self.result = run_sweep(
                lambda: ProMPEngine(layout, settings),
                self.dataset,
                layout,
                percents=self.percents,
                alpha_methods=self.alpha_methods,
                observe_sets=self.observe_sets,
                method_name="ours",
                progress=progress,
            )
        except _Cancelled:
            self.cancelled = True
        except ValueError as exc:
            self.error = str(exc)
        except Exception as exc:  # a bug must end the job visibly, not hang the progress bar
            traceback.print_exc()
            self.error = f"{type(exc).__name__}: {exc}"
        finally:
            self.elapsed_s = time.perf_counter() - start
            self.finished = True


# ------------------------------------------------------------------------------ the panel


class DataPanel:
    """The Data tab (see the module docstring)."""

    def __init__(self, studio: Studio, max_upload_bytes: int = exchange.MAX_UPLOAD_BYTES):
        self.studio = studio
        self.session = studio.session
        gui = studio.server.gui
        self.uploads_received = 0  # uploads that reached the callback (the guard stops others)
        self._job: EvaluationJob | None = None
        self._job_shown: EvaluationJob | None = None
        self._shown_done = -1
        self._thread: threading.Thread | None = None
        self._status_version = -1
        self._result_handles: list = []

        gui.add_markdown("**Export**")
        self.export_model_button = gui.add_button(
            "Export model",
            icon=viser.Icon.DOWNLOAD,
            hint="Download the model learned from the demonstrations (JSON, for robot-side code)",
        )
        self.export_workspace_button = gui.add_button(
            "Export workspace",
            icon=viser.Icon.FILE_ZIP,
            hint="Download every primitive, demonstration and the model as one zip",
        )
        gui.add_markdown("**Import**")
        self.upload_button = gui.add_upload_button(
            "Import model or workspace",
            icon=viser.Icon.UPLOAD,
            mime_type=".json,.zip",
            hint="A model (.json) to infer with, or a workspace (.zip) to replace this one",
        )
        self.model_status = gui.add_markdown("")
        self.use_learned_button = gui.add_button(
            "Use the learned model", icon=viser.Icon.ARROW_BACK_UP, visible=False
        )
        self.importer = DatasetImport(studio.server, self.session, self._notify)
        self.trash = RecentlyDeleted(studio.server, self.session, self._notify)
        self._observe_choices = observe_choices(self.session.layout)
        with gui.add_folder("Leave-one-out evaluation") as self.eval_folder:
            self.observe_dropdown = gui.add_dropdown("Observed", tuple(self._observe_choices))
            self.alpha_dropdown = gui.add_dropdown(
                "Alpha", tuple(ALPHA_CHOICES), initial_value="ml"
            )
            self.percents_text = gui.add_text(
                "Percents", " ".join(f"{p:g}" for p in DEFAULT_PERCENTS)
            )
            self.run_button = gui.add_button(
                "Run leave-one-out evaluation", icon=viser.Icon.PLAYER_PLAY
            )
            self.cancel_button = gui.add_button(
                "Cancel evaluation", icon=viser.Icon.X, color="red", visible=False
            )
            self.progress_bar = gui.add_progress_bar(0.0, visible=False, animated=True)
            self.eval_status = gui.add_markdown(
                f"Held out one demonstration at a time (primitives with at least {MIN_DEMOS})."
            )
            self.results_folder = gui.add_folder("Results", visible=False)

        self._max_upload_bytes = int(max_upload_bytes)
        self.guard = UploadGuard(studio.server, self.upload_button, max_upload_bytes, self._refused)

        self.export_model_button.on_click(lambda event: self.export_model(event.client))
        self.export_workspace_button.on_click(lambda event: self.export_workspace(event.client))
        self.upload_button.on_upload(
            lambda event: self.import_file(
                event.client, event.target.value.name, event.target.value.content
            )
        )
        self.use_learned_button.on_click(lambda event: self.use_learned_model(event.client))
        self.run_button.on_click(lambda event: self.start_evaluation(event.client))
        self.cancel_button.on_click(lambda _: self.cancel_evaluation())
        self._update_model_status()

    # ------------------------------------------------------------------ settings

    @property
    def max_upload_bytes(self) -> int:
        return self._max_upload_bytes

    @max_upload_bytes.setter
    def max_upload_bytes(self, value: int) -> None:
        self._max_upload_bytes = int(value)
        self.guard.max_bytes = int(value)

    # ------------------------------------------------------------------ notifications

    def _notify(
        self, client: viser.ClientHandle | None, title: str, body: str, color: str = "blue"
    ) -> None:
        """To the client that acted (every tab when unknown); errors stay longer."""
        if client is None:
            self.studio.notify(title, body, color=color)
        else:
            seconds = 20.0 if color == "red" else 10.0
            self.studio.notify(title, body, color, client=client, auto_close_seconds=seconds)

    # ------------------------------------------------------------------ export

    def export_model(self, client: viser.ClientHandle | None) -> bytes | None:
        """Send the learned model to ``client`` as ``model-<time>.json``; returns the bytes."""
        with self.session.lock:
            model, reason = self.session.model, self.session.fit_error
        if model is None:
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
        with self.session.lock:
            data = WorkspaceData(
                primitives=list(self.session.primitives),
                demos={name: list(demos) for name, demos in self.session.demos.items()},
                settings=dict(self.session.settings),
            )
            model = self.session.model
        content = exchange.workspace_zip(data, model)
        filename = exchange.export_filename("workspace", "zip")
        if client is not None:
            client.send_file_download(filename, content, save_immediately=True)
        n_demos = sum(len(v) for v in data.demos.values())
        self._notify(
            client,
            "Workspace exported",
            f"{filename} ({exchange.format_size(len(content))}): {len(data.primitives)} "
            f"primitives, {n_demos} demonstrations" + (", the model." if model else "."),
        )
        return content

    # ------------------------------------------------------------------ import

    def _refused(self, client: viser.ClientHandle | None, filename: str, size: int) -> None:
        self._notify(
            client,
            f"Cannot import {display_name(filename)}",
            f"The file is {exchange.format_size(size)}, over the "
            f"{exchange.format_size(self.max_upload_bytes)} upload limit. Nothing was changed.",
            "red",
        )

    def import_file(self, client: viser.ClientHandle | None, filename: str, content: bytes):
        """Validate an uploaded file and import it (a workspace after a confirmation).

        Returns the validated upload, or None when it was refused.
        """
        self.uploads_received += 1
        name = display_name(filename)
        limits = exchange.Limits(max_upload_bytes=self.max_upload_bytes)
        try:
            upload = exchange.read_upload(filename, content, limits)
        except ValueError as exc:
            self._notify(client, f"Cannot import {name}", f"{exc}. Nothing was changed.", "red")
            return None
        except Exception as exc:  # an unforeseen parser failure is still a refused file
            traceback.print_exc()
            self._notify(
                client,
                f"Cannot import {name}",
                f"unreadable file ({type(exc).__name__}: {exc}). Nothing was changed.",
                "red",
            )
            return None
        if isinstance(upload, exchange.ModelUpload):
            try:
                self.session.use_imported_model(upload.model, name)
            except ValueError as exc:
                self._notify(client, f"Cannot import {name}", f"{exc}. Nothing was changed.", "red")
                return None
            names = ", ".join(p.name for p in upload.model.primitives)
            self._notify(
                client,
                "Model imported",
                f"{name}: primitives {names}. Inference uses it until the demonstrations change "
                "(or 'Use the learned model').",
                "green",
            )
            return upload
        if client is None:
            self.replace_workspace(None, upload)
        else:
            self._confirm_replace(client, upload)
        return upload

    def _confirm_replace(
        self, client: viser.ClientHandle, upload: exchange.WorkspaceUpload
    ) -> None:
        name = display_name(upload.filename)
        with self.session.lock:
            current_p = len(self.session.primitives)
            current_d = sum(len(v) for v in self.session.demos.values())
        names = ", ".join(p.name for p in upload.data.primitives) or "none"
        confirm(
            client,
            "Replace the workspace?",
            f"**{name}** holds {len(upload.data.primitives)} primitives ({names}) and "
            f"{upload.n_demos} demonstrations.\n\nImporting it replaces the current "
            f"workspace ({current_p} primitives, {current_d} demonstrations), which moves "
            "to the workspace's trash (*Recently deleted* restores it).",
            "Replace the workspace",
            lambda: self.replace_workspace(client, upload),
            lambda: self._notify(client, "Import cancelled", f"{name}: nothing was changed."),
        )

    def replace_workspace(
        self, client: viser.ClientHandle | None, upload: exchange.WorkspaceUpload
    ) -> bool:
        """Swap the session for a validated workspace archive."""
        name = display_name(upload.filename)
        try:
            self.session.replace(upload.data, f"replaced by the import of {name}")
        except (ValueError, OSError) as exc:
            self._notify(client, f"Cannot import {name}", f"{exc}. Nothing was changed.", "red")
            return False
        skipped = f" (ignored: {', '.join(upload.ignored)})" if upload.ignored else ""
        self._notify(
            client,
            "Workspace imported",
            f"{name}: {len(upload.data.primitives)} primitives, {upload.n_demos} "
            f"demonstrations{skipped}. The previous workspace is in the trash (Recently "
            "deleted).",
            "green",
        )
        return True

    def use_learned_model(self, client: viser.ClientHandle | None) -> None:
        self.session.use_imported_model(None)
        self._notify(client, "Learned model", "Inference uses the model learned from the demos.")

    def _update_model_status(self) -> None:
        session = self.session
        with session.lock:
            self._status_version = session.version
            imported, source = session.imported_model, session.imported_from
            model, reason = session.model, session.fit_error
        if imported is not None:
            names = ", ".join(p.name for p in imported.primitives)
            text = (
                f"**Inference model:** imported from `{source}` ({names}), used until the "
                "demonstrations change."
            )
        elif model is not None:
            names = ", ".join(p.name for p in model.primitives)
            text = f"**Inference model:** learned from the demonstrations ({names})."
        else:
            text = f"**Inference model:** none yet ({reason})."
        self.model_status.content = text
        self.use_learned_button.visible = imported is not None

    # ------------------------------------------------------------------ evaluation

    def start_evaluation(self, client: viser.ClientHandle | None) -> EvaluationJob | None:
        """Start the sweep in a background thread with the GUI's options (None if refused)."""
        if self._job is not None and not self._job.finished:
            return None
        try:
            percents = parse_percents(self.percents_text.value)
        except ValueError as exc:
            self._notify(client, "Cannot evaluate", f"{exc}.", "red")
            return None
        with self.session.lock:
            order = [p.name for p in self.session.primitives]
            dataset, skipped = evaluation_dataset(order, self.session.demos)
            settings = self.session.learning_settings()
            layout = self.session.layout
        observe = self._observe_choices.get(self.observe_dropdown.value)
        if observe is None or any(n not in layout.names for names in observe for n in names):
            self._notify(client, "Cannot evaluate", "choose the observed modalities.", "red")
            return None
        if not dataset:
            counts = ", ".join(f"{n}: {c}" for n, c in skipped.items()) or "no primitives"
            self._notify(
                client,
                "Cannot evaluate",
                f"leave-one-out needs a primitive with at least {MIN_DEMOS} demonstrations "
                f"({counts}).",
                "red",
            )
            return None
        job = EvaluationJob(
            dataset=dataset,
            skipped=skipped,
            percents=percents,
            observe_sets=[list(s) for s in observe],
            alpha_methods=list(ALPHA_CHOICES[self.alpha_dropdown.value]),
            settings=settings,
            layout=layout,
            total=sum(len(v) for v in dataset.values()),
        )
        self._job = job
        self.run_button.disabled = True
        self.cancel_button.visible = True
        self.progress_bar.value = 0.0
        self.progress_bar.animated = True
        self.progress_bar.visible = True
        self.eval_status.content = (
            f"Running: {job.total} held-out demonstrations of {', '.join(dataset)}..."
        )
        self._thread = threading.Thread(target=job.run, name="data-evaluation", daemon=True)
        self._thread.start()
        return job

    def cancel_evaluation(self) -> None:
        if self._job is not None:
            self._job.cancel.set()

    def _show_job(self, job: EvaluationJob) -> None:
        """Progress while it runs; results, status and buttons when it has finished."""
        if job.done != self._shown_done:
            self._shown_done = job.done
            self.progress_bar.value = 100.0 * job.done / max(job.total, 1)
        if not job.finished or self._job_shown is job:
            return
        self._job_shown = job
        self.run_button.disabled = False
        self.cancel_button.visible = False
        self.progress_bar.animated = False
        skipped = (
            " Skipped (fewer than 3 demonstrations): "
            + ", ".join(f"{n} ({c})" for n, c in job.skipped.items())
            + "."
            if job.skipped
            else ""
        )
        if job.cancelled:
            self.eval_status.content = "Evaluation cancelled."
            self.progress_bar.visible = False
            return
        if job.error is not None or job.result is None:
            self.eval_status.content = f"Evaluation failed: {job.error}"
            self.progress_bar.visible = False
            self._notify(None, "Evaluation failed", str(job.error), "red")
            return
        failed = ""
        if job.result.failures:
            listed = "; ".join(
                f"{f['primitive']}/{f['demo']} at {f['percent']:g} % ({f['error']})"
                for f in job.result.failures[:10]
            )
            more = len(job.result.failures) - 10
            failed = (
                f"  \n**{len(job.result.failures)} trial(s) failed** (counted as recognition "
                f"errors): {escape(listed)}" + (f"; and {more} more" if more > 0 else "")
            )
        self.eval_status.content = (
            f"Held out each of {job.total} demonstrations of {', '.join(job.dataset)} in "
            f"{job.elapsed_s:.1f} s (n_basis {job.settings.n_basis}, width "
            f"{job.settings.width:g}).{skipped}{failed}"
        )
        self._draw_results(job.result.rows)
        self._notify(
            None, "Evaluation done", f"{job.total} held-out demonstrations, {job.elapsed_s:.1f} s."
        )

    def _draw_results(self, rows: Sequence[Mapping]) -> None:
        for handle in self._result_handles:
            handle.remove()
        self._result_handles = []
        series = curves(rows)
        if not series:
            return
        gui = self.studio.server.gui
        trials = int(next(iter(series.values()))["trials"][0])
        labels = list(series)
        x = next(iter(series.values()))["percent"]
        styles = []
        for label in labels:
            observed, alpha = label.split(", alpha ")
            style: dict = {
                "label": label,
                "stroke": SERIES_COLORS.get(observed, "#555555"),
                "width": 2,
                "points": {"show": True, "size": 6},
            }
            if alpha == "model":
                style["dash"] = [6, 4]
            styles.append(style)

        def chart(title: str, key: str, unit: str):
            # One sweep: every series has the same percentages.
            ys = [series[label][key] for label in labels]
            return gui.add_uplot(
                data=(x, *ys),
                series=({"label": "% observed"}, *styles),
                title=title,
                scales={"x": {"time": False}, "y": {"auto": True}},
                axes=({"label": "% of the movement observed"}, {"label": unit}),
                legend={"live": False},
                height=240,
            )

        with self.results_folder:
            self._result_handles.append(
                chart(f"Recognition errors (of {trials})", "recognition_errors", "errors")
            )
            self._result_handles.append(
                chart("Position error of the remainder", "position_cm", "cm")
            )
            self._result_handles.append(gui.add_markdown(results_table(rows)))
        self.results_folder.visible = True

    # ------------------------------------------------------------------ loop

    def step(self) -> None:
        if self.session.version != self._status_version:
            self._update_model_status()
            self._sync_observe_choices()
        self.trash.step()
        job = self._job
        if job is not None:
            self._show_job(job)

    def _sync_observe_choices(self) -> None:
        choices = observe_choices(self.session.layout)
        if choices != self._observe_choices:
            self._observe_choices = choices
            self.observe_dropdown.options = tuple(choices)

    def close(self) -> None:
        self.cancel_evaluation()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
        self.guard.close()
        self.importer.close()
