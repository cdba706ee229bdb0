"""The workspace as the studio holds it: what is on disk, as one immutable value.

:class:`Store` owns the workspace folder. Every mutation validates first, writes the
workspace (atomically, :mod:`app.io.workspace`), then publishes a new
:class:`app.core.store_state.StoreState`: readers take :attr:`Store.state` (one attribute read,
no lock) and never see a half-made change. A lock serialises the writers (GUI callbacks run on
viser's thread pool, a take is saved on a worker). After each mutation the store tells its
listeners (the learner, which refits when what is learned from changed:
:attr:`StoreState.learn_version`).

The checks of :mod:`promp.quality` run again whenever the demonstrations change: a flagged
demonstration the user did not keep is left out of learning (:attr:`StoreState.learned`).
Deleting a demonstration or a primitive, and replacing the workspace, move the files to the
workspace's trash (:mod:`app.io.trash`); :meth:`Store.restore` puts them back. The store's
modalities are its workspace's layout: the studio's hand and head for the workspaces it
creates, whatever an imported dataset holds otherwise.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from types import MappingProxyType

import numpy as np

from app.core.store_state import (
    Key,
    StoreState,
    adopted,
    after_trashing,
    frozen_demos,
    next_demo_name,
    save_index,
    to_score,
    with_scores,
)
from app.io.dataset_import import safe_name
from app.io.runs_folder import RUN_KIND, trash_run
from app.io.trash import TrashEntry
from app.io.workspace import FolderKind, Workspace, WorkspaceData, inspect_folder
from app.io.workspace_index import PALETTE, PrimitiveEntry, check_color, check_name
from promp.data import Demonstration
from promp.gaps import repair_gaps
from promp.model import FALLBACK, Settings
from promp.typicality import Typicality

KEEP = object()  # Store.set_learning: leave a setting as it is



class Store:
    """The workspace on disk and in memory (see the module docstring)."""

    def __init__(self, workspace: Workspace, data: WorkspaceData):
        self._lock = threading.RLock()
        self._listeners: list[Callable[[StoreState], None]] = []
        self._state = adopted(workspace, data, version=0, learn_version=0)

    @classmethod
    def open(cls, root: Path, default: Callable[[], WorkspaceData] | None = None) -> Store:
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
    def state(self) -> StoreState:
        """The latest state (lock-free: a reference to an immutable value)."""
        return self._state

    def on_change(self, callback: Callable[[StoreState], None]) -> None:
        """Call ``callback(state)`` after every change (from the thread that made it, under
        the store's lock: keep it short)."""
        self._listeners.append(callback)

    # ------------------------------------------------------------------ publishing

    def _publish(self, state: StoreState, learn: bool = True, recheck: bool = True) -> None:
        """Make ``state`` the current one (lock held): its version counted, the findings
        found again when ``recheck`` (the demonstrations changed), ``learn`` when what is
        learned from changed; then tell the listeners."""
        old = self._state
        changes: dict = {"version": old.version + 1}
        if learn:
            changes["learn_version"] = old.learn_version + 1
        if recheck:
            changes["findings"] = tuple(state.checks.findings(state.demos, state.layout))
        self._state = replace(state, **changes)
        for callback in list(self._listeners):
            callback(self._state)


    # ------------------------------------------------------------------ primitives

    def create_primitive(self, name: str, color: tuple[int, int, int] | None = None) -> None:
        with self._lock:
            state = self._state
            check_name(name)
            if name in state.names:
                raise ValueError(f"a primitive named {name!r} already exists")
            if color is None:
                color = PALETTE[len(state.primitives) % len(PALETTE)]
            primitives = (*state.primitives, PrimitiveEntry(name, check_color(color)))
            demos = frozen_demos({**state.demos, name: []})
            new = replace(state, primitives=primitives, demos=demos)
            state.workspace.demo_dir(name).mkdir(parents=True, exist_ok=True)
            save_index(new)
            self._publish(new, learn=False, recheck=False)

    def rename_primitive(self, old: str, new: str) -> None:
        with self._lock:
            state = self._state
            state.color(old)
            check_name(new)
            if new == old:
                return
            if new in state.names:
                raise ValueError(f"a primitive named {new!r} already exists")
            state.workspace.rename_primitive(old, new)

            def renamed(mapping: Mapping[Key, object]) -> dict:
                return {(new if p == old else p, d): v for (p, d), v in mapping.items()}

            after = replace(
                state,
                primitives=tuple(replace(p, name=new) if p.name == old else p
                                 for p in state.primitives),  # fmt: skip
                demos=frozen_demos({new if n == old else n: d for n, d in state.demos.items()}),
                checks=state.checks.renamed(old, new),
                sources=state.sources.renamed(old, new),
                takes=frozenset(renamed(dict.fromkeys(state.takes))),
            )
            save_index(after)
            self._publish(after)

    def recolor_primitive(self, name: str, color: tuple[int, int, int]) -> None:
        with self._lock:
            state = self._state
            state.color(name)
            rgb = check_color(color)
            after = replace(state, primitives=tuple(
                replace(p, color=rgb) if p.name == name else p for p in state.primitives
            ))  # fmt: skip
            save_index(after)
            self._publish(after, learn=False, recheck=False)

    def delete_primitive(self, name: str) -> TrashEntry:
        """Take the primitive out and move its demonstrations to the trash."""
        with self._lock:
            state = self._state
            state.color(name)
            entry = next(p for p in state.primitives if p.name == name)
            after = replace(
                state,
                primitives=tuple(p for p in state.primitives if p.name != name),
                demos=frozen_demos({n: items for n, items in state.demos.items() if n != name}),
            )
            save_index(after)
            trashed = state.workspace.trash_primitive(entry, state.primitives.index(entry))
            self._publish(after_trashing(after, trashed))
            return trashed

    # ------------------------------------------------------------------ demonstrations

    def add_demo(
        self,
        primitive: str,
        times: np.ndarray,
        values: np.ndarray,
        raw: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> Demonstration:
        """Store a new demonstration (times (n,), values (n, D) in the layout's column order):
        written to disk before it joins the workspace, one of :attr:`StoreState.takes` (the
        learner scores it; until then it is pending, :mod:`app.io.demo_scores`). ``raw``,
        the (times, values) of the take it
        was trimmed from, is kept in the workspace's ``raw/`` folder (named after the
        demonstration and the time). Returns the demonstration (with its name)."""
        with self._lock:
            state = self._state
            state.color(primitive)
            columns, workspace = state.layout.columns, state.workspace
            times = np.asarray(times, dtype=float)
            name = next_demo_name(state, primitive)
            demo = Demonstration(times - times[0], values, columns, name=name)
            workspace.write_demo(primitive, demo, state.layout)
            if raw is not None:
                raw_times = np.asarray(raw[0], dtype=float)
                stamp = time.strftime("%Y%m%d-%H%M%S")
                untrimmed = Demonstration(
                    raw_times - raw_times[0], raw[1], columns, name=f"{name}_{stamp}"
                )
                workspace.write_raw(primitive, untrimmed, state.layout)
            after = replace(
                state,
                demos=frozen_demos({**state.demos, primitive: (*state.demos[primitive], demo)}),
                takes=state.takes | {(primitive, name)},
                checks=to_score(state, {(primitive, name)}),
            )
            save_index(after)
            self._publish(after)
            return demo

    def delete_demo(self, primitive: str, demo: str) -> TrashEntry:
        """Move a demonstration to the trash."""
        with self._lock:
            state = self._state
            state.color(primitive)
            if demo not in {d.name for d in state.demos[primitive]}:
                raise ValueError(f"primitive {primitive!r} has no demonstration {demo!r}")
            entry = next(p for p in state.primitives if p.name == primitive)
            trashed = state.workspace.trash_demo(entry, demo)
            kept = tuple(d for d in state.demos[primitive] if d.name != demo)
            after = replace(state, demos=frozen_demos({**state.demos, primitive: kept}))
            self._publish(after_trashing(after, trashed))
            return trashed

    def restore(self, name: str) -> TrashEntry:
        """Put the trash entry ``name`` back (see :meth:`app.io.workspace.Workspace.restore`)."""
        with self._lock:
            state = self._state
            entry = state.workspace.restore(name)
            deleted = tuple(e for e in state.deleted if e.name != name)
            if entry.kind == RUN_KIND:  # an evaluation run: no demonstration came back
                trash = tuple(state.workspace.trash.entries())
                self._publish(replace(state, deleted=deleted, trash=trash), False, False)
                return entry
            self._reload(state.workspace, deleted)
            return entry

    def trash_run(self, folder: str) -> TrashEntry:
        """Move the evaluation run ``folder`` to the trash (:mod:`app.io.runs_folder`)."""
        with self._lock:
            trashed = trash_run(self._state.workspace.trash, folder)
            self._publish(after_trashing(self._state, trashed), learn=False, recheck=False)
            return trashed

    def undo_delete(self) -> TrashEntry:
        """Restore the latest deletion of this run."""
        with self._lock:
            if not self._state.deleted:
                raise ValueError("nothing deleted since the studio started")
            return self.restore(self._state.deleted[-1].name)

    # ------------------------------------------------------------------ learning

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
        with self._lock:
            state = self._state
            settings = dict(state.settings)
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
            after = replace(state, settings=MappingProxyType(settings))
            save_index(after)
            self._publish(after, recheck=False)

    def set_kept(self, primitive: str, demo: str, kept: bool) -> None:
        """Learn from a flagged demonstration after all (``kept``), or leave it out again (the
        default); stored in the workspace's index, the file never touched."""
        with self._lock:
            state = self._state
            state.color(primitive)
            if demo not in {d.name for d in state.demos[primitive]}:
                raise ValueError(f"primitive {primitive!r} has no demonstration {demo!r}")
            checks = state.checks.keep(primitive, demo, kept)
            if checks == state.checks:
                return
            after = replace(state, checks=checks)
            save_index(after)
            self._publish(after, recheck=False)

    def repair_gap(self, primitive: str, demo: str, mode: str) -> list[Demonstration]:
        """New demonstrations from ``demo``'s gap repaired (:func:`promp.gaps.repair_gaps`:
        ``"cut"`` keeps the part before the gap, ``"split"`` every part), written beside it
        (``<demo>-cut``, ``<demo>-part1``...); ``demo`` itself stays as it is (flagged).

        Raises
        ------
        ValueError
            Unknown primitive or demonstration, no gap, an unknown mode.
        """
        with self._lock:
            state = self._state
            state.color(primitive)
            original = next((d for d in state.demos[primitive] if d.name == demo), None)
            if original is None:
                raise ValueError(f"primitive {primitive!r} has no demonstration {demo!r}")
            parts = repair_gaps(original, mode)
            if parts == [original]:
                raise ValueError(f"{demo} has no gap in its timestamps")
            # never over a file already there (one the store could not read, say)
            folder = state.workspace.demo_dir(primitive)
            taken = {d.name for d in state.demos[primitive]} | {p.stem for p in folder.glob("*")}
            made = []
            for k, part in enumerate(parts, start=1):
                suffix = "cut" if mode == "cut" else f"part{k}"
                name = safe_name(f"{demo[: 40 - len(suffix) - 1]}-{suffix}", taken)
                made.append(Demonstration(part.times, part.values, part.columns, name=name))
            for part in made:
                state.workspace.write_demo(primitive, part, state.layout)
            demos = {**state.demos, primitive: (*state.demos[primitive], *made)}
            after = replace(state, demos=frozen_demos(demos),
                            checks=to_score(state, {(primitive, part.name) for part in made}))
            save_index(after)
            self._publish(after)
            return made

    def keep_scores(self, scored: Sequence[tuple[str, Demonstration, Typicality | None]]) -> None:
        """Keep the typicality the learner gave (primitive, the demonstration scored, its score
        or None: too few others) in the workspace's index, for the demonstrations the workspace
        still holds (these very ones: one recorded again under the name is another)."""
        with self._lock:
            after = with_scores(self._state, scored)
            if after is None:
                return
            save_index(after)
            self._publish(after, learn=False, recheck=False)

    # ------------------------------------------------------------------ whole workspaces

    def replace(self, data: WorkspaceData, label: str = "replaced workspace") -> TrashEntry:
        """Swap the whole workspace for ``data`` (an import), on disk first; the current
        demonstrations and index go to the trash, restorable as one entry."""
        with self._lock:
            state = self._state
            Settings(**data.settings)
            trashed = state.workspace.replace_all(data, label)
            self._reload(state.workspace, (*state.deleted, trashed), fresh=True)
            return trashed

    def switch(self, root: Path, data: WorkspaceData) -> None:
        """Create a new workspace at ``root`` (absent or empty) holding ``data`` and serve it
        instead of the current one, which stays as it is on disk."""
        with self._lock:
            Settings(**data.settings)
            workspace = Workspace.create(root, data)
            self._reload(workspace, (), fresh=True)

    def _reload(
        self, workspace: Workspace, deleted: tuple[TrashEntry, ...], fresh: bool = False
    ) -> None:
        """Publish what ``workspace`` holds on disk; this run's takes carried over unless
        ``fresh`` (another workspace's content)."""
        state = self._state
        kept = {} if fresh else {"takes": state.takes}
        new = adopted(workspace, workspace.load(), state.version, state.learn_version,
                            deleted=deleted, **kept)  # fmt: skip
        self._publish(new, recheck=False)
