"""The workspace's trash: what the studio deletes or replaces is moved here, never destroyed.

::

    WORKSPACE/trash/<YYYYmmdd-HHMMSS-ffffff>-<kind>-<label>/
        entry.json            kind, label, time, and what restoring needs (e.g. the colour)
        files/<path>          the moved files, at their path relative to the workspace

Putting something in the trash writes ``entry.json`` first, then renames each file or folder
into ``files/`` (a rename within one file system: atomic, nothing is copied or rewritten).
Taking it back renames them to where they were, refusing when something is already there, then
removes the entry's own ``entry.json`` and its now empty folders. Entries are kept on disk
until the user deletes them; the studio never empties the trash.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from promp.files import atomic_write_text

TRASH_DIR = "trash"
ENTRY_FILE = "entry.json"
FILES_DIR = "files"
KINDS = ("demo", "primitive", "workspace", "run")  # run: app.io.runs_folder


@dataclass(frozen=True)
class TrashEntry:
    """One deletion or replacement, restorable.

    Attributes
    ----------
    name : str
        The entry's folder name (sorts by time).
    kind : {"demo", "primitive", "workspace", "run"}
    label : str
        What was deleted, for people ("curved_003 of curved").
    deleted_at : float
        Seconds since the epoch.
    paths : tuple of str
        The moved files and folders, relative to the workspace.
    meta : dict
        What restoring needs (the primitive's colour and place, the demonstration's name).
    """

    name: str
    kind: str
    label: str
    deleted_at: float
    paths: tuple[str, ...]
    meta: dict = field(default_factory=dict)

    @property
    def when(self) -> str:
        return time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(self.deleted_at))


class Trash:
    """The trash folder of the workspace at ``root`` (see the module docstring)."""

    def __init__(self, root: Path):
        self.workspace = Path(root)
        self.root = self.workspace / TRASH_DIR

    def put(
        self,
        kind: str,
        label: str,
        paths: list[str],
        meta: dict | None = None,
        copies: tuple[str, ...] = (),
    ) -> TrashEntry:
        """Move ``paths`` (relative to the workspace; files or folders) into a new entry, and
        copy the files ``copies`` (which stay in place until the caller replaces them).

        Paths that do not exist are left out; the entry records only what it holds.
        """
        if kind not in KINDS:
            raise ValueError(f"unknown trash entry kind {kind!r}")
        now = time.time()
        stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(now)) + f"-{int(now % 1 * 1e6):06d}"
        slug = re.sub(r"[^A-Za-z0-9_-]+", "_", label)[:40].strip("_") or kind
        self.root.mkdir(parents=True, exist_ok=True)
        folder = self.root / f"{stamp}-{kind}-{slug}"
        suffix = 1
        while True:
            try:
                folder.mkdir()
                break
            except FileExistsError:
                suffix += 1
                folder = self.root / f"{stamp}-{kind}-{slug}-{suffix}"
        present = [p for p in paths if (self.workspace / p).exists()]
        copied = [p for p in copies if (self.workspace / p).is_file()]
        entry = TrashEntry(
            folder.name, kind, label, now, (*present, *copied), dict(meta or {})
        )
        atomic_write_text(folder / ENTRY_FILE, json.dumps(_to_json(entry), indent=1))
        for relative in copied:
            target = folder / FILES_DIR / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(self.workspace / relative, target)
        for relative in present:
            target = folder / FILES_DIR / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            os.rename(self.workspace / relative, target)
        return entry

    def entries(self) -> list[TrashEntry]:
        """Every readable entry, newest first (unreadable ones are skipped)."""
        if not self.root.is_dir():
            return []
        out = []
        for folder in sorted(self.root.iterdir(), reverse=True):
            entry = self._read(folder)
            if entry is not None:
                out.append(entry)
        return out

    def get(self, name: str) -> TrashEntry:
        safe = "/" not in name and "\\" not in name and name not in ("", ".", "..")
        entry = self._read(self.root / name) if safe else None
        if entry is None:
            raise ValueError(f"the trash has no entry {name!r}")
        return entry

    def missing(self, entry: TrashEntry) -> list[str]:
        """The entry's paths that are no longer in the trash (e.g. deleted by hand)."""
        folder = self.root / entry.name / FILES_DIR
        return [p for p in entry.paths if not (folder / p).exists()]

    def take_back(self, entry: TrashEntry) -> None:
        """Move the entry's files back to where they were, then drop the entry.

        Raises
        ------
        ValueError
            A file of the entry is missing from the trash, or its place in the workspace is
            taken; nothing is moved then.
        """
        folder = self.root / entry.name
        missing = self.missing(entry)
        if missing:
            raise ValueError(f"the trash entry {entry.name} lacks {', '.join(missing)}")
        taken = [p for p in entry.paths if (self.workspace / p).exists()]
        if taken:
            raise ValueError(f"{', '.join(taken)} already exists in the workspace")
        for relative in entry.paths:
            target = self.workspace / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            os.rename(folder / FILES_DIR / relative, target)
        (folder / ENTRY_FILE).unlink()
        # Only the empty folders the entry made are left: remove them bottom-up (rmdir refuses
        # a folder that is not empty, so nothing else can go).
        for directory in sorted((p for p in folder.rglob("*") if p.is_dir()), reverse=True):
            directory.rmdir()
        folder.rmdir()

    def _read(self, folder: Path) -> TrashEntry | None:
        try:
            raw = json.loads((folder / ENTRY_FILE).read_text(encoding="utf-8"))
            entry = TrashEntry(
                name=folder.name,
                kind=str(raw["kind"]),
                label=str(raw["label"]),
                deleted_at=float(raw["deleted_at"]),
                paths=tuple(str(p) for p in raw["paths"]),
                meta=dict(raw.get("meta", {})),
            )
        except (OSError, ValueError, KeyError, TypeError):
            return None
        if entry.kind not in KINDS or any(
            p.startswith("/") or ".." in Path(p).parts for p in entry.paths
        ):
            return None
        return entry


def _to_json(entry: TrashEntry) -> dict:
    return {
        "kind": entry.kind,
        "label": entry.label,
        "deleted_at": entry.deleted_at,
        "paths": list(entry.paths),
        "meta": entry.meta,
    }
