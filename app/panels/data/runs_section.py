"""The Data tab's "Saved runs": every evaluation kept in the workspace's ``runs/``.

Each evaluation the tab runs to its end (and a cancelled one that has results, marked partial)
is written as ``runs/<YYYYmmdd-HHMMSS>-<name>/`` by the command line's writer
(:mod:`app.io.runs_folder`, :func:`promp.evaluate.runs.write_run`), on a worker, under the
name typed in the evaluation's "Run name" (by default its observed modalities and alpha
method). Runs the command line wrote there (``--run WORKSPACE/runs/NAME``) are listed too: the
folder is looked at again every :data:`SCAN_SECONDS`, on a worker.

For the chosen run: *Open run* shows its results in the evaluation's results area, under its
name; *Export run* downloads its folder as a zip; *Delete run* moves it to the workspace's
trash (*Recently deleted* restores it); *Compare runs* lays it beside the run chosen in
"Compare with" (:func:`promp.evaluate.runs.compare_runs`, :mod:`app.panels.data.runs_text`).
A run that cannot be read is listed with the reason and refused with it; nothing changes then.
"""

from __future__ import annotations

import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import viser

from app.core.snapshot import Snapshot
from app.io.exchange import format_size
from app.io.runs_folder import RUNS_DIR, RunListing, RunsScanner, open_run, run_zip, save_run
from app.io.trash import TrashEntry
from app.panels.data.evaluation import EvaluationJob
from app.panels.data.evaluation_plan import METHOD, EvaluationPlan
from app.panels.data.evaluation_section import EvaluationSection
from app.panels.data.runs_text import NO_RUN, comparison_markdown, describe, run_choices, runs_table
from app.ui.context import PanelContext
from app.ui.display import ALPHA_LABELS, observed_label
from app.ui.text import escape
from promp.evaluate.decisions import decisions_of
from promp.evaluate.plots import figures_unavailable
from promp.evaluate.runs import Run, compare_runs

Notify = Callable[[viser.ClientHandle | None, str, str, str], None]
SCAN_SECONDS = 2.0  # how often runs/ is looked at for runs written by others


def default_name(plan: EvaluationPlan) -> str:
    """A run's name when none is typed: its observed modalities and alpha method, e.g.
    ``hand + head ML`` (``each`` when several modality sets are compared), and the methods
    when not ours alone (``hand ML ours+seed+dtw+prefix-nn``)."""
    sets = plan.observe_sets
    observed = observed_label(sets[0]) if len(sets) == 1 else "each"
    methods = "" if plan.methods == [METHOD] else " " + "+".join(plan.methods)
    return f"{observed} {'+'.join(ALPHA_LABELS.get(a, a) for a in plan.alpha_methods)}{methods}"


def _workspace(ctx: PanelContext) -> Path:
    return ctx.store.state.workspace.root


@dataclass(frozen=True, eq=False)
class RunsControls:
    """The handles of the "Saved runs" folder."""

    summary: viser.GuiMarkdownHandle
    table: viser.GuiMarkdownHandle
    choice: viser.GuiDropdownHandle
    open_button: viser.GuiButtonHandle
    export_button: viser.GuiButtonHandle
    delete_button: viser.GuiButtonHandle
    other: viser.GuiDropdownHandle
    compare_button: viser.GuiButtonHandle
    comparison: viser.GuiMarkdownHandle


