"""The CSV folder format (the engine's own): ``DATASET/<primitive>/<demo>.csv``, a header row,
column ``t`` (seconds) then named columns; one file per demonstration, written atomically."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from promp.data import Demonstration, Layout
from promp.datasets.folders import (
    Dataset,
    check_columns,
    class_folders,
    demo_name,
    placed_in_time,
    sorted_files,
)
from promp.files import atomic_write_text
from promp.quality import Finding

__all__ = [
    "demo_from_csv", "demo_to_csv", "load_csv_dataset", "read_csv_demo", "write_csv_dataset",
    "write_csv_demo",
]  # fmt: skip


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


def read_csv_demo(path: Path, name: str = "") -> Demonstration:
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
    return demo_from_csv(text, name=name or path.stem, label=str(path))


def _csv_table(text: str, label: str) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """The times, values and column names of one CSV demonstration's text (unchecked times)."""
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
    columns = tuple(column for i, column in enumerate(header) if i != t_index)
    return table[:, t_index], np.delete(table, t_index, axis=1), columns


def demo_from_csv(text: str, name: str = "", label: str = "CSV") -> Demonstration:
    """Parse the CSV text of one demonstration (the inverse of :func:`demo_to_csv`).

    ``label`` names the source in error messages (a path, an archive member).

    Raises
    ------
    ValueError
        As :func:`read_csv_demo`.
    """
    times, values, columns = _csv_table(text, label)
    try:
        return Demonstration(times, values, columns, name=name)
    except ValueError as exc:
        raise ValueError(f"{label}: {exc}") from exc


def load_csv_dataset(
    root: Path, layout: Layout | None = None, findings: list[Finding] | None = None
) -> Dataset:
    """Read ``root/<primitive>/<demo>.csv`` into {primitive: [demonstrations]}.

    When ``layout`` is given, every demonstration must have its columns. With a ``findings``
    list, samples whose timestamps do not increase are set aside and reported there
    (:func:`promp.quality.timestamp_finding`) instead of refusing the file.
    """
    dataset: Dataset = {}
    root = Path(root)
    for folder in class_folders(root):
        demos = []
        for path in sorted_files(folder, "*.csv"):
            name = demo_name(path, folder)
            if findings is None:
                demos.append(read_csv_demo(path, name))
                continue
            try:
                text = path.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                raise ValueError(f"{path}: cannot read as text ({exc})") from exc
            times, values, columns = _csv_table(text, str(path))
            label = path.relative_to(root).as_posix()
            demos.append(
                placed_in_time(times, values, columns, name, label, folder.name, findings)
            )
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
