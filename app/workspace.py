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
from dataclasses import dataclass, field, fields
from pathlib import Path

from promp.data import Demonstration, Layout, Modality
from promp.datasets import atomic_write_text, read_csv_demo, write_csv_demo
from promp.model import Settings

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


def layout_listing(layout: Layout) -> list[dict]:
    """The modalities as ``studio.json`` lists them."""
    return [
        {"name": m.name, "columns": list(m.columns), "unit": m.unit, "kind": m.kind}
        for m in layout.modalities
    ]


def describe_layout(layout: Layout) -> str:
    return ", ".join(
        f"{m.name} = {'/'.join(m.columns)} ({m.unit}, {m.kind})" for m in layout.modalities
    )


def index_json(primitives: Sequence[PrimitiveEntry], settings: Mapping) -> str:
    """The text of ``studio.json``."""
    index = {
        "format": FORMAT,
        "version": VERSION,
        "layout": layout_listing(LAYOUT),
        "primitives": [{"name": p.name, "color": list(p.color)} for p in primitives],
        "settings": dict(settings),
    }
    return json.dumps(index, indent=1)


_SETTING_NAMES = {f.name for f in fields(Settings)}


def check_index(index: object, label: str) -> tuple[list[PrimitiveEntry], dict]:
    """The primitives and learning settings of a decoded ``studio.json``; a ``ValueError``
    starting with ``label`` says what is wrong (the workspace on disk and an imported archive
    are checked alike)."""
    if not isinstance(index, dict) or index.get("format") != FORMAT:
        raise ValueError(f"{label}: not a studio workspace index ('format' is not {FORMAT!r})")
    if index.get("version") != VERSION:
        raise ValueError(
            f"{label}: unsupported workspace version {index.get('version')!r}; "
            f"this studio reads version {VERSION}"
        )
    if "layout" in index and index["layout"] != layout_listing(LAYOUT):
        raise ValueError(
            f"{label}: the workspace's modalities are not the studio's ({describe_layout(LAYOUT)})"
        )
    raw = index.get("primitives", [])
    if not isinstance(raw, list):
        raise ValueError(f"{label}: 'primitives' must be a list")
    primitives: list[PrimitiveEntry] = []
    for i, entry in enumerate(raw):
        if not isinstance(entry, dict) or "name" not in entry or "color" not in entry:
            raise ValueError(f"{label}: primitive {i} needs a 'name' and a 'color'")
        try:
            name = check_name(entry["name"])
            color = entry["color"]
            if not (
                isinstance(color, list)
                and all(isinstance(c, int) and not isinstance(c, bool) for c in color)
            ):
                raise ValueError(f"a colour is three integers in 0-255, got {color!r}")
            rgb = check_color(color)
        except ValueError as exc:
            raise ValueError(f"{label}: {exc}") from None
        if name in {p.name for p in primitives}:
            raise ValueError(f"{label}: primitive {name!r} is listed twice")
        primitives.append(PrimitiveEntry(name, rgb))
    settings = index.get("settings", {})
    if not isinstance(settings, dict):
        raise ValueError(f"{label}: 'settings' must be an object")
    unknown = sorted(set(settings) - _SETTING_NAMES)
    if unknown:
        raise ValueError(f"{label}: unknown setting(s) {unknown}")
    if "n_basis" in settings and (
        not isinstance(settings["n_basis"], int) or isinstance(settings["n_basis"], bool)
    ):
        raise ValueError(f"{label}: 'n_basis' must be an integer, got {settings['n_basis']!r}")
    if "width" in settings and (
        not isinstance(settings["width"], (int, float)) or isinstance(settings["width"], bool)
    ):
        raise ValueError(f"{label}: 'width' must be a number, got {settings['width']!r}")
    try:
        Settings(**settings)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{label}: invalid learning settings ({exc})") from None
    return primitives, dict(settings)


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
        data.primitives, data.settings = check_index(index, str(self.index_path))
        data.demos = {entry.name: [] for entry in data.primitives}
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
        atomic_write_text(self.index_path, index_json(primitives, settings))

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