class RunsSection:
    """The "Saved runs" folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext, notify: Notify, evaluation: EvaluationSection):
        self.ctx, self.notify, self.evaluation = ctx, notify, evaluation
        self._root: Path | None = None  # the workspace listed
        self._listed: dict[str, tuple[float, RunListing]] | None = None  # what the list shows
        self._choices: dict[str, str] = {}  # dropdown label -> run folder
        self._scanner = RunsScanner(SCAN_SECONDS)
        self._watched: EvaluationJob | None = None  # the evaluation to save once it ends
        self._name = ""
        self.savers: list[threading.Thread] = []  # the runs being kept (the last, the latest)
        gui = ctx.gui
        with gui.add_folder("Saved runs"):
            summary = gui.add_markdown("")
            table = gui.add_markdown("")
            choice = gui.add_dropdown("Run", (NO_RUN,))
            open_button = gui.add_button(
                "Open run", icon=viser.Icon.FOLDER_OPEN,
                hint="Show its results in the results area above, under the run's name",
            )  # fmt: skip
            export_button = gui.add_button(
                "Export run", icon=viser.Icon.FILE_ZIP,
                hint="Download its folder as a zip: run.json, results.csv, trials.csv, figures",
            )  # fmt: skip
            delete_button = gui.add_button(
                "Delete run", icon=viser.Icon.TRASH, color="gray",
                hint="Move its folder to the workspace's trash (Recently deleted restores it)",
            )  # fmt: skip
            other = gui.add_dropdown("Compare with", (NO_RUN,))
            compare_button = gui.add_button(
                "Compare runs", icon=viser.Icon.GIT_COMPARE,
                hint="The chosen run (A) beside the one to compare with (B): how they were made "
                "and, per percentage, errors, position and duration, A → B (B − A)",
            )  # fmt: skip
            comparison = gui.add_markdown("")
        self.controls = RunsControls(summary, table, choice, open_button, export_button,
                                     delete_button, other, compare_button, comparison)  # fmt: skip
        open_button.on_click(lambda event: self.open(event.client))
        export_button.on_click(lambda event: self.export(event.client))
        delete_button.on_click(lambda event: self.delete(event.client))
        compare_button.on_click(lambda event: self.compare(event.client))

    # ------------------------------------------------------------------ the loop

    def rescan(self) -> None:
        """List ``runs/`` again soon (runs were added from outside the section)."""
        self._scanner.rescan()

    def step(self, snapshot: Snapshot) -> None:
        """Save the evaluation that has just ended; list ``runs/`` when it may have changed."""
        root = snapshot.store.workspace.root
        if root != self._root:  # another workspace: its runs
            self._root, self._listed = root, None
            self.controls.comparison.content = ""
            self._scanner.rescan()
        self._watch(self.evaluation.job, root)
        listed = self._scanner.poll(root)  # read on a worker: the loop never waits for it
        if listed is not None:
            self._show(root, listed)

    def _watch(self, job: EvaluationJob | None, root: Path) -> None:
        if job is None:
            return
        if job is not self._watched:  # just started: the name typed for it
            self._watched = job
            typed = self.evaluation.controls.run_name_text.value.strip()
            self._name = typed or default_name(job.plan)
            return
        outcome = job.outcome
        if outcome is not None and self._name:
            name, self._name = self._name, ""
            if outcome.result is not None and outcome.result.rows:  # done, or cancelled with rows
                # Into the workspace it evaluated, even if another is shown now.
                where = Path(job.plan.source) if job.plan.source else root
                saver = threading.Thread(target=self.save, args=(job, name, where),
                                         name="data-run-save", daemon=True)  # fmt: skip
                saver.start()
                self.savers = [t for t in self.savers if t.is_alive()] + [saver]

    def save(self, job: EvaluationJob, name: str, root: Path) -> Run | None:
        """Write the ended ``job`` as a run of the workspace at ``root`` (blocking)."""

        def figures(folder: Path) -> None:
            if figures_unavailable():
                self.notify(None, "Run kept without figures", f"{figures_unavailable()}.",
                            "yellow")  # fmt: skip
                return
            try:
                folder.mkdir(parents=True, exist_ok=True)
                for file, png in job.figures().items():  # drawn once, for the export too
                    (folder / file).write_bytes(png)
            except Exception:  # a figure that cannot be drawn must not lose the run's tables
                traceback.print_exc()

        try:
            report = job.report()
            run = save_run(root, report, name, figures, partial=job.outcome.cancelled)
        except (ValueError, OSError) as exc:
            self.notify(None, "Run not kept", f"{exc}.", "red")
            return None
        finally:
            self._scanner.rescan()
        partial = " (partial: the evaluation was cancelled)" if job.outcome.cancelled else ""
        self.notify(None, "Run kept", f"{RUNS_DIR}/{run.folder.name}{partial}: Saved runs "
                    "lists it.", "blue")  # fmt: skip
        return run

    def _show(self, root: Path, listed: dict[str, tuple[float, RunListing]]) -> None:
        if listed is self._listed:
            return
        previous, self._listed = self._listed, listed
        items = [item for _, item in listed.values()]
        self._choices = run_choices(items)
        options = tuple(self._choices) or (NO_RUN,)
        c = self.controls
        chosen, other = c.choice.value, c.other.value
        for dropdown in (c.choice, c.other):
            if tuple(dropdown.options) != options:
                dropdown.options = options
        fresh = [label for label, folder in self._choices.items() if folder not in (previous or {})]
        if fresh and previous:  # a new run: chosen, to compare with the one chosen before
            chosen, other = fresh[0], chosen
        if chosen not in self._choices:
            chosen = options[0]
        if other not in self._choices or other == chosen:
            other = next((o for o in options if o != chosen), chosen)
        for dropdown, value in ((c.choice, chosen), (c.other, other)):
            if dropdown.value != value:
                dropdown.value = value
        for button in (c.open_button, c.export_button, c.delete_button):
            button.disabled = not items
        c.compare_button.disabled = len(items) < 2
        c.summary.content = (
            f"{len(items)} run(s) in {escape(str(root / RUNS_DIR))}."
            if items
            else "Every evaluation run to its end is kept here (in the workspace's runs/ "
            "folder), as are runs of python -m promp.evaluate --run WORKSPACE/runs/NAME."
        )
        c.table.content = runs_table(items)

    # ------------------------------------------------------------------ the actions

    def _chosen(self, client, dropdown: viser.GuiDropdownHandle) -> str | None:
        folder = self._choices.get(dropdown.value)
        if folder is None:
            self.notify(client, "No run chosen", "Run an evaluation first: it is kept here.",
                        "yellow")  # fmt: skip
        return folder

    def _read(self, client, dropdown: viser.GuiDropdownHandle) -> Run | None:
        folder = self._chosen(client, dropdown)
        if folder is None:
            return None
        try:
            return open_run(_workspace(self.ctx), folder)
        except (ValueError, KeyError, TypeError) as exc:
            self.notify(client, "Cannot open run", f"{exc}. Nothing was changed.", "red")
            return None

    def open(self, client: viser.ClientHandle | None) -> Run | None:
        """Show the chosen run's results in the results area, under its name."""
        run = self._read(client, self.controls.choice)
        if run is None:
            return None
        item = (self._listed or {}).get(run.folder.name, (0.0, None))[1]
        how = " · ".join(describe(item)) + " %" if isinstance(item, RunListing) else ""
        partial = " *(partial)*" if run.report.get("partial") else ""
        self.evaluation.results.show(
            f"**Saved run:** {escape(run.label)}{partial}  \n{how}", run.report["results"],
            decisions_of(run.report), run.report.get("paired", []),
        )  # fmt: skip
        self.notify(client, "Run opened", f"{run.label}: its results are shown.", "blue")
        return run

    def export(self, client: viser.ClientHandle | None) -> bytes | None:
        """Send the chosen run's folder to ``client`` as ``run-<folder>.zip``."""
        folder = self._chosen(client, self.controls.choice)
        if folder is None:
            return None
        try:
            content = run_zip(_workspace(self.ctx), folder)
        except (ValueError, OSError) as exc:
            self.notify(client, "Cannot export run", f"{exc}.", "red")
            return None
        filename = f"run-{folder}.zip"
        if client is not None:
            client.send_file_download(filename, content, save_immediately=True)
        self.notify(client, "Run exported", f"{filename} ({format_size(len(content))}).", "blue")
        return content

    def delete(self, client: viser.ClientHandle | None) -> TrashEntry | None:
        """Move the chosen run to the workspace's trash."""
        folder = self._chosen(client, self.controls.choice)
        if folder is None:
            return None
        try:
            entry = self.ctx.store.trash_run(folder)
        except (ValueError, OSError) as exc:
            self.notify(client, "Cannot delete run", f"{exc}. Nothing was changed.", "red")
            return None
        self._scanner.rescan()
        self.controls.comparison.content = ""
        self.notify(client, "Run deleted", f"{folder} is in the workspace's trash; Recently "
                    "deleted restores it.", "blue")  # fmt: skip
        return entry

    def compare(self, client: viser.ClientHandle | None) -> str | None:
        """Show the chosen run (A) beside the one chosen in "Compare with" (B)."""
        c = self.controls
        if c.choice.value == c.other.value:
            self.notify(client, "Choose two runs", "Compare with another run than the one "
                        "chosen.", "yellow")  # fmt: skip
            return None
        a = self._read(client, c.choice)
        b = self._read(client, c.other) if a is not None else None
        if a is None or b is None:
            return None
        text = comparison_markdown(a, b, compare_runs(a, b))
        c.comparison.content = text
        return text

    @property
    def idle(self) -> bool:
        """No run is being kept: every evaluation that ended with results is written (its
        figures drawn), or could not be."""
        return not any(t.is_alive() for t in self.savers)

    def close(self) -> None:
        """Let the runs being written finish (each is renamed into place whole, or not at
        all)."""
        for saver in self.savers:
            saver.join(timeout=30.0)
