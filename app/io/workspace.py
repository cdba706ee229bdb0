"""The workspace: a folder of plain files holding a studio session.

::

    WORKSPACE/
      studio.json                     format, version, the layout of modalities, primitives
                                      (name, colour, order), learning settings, the hand's
                                      frame (app.io.hand_frame), where imported demonstrations
                                      came from (app.io.demo_sources)
      demos/<primitive>/<demo>.csv    one demonstration each, the engine's CSV format
      raw/<primitive>/<demo>_<time>.csv
                                      each recorded take as it was sampled, before its idle
                                      ends were trimmed (never read as a demonstration)
      trash/                          what was deleted or replaced (app.io.trash), restorable
      runs/<time>-<name>/             evaluation runs (app.io.runs_folder; never demonstrations)

The studio only ever writes inside a folder that is absent, empty, or already a studio
workspace (it has ``studio.json``): :func:`inspect_folder` tells them apart, and any other
folder (a user's recordings, say) is refused untouched. It deletes nothing: a deleted
demonstration or primitive, and a replaced workspace, move to ``trash/``.

Every write is atomic (temporary file, fsync, rename), and each demonstration is its own file,
so killing the studio at any moment loses nothing already recorded and never leaves a
half-written file. A new workspace is built in a sibling folder and renamed into place, so it
appears whole or not at all. Restarting reads the same files back: the session is restored
exactly. Mutations validate their input first and raise ``ValueError`` without touching the
disk when it is wrong.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

from app.io.demo_checks import DemoChecks
from app.io.demo_sources import DemoSources
from app.io.hand_frame import ICUB_FRAME, HandFrame
from app.io.runs_folder import RUN_KIND, RUNS_DIR
from app.io.trash import Trash, TrashEntry
from app.io.workspace_index import (
    INDEX_NAME,
    Index,
    PrimitiveEntry,
    check_color,
    check_index,
    check_layout,
    check_name,
    index_json,
)
from promp.data import Demonstration, Layout
from promp.datasets import read_csv_demo, write_csv_demo
from promp.files import atomic_write_text
from promp.model import Settings
from promp.names import natural_sorted
from robots.icub.layout import STUDIO_LAYOUT

DEMOS_DIR = "demos"
RAW_DIR = "raw"  # untrimmed takes: kept for the record, not loaded


@dataclass
class WorkspaceData:
    """Everything a workspace holds, in memory."""

    primitives: list[PrimitiveEntry] = field(default_factory=list)
    demos: dict[str, list[Demonstration]] = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)  # files that could not be read
    layout: Layout = STUDIO_LAYOUT
    checks: DemoChecks = DemoChecks()  # what the user kept despite findings (app.io.demo_checks)
    frame: HandFrame = ICUB_FRAME  # the hand's frame: the demos are in the iCub's once placed
    sources: DemoSources = DemoSources()  # where imported demos came from (app.io.demo_sources)

    @property
    def n_demos(self) -> int:
        return sum(len(v) for v in self.demos.values())


class FolderKind(Enum):
    ABSENT = "absent"
    EMPTY = "empty"
    WORKSPACE = "workspace"
    FOREIGN = "foreign"


def inspect_folder(root: Path) -> tuple[FolderKind, str]:
    """What is at ``root``, and, for a folder the studio must not use, a message that says
    what is there and what to do.

    Raises
    ------
    ValueError
        If ``root`` exists and is not a folder.
    """
    root = Path(root)
    if not root.exists():
        return FolderKind.ABSENT, ""
    if not root.is_dir():
        raise ValueError(f"workspace {root} exists and is not a folder")
    if (root / INDEX_NAME).is_file():
        return FolderKind.WORKSPACE, ""
    # Only runs/ (``promp.evaluate --run`` wrote one first): the workspace is made around it.
    entries = [p for p in root.iterdir() if p.name != RUNS_DIR or not p.is_dir()]
    if not entries:
        return FolderKind.EMPTY, ""
    files = 0
    examples: list[str] = []
    for path in natural_sorted(root.rglob("*"), key=lambda p: p.relative_to(root)):
        if path.is_file():
            files += 1
            if len(examples) < 3:
                examples.append(path.relative_to(root).as_posix())
    what = f"{files} file(s) (e.g. {', '.join(examples)})" if files else "only empty folders"
    return FolderKind.FOREIGN, (
        f"{root} holds {what} and is not a studio workspace (it has no {INDEX_NAME}); the "
        "studio changes nothing there. To open these recordings, import them into a new "
        f"workspace: --import-dataset {root} --format records|csv --workspace NEW_FOLDER; or "
        "choose an absent or empty --workspace folder"
    )


class Workspace:
    """A studio session on disk (see the module docstring). Not thread-safe by itself: the
    :class:`app.core.store.Store` serialises access."""

    def __init__(self, root: Path):
        self.root = Path(root)
        if self.root.exists() and not self.root.is_dir():
            raise ValueError(f"workspace {self.root} exists and is not a folder")
        self.trash = Trash(self.root)

    @property
    def index_path(self) -> Path:
        return self.root / INDEX_NAME

    def demo_dir(self, primitive: str) -> Path:
        return self.root / DEMOS_DIR / check_name(primitive)

    def demo_path(self, primitive: str, demo: str) -> Path:
        return self.demo_dir(primitive) / f"{check_name(demo, 'demonstration')}.csv"

    @staticmethod
    def relative_demo_dir(primitive: str) -> str:
        return f"{DEMOS_DIR}/{check_name(primitive)}"

    # ------------------------------------------------------------------ creating

    @classmethod
    def create(cls, root: Path, data: WorkspaceData) -> Workspace:
        """A new workspace at ``root`` holding ``data``; ``root`` must be absent or empty.

        Built in a hidden sibling folder, then renamed to ``root``: a failure or a crash
        leaves ``root`` as it was.

        Raises
        ------
        ValueError
            ``root`` holds something, or ``data`` is invalid (nothing is written then).
        """
        root = Path(root)
        kind, message = inspect_folder(root)
        if kind not in (FolderKind.ABSENT, FolderKind.EMPTY):
            raise ValueError(message or f"{root} is already a studio workspace")
        _check_data(data)
        root.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{root.name}.creating-", dir=root.parent))
        try:
            _write_all(staging, data)
            if kind is FolderKind.EMPTY and (root / RUNS_DIR).is_dir():
                # The runs stay where they are: the demonstrations, then the index, move in.
                os.rename(staging / DEMOS_DIR, root / DEMOS_DIR)
                os.rename(staging / INDEX_NAME, root / INDEX_NAME)
                staging.rmdir()
                return cls(root)
            if kind is FolderKind.EMPTY:
                root.rmdir()  # refuses unless still empty
            os.rename(staging, root)
        except BaseException:
            if staging.exists():
                shutil.rmtree(staging)  # the studio's own half-built folder
            raise
        return cls(root)

    # ------------------------------------------------------------------ reading

    def read_index(self) -> Index:
        try:
            index = json.loads(self.index_path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ValueError(f"{self.index_path}: not a readable workspace index ({exc})") from exc
        return check_index(index, str(self.index_path))

    def load(self) -> WorkspaceData:
        """Read the whole workspace. Unreadable demonstration files are skipped and reported in
        ``problems`` (the rest of the session still opens); a corrupt index is an error."""
        data = WorkspaceData()
        if not self.index_path.exists():
            return data
        index = self.read_index()
        data.primitives, data.settings, data.layout = index.primitives, index.settings, index.layout
        data.checks, data.frame, data.sources = index.checks, index.frame, index.sources
        data.demos = {entry.name: [] for entry in data.primitives}
        for entry in data.primitives:
            folder = self.demo_dir(entry.name)
            if not folder.is_dir():
                continue
            for path in natural_sorted(folder.glob("*.csv"), key=lambda p: p.name):
                try:
                    demo = read_csv_demo(path)
                    demo.select(data.layout.columns)
                except ValueError as exc:
                    data.problems.append(str(exc))
                    continue
                data.demos[entry.name].append(demo)
        return data

    # ------------------------------------------------------------------ writing

    def save_index(
        self,
        primitives: Sequence[PrimitiveEntry],
        settings: Mapping,
        layout: Layout,
        checks: DemoChecks,
        frame: HandFrame = ICUB_FRAME,
        sources: DemoSources | None = None,
    ) -> None:
        text = index_json(primitives, settings, layout, checks, frame, sources)
        atomic_write_text(self.index_path, text)

    def write_demo(self, primitive: str, demo: Demonstration, layout: Layout) -> Path:
        """Write one demonstration (its ``name`` is the file stem), atomically."""
        path = self.demo_path(primitive, demo.name)
        _write_demo(path, demo, layout)
        return path

    def write_raw(self, primitive: str, demo: Demonstration, layout: Layout) -> Path:
        """Keep an untrimmed take (its ``name`` is the file stem) in ``raw/<primitive>/``,
        atomically; the loader never reads it."""
        path = self.root / RAW_DIR / check_name(primitive) / f"{demo.name}.csv"
        _write_demo(path, demo, layout)
        return path

    def rename_primitive(self, old: str, new: str) -> None:
        source, target = self.demo_dir(old), self.demo_dir(new)
        if target.exists():
            raise ValueError(f"a folder for primitive {new!r} already exists")
        if source.exists():
            source.rename(target)

    # ------------------------------------------------------------------ trash

    def trash_demo(self, primitive: PrimitiveEntry, demo: str) -> TrashEntry:
        """Move one demonstration's file to the trash."""
        path = self.demo_path(primitive.name, demo)
        relative = path.relative_to(self.root).as_posix()
        return self.trash.put(
            "demo",
            f"{demo} of {primitive.name}",
            [relative],
            {"primitive": primitive.name, "color": list(primitive.color), "demo": demo},
        )

    def trash_primitive(self, primitive: PrimitiveEntry, position: int) -> TrashEntry:
        """Move a primitive's folder of demonstrations to the trash (the caller has already
        taken it out of the index)."""
        return self.trash.put(
            "primitive",
            primitive.name,
            [self.relative_demo_dir(primitive.name)],
            {"primitive": primitive.name, "color": list(primitive.color), "position": position},
        )

    def replace_all(self, data: WorkspaceData, label: str = "replaced workspace") -> TrashEntry:
        """Make the workspace hold ``data`` (an import): the current index and demonstrations
        go to the trash first, as one entry that restores them.

        The new content is written in full in a staging folder before anything moves; the
        index is replaced last, in one rename.
        """
        _check_data(data)
        staging = Path(tempfile.mkdtemp(prefix=".staging-", dir=self.root))
        try:
            _write_all(staging, data)
            entry = self._trash_content(label)
            os.rename(staging / DEMOS_DIR, self.root / DEMOS_DIR)
            os.replace(staging / INDEX_NAME, self.index_path)
        finally:
            if staging.exists():
                shutil.rmtree(staging)  # the studio's own staging folder
        return entry

    def _trash_content(self, label: str) -> TrashEntry:
        """The index (copied: it stays until replaced) and the demonstrations (moved) into one
        trash entry of kind ``workspace``."""
        return self.trash.put("workspace", label, [DEMOS_DIR], copies=(INDEX_NAME,))

    def restore(self, name: str) -> TrashEntry:
        """Put a trash entry back; the index is updated to list what comes back.

        A demonstration whose primitive is gone brings the primitive back (with its colour);
        a primitive comes back at its place in the list; a replaced workspace swaps with the
        current one (which goes to the trash in turn).

        Raises
        ------
        ValueError
            Unknown entry, missing files, or a name already taken (nothing changes then).
        """
        entry = self.trash.get(name)
        missing = self.trash.missing(entry)
        if missing:
            raise ValueError(f"cannot restore {entry.label}: {', '.join(missing)} is gone")
        if entry.kind == "workspace":
            if INDEX_NAME not in entry.paths:
                raise ValueError(f"cannot restore {entry.label}: it has no {INDEX_NAME}")
            staging = self.trash.root / entry.name / "files"
            check_index(
                json.loads((staging / INDEX_NAME).read_text(encoding="utf-8")),
                f"{entry.label} ({INDEX_NAME})",
            )
            self._trash_content(f"workspace replaced by restoring {entry.when}")
            self.index_path.unlink()  # its copy is in the trash entry just made
            self.trash.take_back(entry)
            return entry
        if entry.kind == RUN_KIND:  # an evaluation run's folder, back in runs/
            self.trash.take_back(entry)
            return entry
        index = self.read_index()
        primitives = list(index.primitives)
        meta = entry.meta
        name_, color = str(meta.get("primitive", "")), meta.get("color", [128, 128, 128])
        known = {p.name for p in primitives}
        if entry.kind == "primitive":
            if name_ in known:
                raise ValueError(
                    f"cannot restore primitive {name_!r}: a primitive of that name exists; "
                    "rename it first"
                )
            position = min(max(int(meta.get("position", len(primitives))), 0), len(primitives))
            primitives.insert(position, PrimitiveEntry(check_name(name_), check_color(color)))
        elif name_ not in known:
            primitives.append(PrimitiveEntry(check_name(name_), check_color(color)))
        self.trash.take_back(entry)
        if [p.name for p in primitives] != [p.name for p in index.primitives]:
            self.save_index(primitives, index.settings, index.layout, index.checks, index.frame,
                            index.sources)  # fmt: skip
        return entry


