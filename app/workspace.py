"""The workspace: a folder of plain files holding a studio session.

::

    WORKSPACE/
      studio.json                     primitives (name, colour, order), learning settings
      demos/<primitive>/<demo>.csv    one demonstration each, the engine's CSV format
                                      (t, x, y, z, roll, pitch, yaw)

Every write is atomic (temporary file, fsync, rename), and each demonstration is its own file,
so killing the studio at any moment loses nothing already recorded and never leaves a
half-written file. Restarting reads the same files back: the session is restored exactly.
Mutations validate their input first and raise ``ValueError`` without touching the disk when
it is wrong.
"""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from promp.data import Demonstration, Layout, Modality
from promp.datasets import atomic_write_text, read_csv_demo, write_csv_demo

FORMAT = "icub-intention-studio/workspace"
VERSION = 1
HAND = Modality("hand", ("x", "y", "z"), unit="m", kind="linear")
HEAD = Modality("head", ("roll", "pitch", "yaw"), unit="rad", kind="angle")
LAYOUT = Layout((HAND, HEAD))
COLUMNS = LAYOUT.columns
NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_\-]{0,39}$")
PALETTE = (
    (228, 87, 46),
    (41, 128, 185),
    (39, 174, 96),
    (142, 68, 173),
    (243, 156, 18),
    (22, 160, 133),
    (192, 57, 43),
    (52, 73, 94),
)


def check_name(name: str, what: str = "primitive") -> str:
    """A safe file name: letters, digits, '_' and '-', 1-40 characters."""
    if not isinstance(name, str) or not NAME_PATTERN.match(name):
        raise ValueError(
            f"invalid {what} name {name!r}: use 1-40 letters, digits, '_' or '-', "
            "starting with a letter or digit"
        )
    return name


def check_color(color: Sequence[int]) -> tuple[int, int, int]:
    rgb = tuple(int(c) for c in color)
    if len(rgb) != 3 or not all(0 <= c <= 255 for c in rgb):
        raise ValueError(f"a colour is three integers in 0-255, got {color!r}")
    return rgb  # type: ignore[return-value]


@dataclass
class PrimitiveEntry:
    name: str
    color: tuple[int, int, int]


@dataclass
class WorkspaceData:
    """Everything a workspace holds, in memory."""

    primitives: list[PrimitiveEntry] = field(default_factory=list)
    demos: dict[str, list[Demonstration]] = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)  # files that could not be read


class Workspace:
    """A studio session on disk (see the module docstring). Not thread-safe by itself: the
    :class:`app.session.Session` serialises access."""

    def __init__(self, root: Path):
        self.root = Path(root)
        if self.root.exists() and not self.root.is_dir():
            raise ValueError(f"workspace {self.root} exists and is not a folder")

    @property
    def index_path(self) -> Path:
        return self.root / "studio.json"

    def demo_dir(self, primitive: str) -> Path:
        return self.root / "demos" / check_name(primitive)

    def demo_path(self, primitive: str, demo: str) -> Path:
        return self.demo_dir(primitive) / f"{check_name(demo, 'demonstration')}.csv"

    def is_empty(self) -> bool:
        return not self.index_path.exists() and not (self.root / "demos").exists()

    # ------------------------------------------------------------------ reading

    def load(self) -> WorkspaceData:
        """Read the whole workspace. Unreadable demonstration files are skipped and reported in
        ``problems`` (the rest of the session still opens); a corrupt index is an error."""
        data = WorkspaceData()
        if not self.index_path.exists():
            return data
        try:
            index = json.loads(self.index_path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ValueError(f"{self.index_path}: not a readable workspace index ({exc})") from exc
        if not isinstance(index, Mapping) or index.get("format") != FORMAT:
            raise ValueError(f"{self.index_path}: not a studio workspace index")
        if index.get("version") != VERSION:
            raise ValueError(
                f"{self.index_path}: unsupported workspace version {index.get('version')!r}"
            )
        for entry in index.get("primitives", []):
            name = check_name(entry["name"])
            data.primitives.append(PrimitiveEntry(name, check_color(entry["color"])))
            data.demos[name] = []
        data.settings = dict(index.get("settings", {}))
        for entry in data.primitives:
            folder = self.demo_dir(entry.name)
            if not folder.is_dir():
                continue
            for path in sorted(folder.glob("*.csv")):
                try:
                    demo = read_csv_demo(path)
                    demo.select(COLUMNS)
                except ValueError as exc:
                    data.problems.append(str(exc))
                    continue
                data.demos[entry.name].append(demo)
        return data

    # ------------------------------------------------------------------ writing

    def save_index(self, primitives: Sequence[PrimitiveEntry], settings: Mapping) -> None:
        index = {
            "format": FORMAT,
            "version": VERSION,
            "layout": [
                {"name": m.name, "columns": list(m.columns), "unit": m.unit, "kind": m.kind}
                for m in LAYOUT.modalities
            ],
            "primitives": [{"name": p.name, "color": list(p.color)} for p in primitives],
            "settings": dict(settings),
        }
        atomic_write_text(self.index_path, json.dumps(index, indent=1))

    def write_demo(self, primitive: str, demo: Demonstration) -> Path:
        """Write one demonstration (its ``name`` is the file stem), atomically."""
        path = self.demo_path(primitive, demo.name)
        values = demo.select(COLUMNS)
        write_csv_demo(path, Demonstration(demo.times, values, COLUMNS, name=demo.name))
        return path

    def delete_demo(self, primitive: str, demo: str) -> None:
        self.demo_path(primitive, demo).unlink(missing_ok=True)

    def rename_primitive(self, old: str, new: str) -> None:
        source, target = self.demo_dir(old), self.demo_dir(new)
        if target.exists():
            raise ValueError(f"a folder for primitive {new!r} already exists")
        if source.exists():
            source.rename(target)

    def delete_primitive(self, name: str) -> None:
        folder = self.demo_dir(name)
        if folder.exists():
            shutil.rmtree(folder)

    def replace_all(self, data: WorkspaceData) -> None:
        """Make the workspace hold exactly ``data`` (used by imports and the default scenario).

        Written to a sibling folder first, then swapped in, so a failure leaves the old
        workspace untouched.
        """
        staging = self.root.with_name(f".{self.root.name}.import")
        if staging.exists():
            shutil.rmtree(staging)
        fresh = Workspace(staging)
        for entry in data.primitives:
            fresh.demo_dir(entry.name).mkdir(parents=True, exist_ok=True)
            for demo in data.demos.get(entry.name, []):
                fresh.write_demo(entry.name, demo)
        fresh.save_index(data.primitives, data.settings)
        old = self.root.with_name(f".{self.root.name}.old")
        if old.exists():
            shutil.rmtree(old)
        if self.root.exists():
            self.root.rename(old)
        staging.rename(self.root)
        if old.exists():
            shutil.rmtree(old)
