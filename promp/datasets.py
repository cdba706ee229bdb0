"""Dataset readers and writers: the CSV folder format and the lab-record format.

CSV folder format (the engine's own)::

    DATASET/<primitive>/<demo>.csv      header row, column ``t`` (seconds) then named columns

Lab-record format (``lab-records-heights``)::

    DATASET/<class>/<any sub-folders>/<record>.txt   whitespace-separated, 13 columns

The class of a record is its first-level folder; deeper folders (one per person) are grouped
under it. Columns: 0 time (s), 1-3 hand in the haptic device's frame, 4-9 force and moment, 10-12
hand position in the robot's root frame. Rows whose six wrench values are all -1 have no wrench
reading: when a layout uses the ``wrench`` modality those rows are **dropped** (the phase of
every sample comes from its time stamp, so the remaining samples keep their true phase);
otherwise they are kept, since their positions are valid.
"""

from __future__ import annotations

import csv
import io
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from promp.data import Demonstration, Layout, Modality

Dataset = dict[str, list[Demonstration]]

RECORD_COLUMNS = (
    "t", "device_x", "device_y", "device_z",
    "fx", "fy", "fz", "mx", "my", "mz",
    "x", "y", "z",
)  # fmt: skip
WRENCH_COLUMNS = ("fx", "fy", "fz", "mx", "my", "mz")
RECORD_MODALITIES = {
    "position": Modality("position", ("x", "y", "z"), unit="m", kind="linear"),
    "wrench": Modality("wrench", WRENCH_COLUMNS, unit="N|N m", kind="linear"),
}


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that a crash leaves either the old file or the new one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def demo_to_csv(demo: Demonstration) -> str:
    """CSV text of ``demo``: header ``t,<columns>``, numbers with 17 significant digits
    (an exact float64 round trip)."""
    buffer = io.StringIO()
    buffer.write(",".join(("t", *demo.columns)) + "\n")
    table = np.column_stack([demo.times, demo.values])
    np.savetxt(buffer, table, delimiter=",", fmt="%.17g")
    return buffer.getvalue()


def write_csv_demo(path: Path, demo: Demonstration) -> None:
    """Write ``demo`` as one CSV file of the folder format, atomically."""
    atomic_write_text(Path(path), demo_to_csv(demo))


def read_csv_demo(path: Path) -> Demonstration:
    """Read one CSV demonstration (header row with a ``t`` column, then named columns).

    Raises
    ------
    ValueError
        If the file is not such a CSV: no header, no ``t`` column, ragged or non-numeric rows,
        NaN/inf values, fewer than 2 samples, times not increasing.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: cannot read as text ({exc})") from exc
    return demo_from_csv(text, name=path.stem, label=str(path))


def demo_from_csv(text: str, name: str = "", label: str = "CSV") -> Demonstration:
    """Parse the CSV text of one demonstration (the inverse of :func:`demo_to_csv`).

    ``label`` names the source in error messages (a path, an archive member).

    Raises
    ------
    ValueError
        As :func:`read_csv_demo`.
    """
    rows = [row for row in csv.reader(io.StringIO(text)) if any(cell.strip() for cell in row)]
    if not rows:
        raise ValueError(f"{label}: empty file, expected a header row 't,<columns>' and samples")
    header = [cell.strip() for cell in rows[0]]
    if "t" not in header:
        raise ValueError(f"{label}: the header {header} has no 't' (time in seconds) column")
    if len(rows) < 2:
        raise ValueError(f"{label}: no samples after the header")
    if any(len(row) != len(header) for row in rows[1:]):
        raise ValueError(f"{label}: every row must have {len(header)} values like the header")
    try:
        table = np.array([[float(cell) for cell in row] for row in rows[1:]], dtype=float)
    except ValueError as exc:
        raise ValueError(f"{label}: non-numeric value ({exc})") from exc
    t_index = header.index("t")
    columns = [column for i, column in enumerate(header) if i != t_index]
    values = np.delete(table, t_index, axis=1)
    try:
        return Demonstration(table[:, t_index], values, tuple(columns), name=name)
    except ValueError as exc:
        raise ValueError(f"{label}: {exc}") from exc


def _sorted_files(folder: Path, pattern: str) -> list[Path]:
    return sorted(p for p in folder.rglob(pattern) if p.is_file() and not p.name.startswith("."))


def load_csv_dataset(root: Path, layout: Layout | None = None) -> Dataset:
    """Read ``root/<primitive>/<demo>.csv`` into {primitive: [demonstrations]}.

    When ``layout`` is given, every demonstration must have its columns.
    """
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"dataset folder {root} does not exist")
    dataset: Dataset = {}
    for folder in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        demos = [read_csv_demo(p) for p in _sorted_files(folder, "*.csv")]
        if demos:
            dataset[folder.name] = demos
    if not dataset:
        raise ValueError(f"{root}: no <primitive>/<demo>.csv files found")
    if layout is not None:
        check_columns(dataset, layout.columns)
    return dataset


def write_csv_dataset(root: Path, dataset: Dataset) -> None:
    """Write {primitive: [demos]} as ``root/<primitive>/<demo name or index>.csv``."""
    for primitive, demos in dataset.items():
        for i, demo in enumerate(demos):
            write_csv_demo(Path(root) / primitive / f"{demo.name or f'demo{i:03d}'}.csv", demo)


def read_record(path: Path, drop_missing_wrench: bool = False) -> Demonstration:
    """Read one lab record (13 whitespace-separated columns, see the module docstring)."""
    path = Path(path)
    try:
        table = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: not a lab record ({exc})") from exc
    if table.shape[1] != len(RECORD_COLUMNS):
        raise ValueError(
            f"{path}: a lab record has {len(RECORD_COLUMNS)} columns, "
            f"this file has {table.shape[1]}"
        )
    if drop_missing_wrench:
        wrench = table[:, 4:10]
        table = table[~np.all(wrench == -1.0, axis=1)]
    name = "/".join(path.parts[-2:])[: -len(path.suffix)]
    try:
        return Demonstration(table[:, 0], table[:, 1:], RECORD_COLUMNS[1:], name=name)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc


def load_records_dataset(root: Path, modalities: Sequence[str] = ("position",)) -> Dataset:
    """Read the lab-record format into {class: [demonstrations]} (see the module docstring)."""
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"dataset folder {root} does not exist")
    drop = "wrench" in modalities
    dataset: Dataset = {}
    for folder in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        demos = [read_record(p, drop) for p in _sorted_files(folder, "*.txt")]
        if demos:
            dataset[folder.name] = demos
    if not dataset:
        raise ValueError(f"{root}: no <class>/.../<record>.txt files found")
    return dataset


def records_layout(modalities: Sequence[str] = ("position",)) -> Layout:
    """The layout of the predefined lab-record modalities ``position`` and ``wrench``."""
    unknown = [m for m in modalities if m not in RECORD_MODALITIES]
    if unknown:
        raise ValueError(
            f"unknown lab-record modality {unknown}; available: {sorted(RECORD_MODALITIES)}"
        )
    return Layout(tuple(RECORD_MODALITIES[m] for m in modalities))


def check_columns(dataset: Dataset, columns: Sequence[str]) -> None:
    """Raise ValueError naming the first demonstration that lacks one of ``columns``."""
    for primitive, demos in dataset.items():
        for demo in demos:
            missing = [c for c in columns if c not in demo.columns]
            if missing:
                raise ValueError(
                    f"{primitive}/{demo.name}: missing column(s) {missing}; "
                    f"it has {list(demo.columns)}"
                )