def _check_data(data: WorkspaceData) -> None:
    check_layout(data.layout)
    for entry in data.primitives:
        check_name(entry.name)
        check_color(entry.color)
        names = [d.name for d in data.demos.get(entry.name, [])]
        for demo_name in names:
            check_name(demo_name, "demonstration")
        if len(set(names)) != len(names):
            raise ValueError(f"primitive {entry.name!r} has two demonstrations of one name")
    Settings(**data.settings)


def _write_demo(path: Path, demo: Demonstration, layout: Layout) -> None:
    values = demo.select(layout.columns)
    write_csv_demo(path, Demonstration(demo.times, values, layout.columns, name=demo.name))


def _write_all(root: Path, data: WorkspaceData) -> None:
    """Write ``data`` as a workspace in the (new) folder ``root``: demos, then the index."""
    for entry in data.primitives:
        folder = root / DEMOS_DIR / entry.name
        folder.mkdir(parents=True, exist_ok=True)
        for demo in data.demos.get(entry.name, []):
            _write_demo(folder / f"{demo.name}.csv", demo, data.layout)
    (root / DEMOS_DIR).mkdir(parents=True, exist_ok=True)
    atomic_write_text(
        root / INDEX_NAME,
        index_json(data.primitives, data.settings, data.layout, data.checks, data.frame,
                   data.sources),
    )
