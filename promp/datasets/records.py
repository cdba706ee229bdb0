"""The lab-record format (``lab-records-heights``): ``DATASET/<class>/<any sub-folders>/
<record>.txt``, whitespace-separated, 13 columns: 0 time (s), 1-3 hand in the haptic device's
frame, 4-9 force and moment, 10-12 hand position in the robot's root frame. Rows whose six
wrench values are all -1 have no wrench reading: when a layout uses a wrench column those rows
are dropped (the phase of every sample comes from its time stamp, so the remaining samples keep
their true phase); otherwise they are kept, since their positions are valid."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from promp.data import Demonstration
from promp.datasets.folders import Dataset, class_folders, demo_name, placed_in_time, sorted_files
from promp.quality import Finding

__all__ = ["RECORD_COLUMNS", "WRENCH_COLUMNS", "load_records_dataset", "read_record"]

RECORD_COLUMNS = (
    "t", "device_x", "device_y", "device_z",
    "fx", "fy", "fz", "mx", "my", "mz",
    "x", "y", "z",
)  # fmt: skip
WRENCH_COLUMNS = ("fx", "fy", "fz", "mx", "my", "mz")


def _record_table(path: Path, drop_missing_wrench: bool) -> np.ndarray:
    """The rows of one lab record (13 columns; unchecked times)."""
    try:
        if not path.read_bytes().strip():
            raise ValueError(f"{path}: empty file: a lab record needs at least 2 samples")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # numpy's "input contained no data"
            table = np.loadtxt(path, ndmin=2)
    except OSError as exc:
        raise ValueError(f"{path}: cannot be read ({exc})") from exc
    except ValueError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ValueError(f"{path}: not a lab record ({exc})") from exc
    if table.shape[1] != len(RECORD_COLUMNS):
        raise ValueError(
            f"{path}: a lab record has {len(RECORD_COLUMNS)} columns, "
            f"this file has {table.shape[1]}"
        )
    if drop_missing_wrench:
        wrench = table[:, 4:10]
        table = table[~np.all(wrench == -1.0, axis=1)]
    return table


def read_record(path: Path, drop_missing_wrench: bool = False, name: str = "") -> Demonstration:
    """Read one lab record (13 whitespace-separated columns, see the module docstring)."""
    path = Path(path)
    table = _record_table(path, drop_missing_wrench)
    name = name or path.with_suffix("").name
    try:
        return Demonstration(table[:, 0], table[:, 1:], RECORD_COLUMNS[1:], name=name)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc


def load_records_dataset(
    root: Path, drop_missing_wrench: bool = False, findings: list[Finding] | None = None
) -> Dataset:
    """Read the lab-record format into {class: [demonstrations]} (see the module docstring).

    A demonstration is named by its path below the class folder (``person1/record0``).
    ``findings``: as :func:`promp.datasets.csv_folder.load_csv_dataset`.
    """
    dataset: Dataset = {}
    root = Path(root)
    for folder in class_folders(root):
        demos = []
        for path in sorted_files(folder, "*.txt"):
            name = demo_name(path, folder)
            if findings is None:
                demos.append(read_record(path, drop_missing_wrench, name=name))
                continue
            table = _record_table(path, drop_missing_wrench)
            label = path.relative_to(root).as_posix()
            demos.append(
                placed_in_time(
                    table[:, 0], table[:, 1:], RECORD_COLUMNS[1:], name, label, folder.name,
                    findings,
                )
            )  # fmt: skip
        if demos:
            dataset[folder.name] = demos
    if not dataset:
        raise ValueError(f"{root}: no <class>/.../<record>.txt files found")
    return dataset
