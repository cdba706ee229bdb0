"""The studio's session: primitives, demonstrations, settings and the learned model.

One :class:`Session` per server, shared by every browser tab, so two tabs always show the same
state. Every mutation validates first, writes the workspace (atomically), then updates memory
and bumps :attr:`Session.version`; panels redraw when the version they drew is stale. A lock
serialises mutations coming from GUI callbacks (which viser runs on a thread pool).

Learning runs in one background worker: a mutation that changes what is learned (the
demonstrations, the settings, the workspace) asks for a refit and returns at once. Meanwhile the
previous model stays in use (and drawn); a newer request supersedes one in flight, whose result
is then dropped, so only the model of the latest request is adopted (and bumps the version).
:meth:`Session.wait_for_model` waits for it. A refit of what was learned a moment ago (Undo
delete, a setting put back) reuses that model (:mod:`app.core.fit_cache`). A model of other
modalities than the workspace's (after an import) is dropped at once rather than kept
meanwhile.

Deleting a demonstration or a primitive, and replacing the workspace, move the files to the
workspace's trash (:mod:`app.io.trash`); :meth:`Session.restore` puts them back. The session's
modalities are its workspace's layout: the studio's hand and head for the workspaces it
creates, whatever an imported dataset holds otherwise.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

from app.core.learning import Learned, Training, learn
from app.core.session_checks import FlaggedDemos
from app.io.demo_checks import DemoChecks
from app.io.trash import TrashEntry
from app.io.workspace import FolderKind, Workspace, WorkspaceData, inspect_folder
from app.io.workspace_index import PALETTE, PrimitiveEntry, check_color, check_name
from promp.data import Demonstration, Layout
from promp.model import FALLBACK, ProMPModel, Settings
from promp.typicality import Typicality, typicality

KEEP = object()  # set_learning: leave a setting as it is
REFIT_TIMEOUT_S = 120.0


class Session(FlaggedDemos):
    """Shared state of the studio (see the module docstring)."""

    def __init__(self, workspace: Workspace, data: WorkspaceData):
        self.lock = threading.RLock()
        self.hidden: set[tuple[str, str]] = set()  # (primitive, demo) not drawn
        self.typicality: dict[tuple[str, str], Typicality] = {}
        self.model: ProMPModel | None = None
        self.fit_ms = 0.0
        self.fit_error: str | None = None
        self.fit_reused = False  # the model came from a recent refit of the same training
        # A model imported from a file (Data tab) that inference uses instead of the learned
        # one until the demonstrations or settings next change (see use_imported_model).
        self.imported_model: ProMPModel | None = None
        self.imported_from = ""
        self.deleted: list[TrashEntry] = []  # this run's deletions, newest last ("Undo delete")
        self.version = 0
        # What is learned from (demonstrations, settings, layout) changes: learn_version counts
        # those changes, model_version is the one the current model was learned from.
        self.learn_version = 0
        self.model_version = 0
        self._fitted = threading.Condition(self.lock)
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="refit")
        self._closed = False
        self._listeners: list[Callable[[], None]] = []
        self._adopt(workspace, data)
        self._use(learn(self._training()))  # the first model, before anyone looks

    def _adopt(self, workspace: Workspace, data: WorkspaceData) -> None:
        """Hold ``data``, read from (or just written to) ``workspace``."""
        self.workspace = workspace
        self.layout: Layout = data.layout
        self.primitives: list[PrimitiveEntry] = list(data.primitives)
        self.demos: dict[str, list[Demonstration]] = {
            p.name: list(data.demos.get(p.name, [])) for p in self.primitives
        }
        # What the workspace sets; the engine's defaults fill the rest (learning_settings).
        self.settings: dict = dict(data.settings)
        self.problems: list[str] = list(data.problems)
        self.checks: DemoChecks = data.checks
        self._recheck()
        keys = {(p, d.name) for p, items in self.demos.items() for d in items}
        self.hidden &= keys
        self.typicality = {k: v for k, v in self.typicality.items() if k in keys}

    @classmethod
    def open(cls, root: Path, default: Callable[[], WorkspaceData] | None = None) -> Session:
        """Open the workspace at ``root``. An absent or empty folder first becomes a workspace
        holding ``default()`` (or nothing).

        Raises
        ------
        ValueError
            ``root`` is a folder that holds something other than a studio workspace (the
            message says what and how to import it; nothing is touched), or its index is
            unreadable.
        """
        kind, message = inspect_folder(root)
        if kind is FolderKind.FOREIGN:
            raise ValueError(message)
        if kind is not FolderKind.WORKSPACE:
            Workspace.create(root, default() if default is not None else WorkspaceData())
        workspace = Workspace(root)
        return cls(workspace, workspace.load())

    @property
    def columns(self) -> tuple[str, ...]:
        return self.layout.columns

    # ------------------------------------------------------------------ observers

    def on_change(self, callback: Callable[[], None]) -> None:
        """Call ``callback()`` after every mutation (from the thread that made it)."""
        self._listeners.append(callback)

    def _save_index(self, primitives=None, settings=None, checks=None) -> None:
        """Write ``studio.json`` with these (default: the session's own) primitives, settings
        and checks."""
        self.workspace.save_index(
            self.primitives if primitives is None else primitives,
            self.settings if settings is None else settings,
            self.layout,
            self.checks if checks is None else checks,
        )

    def _changed(self, refit: bool = True, recheck: bool = True) -> None:
        """After a mutation: find the faults again (``recheck``: the demonstrations may have
        changed), refit, and tell the listeners."""
        if refit:
            if recheck:
                self._recheck()
            self._ask_refit()
            self.imported_model, self.imported_from = None, ""
        self.version += 1
        for callback in list(self._listeners):
            callback()

    # ------------------------------------------------------------------ queries

    def names(self) -> list[str]:
        with self.lock:
            return [p.name for p in self.primitives]

    def entry(self, name: str) -> PrimitiveEntry:
        for p in self.primitives:
            if p.name == name:
                return p
        raise ValueError(f"unknown primitive {name!r}")

    def color(self, name: str) -> tuple[int, int, int]:
        return self.entry(name).color

    def inference_model(self) -> ProMPModel | None:
        """The model inference uses: the imported one if any, else the learned one."""
        with self.lock:
            return self.imported_model if self.imported_model is not None else self.model

    def learning_settings(self) -> Settings:
        # Every stored setting is honoured (an imported workspace may set the ridge or the
        # noise, for example); absent ones take the engine's defaults.
        return Settings(**self.settings)

    # ------------------------------------------------------------------ learning

    def _training(self, keep_choice: bool = True) -> Training:
        """What a refit learns from; with ``keep_choice``, the last model's choice of the
        automatic settings, which the fit keeps unless the demonstrations say otherwise."""
        with self.lock:
            learned = self.learned_demos()
            trainable = {n: list(d) for n, d in learned.items() if len(d) >= 2}
            previous = None
            if keep_choice and self.model is not None and self.model.layout == self.layout:
                previous = self.model.report.get("settings")
            return Training(trainable, self.layout, self.learning_settings(), previous)

    def _use(self, learned: Learned) -> None:
        """Adopt a refit's outcome (lock held)."""
        self.model, self.fit_error, self.fit_ms = learned.model, learned.error, learned.ms
        self.fit_reused = learned.reused

    def _ask_refit(self, reuse: bool = True) -> None:
        """Refit in the background from the current state (lock held)."""
        self.learn_version += 1
        if self.model is not None and self.model.layout != self.layout:
            self.model = None  # another workspace's model: nothing to show meanwhile
        if not self._closed:
            self._worker.submit(
                self._refit, self.learn_version, self._training(keep_choice=reuse), reuse
            )

    def _refit(self, request: int, training: Training, reuse: bool = True) -> None:
        """The worker's job: learn, then adopt the result if no newer request came."""
        with self.lock:
            if request != self.learn_version:
                return  # superseded before it started
        learned = learn(training, reuse)
        with self.lock:
            if request != self.learn_version:
                return  # superseded while it ran: the newer request's result will do
            self._use(learned)
            self.model_version = request
            self.version += 1
            self._fitted.notify_all()

    @property
    def refitting(self) -> bool:
        """True while the model does not yet answer the latest change."""
        return self.model_version != self.learn_version

    def wait_for_model(self, timeout: float = REFIT_TIMEOUT_S) -> ProMPModel | None:
        """The model of the current state, once learned (None when nothing can be learned).

        Raises
        ------
        TimeoutError
            If the refit takes longer than ``timeout`` seconds.
        """
        with self.lock:
            if not self._fitted.wait_for(lambda: not self.refitting, timeout):
                raise TimeoutError(f"no model learned within {timeout:g} s")
            return self.model

    def refit(self) -> ProMPModel | None:
        """Learn the model again from every primitive with at least two demonstrations (never
        a reused one), and wait for it (e.g. to time it: :attr:`fit_ms`)."""
        with self.lock:
            self._ask_refit(reuse=False)
        return self.wait_for_model()

    def close(self) -> None:
        """Stop the refit worker (a refit under way finishes first)."""
        with self.lock:
            self._closed = True
        self._worker.shutdown(wait=True, cancel_futures=True)

    def score(self, primitive: str, demo: Demonstration) -> Typicality | None:
        """Typicality of ``demo`` against the model learned from ``primitive``'s other
        demonstrations that learning uses (None when fewer than three exist)."""
        with self.lock:
            learned = self.learned_demos().get(primitive, [])
            others = [d for d in learned if d.name != demo.name]
            return typicality(demo, others, self.layout, self.resolved_settings())

    # ------------------------------------------------------------------ mutations

    def create_primitive(self, name: str, color: tuple[int, int, int] | None = None) -> None:
        with self.lock:
            check_name(name)
            if name in self.names():
                raise ValueError(f"a primitive named {name!r} already exists")
            if color is None:
                color = PALETTE[len(self.primitives) % len(PALETTE)]
            entry = PrimitiveEntry(name, check_color(color))
            self.workspace.demo_dir(name).mkdir(parents=True, exist_ok=True)
            self._save_index(primitives=[*self.primitives, entry])
            self.primitives.append(entry)
            self.demos[name] = []
            self._changed(refit=False)

    def rename_primitive(self, old: str, new: str) -> None:
        with self.lock:
            self.entry(old)
            check_name(new)
            if new == old:
                return
            if new in self.names():
                raise ValueError(f"a primitive named {new!r} already exists")
            self.workspace.rename_primitive(old, new)
            primitives = [replace(p, name=new) if p.name == old else p for p in self.primitives]
            checks = self.checks.renamed(old, new)
            self._save_index(primitives=primitives, checks=checks)
            self.primitives, self.checks = primitives, checks
            self.demos[new] = self.demos.pop(old)
            self.hidden = {(new if p == old else p, d) for p, d in self.hidden}
            self.typicality = {
                (new if p == old else p, d): t for (p, d), t in self.typicality.items()
            }
            self._changed()

    def recolor_primitive(self, name: str, color: tuple[int, int, int]) -> None:
        with self.lock:
            self.entry(name)
            rgb = check_color(color)
            primitives = [replace(p, color=rgb) if p.name == name else p for p in self.primitives]
            self._save_index(primitives=primitives)
            self.primitives = primitives
            self._changed(refit=False)

    def delete_primitive(self, name: str) -> TrashEntry:
        """Take the primitive out and move its demonstrations to the trash."""
        with self.lock:
            entry = self.entry(name)
            position = self.primitives.index(entry)
            primitives = [p for p in self.primitives if p.name != name]
            self._save_index(primitives=primitives)
            trashed = self.workspace.trash_primitive(entry, position)
            self.primitives = primitives
            self.demos.pop(name, None)
            self.deleted.append(trashed)
            self._changed()
            return trashed

    def next_demo_name(self, primitive: str) -> str:
        existing = {d.name for d in self.demos.get(primitive, [])}
        i = len(existing)
        while (
            f"{primitive}_{i:03d}" in existing
            or self.workspace.demo_path(primitive, f"{primitive}_{i:03d}").exists()
        ):
            i += 1
        return f"{primitive}_{i:03d}"

    def add_demo(
        self,
        primitive: str,
        times: np.ndarray,
        values: np.ndarray,
        raw: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> Demonstration:
        """Store a new demonstration (times (n,), values (n, D) in the layout's column order):
        written to disk before it joins the session. ``raw``, the (times, values) of the take
        it was trimmed from, is kept in the workspace's ``raw/`` folder (named after the
        demonstration and the time). Returns the demonstration (with its name)."""
        with self.lock:
            self.entry(primitive)
            times = np.asarray(times, dtype=float)
            demo = Demonstration(
                times - times[0], values, self.columns, name=self.next_demo_name(primitive)
            )
            untrimmed = None
            if raw is not None:
                raw_times = np.asarray(raw[0], dtype=float)
                stamp = time.strftime("%Y%m%d-%H%M%S")
                untrimmed = Demonstration(
                    raw_times - raw_times[0], raw[1], self.columns, name=f"{demo.name}_{stamp}"
                )
            typicality = self.score(primitive, demo)
            self.workspace.write_demo(primitive, demo, self.layout)
            if untrimmed is not None:
                self.workspace.write_raw(primitive, untrimmed, self.layout)
            self.demos[primitive].append(demo)
            if typicality is not None:
                self.typicality[(primitive, demo.name)] = typicality
            self._changed()
            return demo

    def delete_demo(self, primitive: str, demo: str) -> TrashEntry:
        """Move a demonstration to the trash."""
        with self.lock:
            entry = self.entry(primitive)
            if demo not in {d.name for d in self.demos[primitive]}:
                raise ValueError(f"primitive {primitive!r} has no demonstration {demo!r}")
            trashed = self.workspace.trash_demo(entry, demo)
            self.demos[primitive] = [d for d in self.demos[primitive] if d.name != demo]
            self.hidden.discard((primitive, demo))
            self.typicality.pop((primitive, demo), None)
            self.deleted.append(trashed)
            self._changed()
            return trashed

    def trash_entries(self) -> list[TrashEntry]:
        """Everything in the workspace's trash, newest first."""
        with self.lock:
            return self.workspace.trash.entries()

    def restore(self, name: str) -> TrashEntry:
        """Put the trash entry ``name`` back (see :meth:`app.io.workspace.Workspace.restore`)."""
        with self.lock:
            entry = self.workspace.restore(name)
            self.deleted = [e for e in self.deleted if e.name != name]
            self._adopt(self.workspace, self.workspace.load())
            self._changed()
            return entry

    def undo_delete(self) -> TrashEntry:
        """Restore the latest deletion of this run."""
        with self.lock:
            if not self.deleted:
                raise ValueError("nothing deleted since the studio started")
            return self.restore(self.deleted[-1].name)

    def set_hidden(self, primitive: str, demo: str, hidden: bool) -> None:
        with self.lock:
            (self.hidden.add if hidden else self.hidden.discard)((primitive, demo))
            self._changed(refit=False)

    def set_learning(
        self,
        n_basis: int | None,
        width: float | None,
        shrinkage: object = KEEP,
        noise_scale: object = KEEP,
    ) -> None:
        """Change the learning settings.

        ``n_basis`` and ``width`` None: the basis, its width and the noise scale are chosen
        from the demonstrations by every fit (the engine's automatic settings). Otherwise they
        are given, and so is ``noise_scale`` when passed (a positive factor; None leaves it to
        the fit). ``shrinkage``: a float in (0, 1], or None for the automatic pooled prior.
        What is omitted is kept as it is.
        """
        with self.lock:
            settings = dict(self.settings)
            if n_basis is None and width is None:
                for name in FALLBACK:  # back to the automatic choice: absent means automatic
                    settings.pop(name, None)
            else:
                settings["n_basis"], settings["width"] = int(n_basis), float(width)
                if noise_scale is None:
                    settings.pop("noise_scale", None)
                elif noise_scale is not KEEP:
                    settings["noise_scale"] = float(noise_scale)
            if shrinkage is not KEEP:
                settings["shrinkage"] = None if shrinkage is None else float(shrinkage)
            Settings(**settings)  # validates
            self._save_index(settings=settings)
            self.settings = settings
            self._changed(recheck=False)

    def resolved_settings(self) -> Settings:
        """The settings with every automatic one at the value the current model chose (its
        fallback value while no model is learned): what a fit of one primitive's
        demonstrations uses, e.g. for typicality, without choosing again."""
        with self.lock:
            settings = self.learning_settings()
            model = self.model
            if model is None or not settings.automatic:
                return settings.with_fallback()
            return replace(
                settings, **{name: getattr(model.settings, name) for name in settings.automatic}
            )

    def use_imported_model(self, model: ProMPModel | None, source: str = "") -> None:
        """Infer with ``model`` (e.g. read from an uploaded file) instead of the model learned
        from the demonstrations, until the demonstrations or learning settings next change;
        None goes back to the learned model. Not written to the workspace."""
        with self.lock:
            if model is not None and model.layout != self.layout:
                raise ValueError(
                    f"the model's modalities {list(model.layout.columns)} are not the "
                    f"workspace's {list(self.layout.columns)}"
                )
            self.imported_model = model
            self.imported_from = source if model is not None else ""
            self._changed(refit=False)

    def replace(self, data: WorkspaceData, label: str = "replaced workspace") -> TrashEntry:
        """Swap the whole session for ``data`` (an import), on disk first; the current
        demonstrations and index go to the trash, restorable as one entry."""
        with self.lock:
            Settings(**data.settings)
            trashed = self.workspace.replace_all(data, label)
            self.hidden.clear()
            self.typicality.clear()
            self._adopt(self.workspace, self.workspace.load())
            self.deleted.append(trashed)
            self._changed()
            return trashed

    def switch(self, root: Path, data: WorkspaceData) -> None:
        """Create a new workspace at ``root`` (absent or empty) holding ``data`` and serve it
        instead of the current one, which stays as it is on disk."""
        with self.lock:
            Settings(**data.settings)
            workspace = Workspace.create(root, data)
            self.hidden.clear()
            self.typicality.clear()
            self.deleted = []
            self._adopt(workspace, workspace.load())
            self._changed()
