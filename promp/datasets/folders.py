"""What the folder readers share: the class folders and files of a dataset, in natural order,
the name of a demonstration, and a demonstration of the samples that can be placed in time."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from promp.data import Demonstration, check_values
from promp.names import natural_sorted
from promp.quality import Finding, increasing_samples, timestamp_finding

__all__ = [
    "Dataset", "check_columns", "class_folders", "demo_name", "placed_in_time", "sorted_files"
]  # fmt: skip

Dataset = dict[str, list[Demonstration]]


def placed_in_time(
    times: np.ndarray,
    values: np.ndarray,
    columns: Sequence[str],
    name: str,
    label: str,
    primitive: str,
    findings: list[Finding],
) -> Demonstration:
    """The demonstration of the samples that can be placed in time
    (:func:`promp.quality.increasing_samples`), with a ``timestamps`` finding appended to
    ``findings`` when some could not; ValueError (naming ``label``) when it is not a
    demonstration (values not finite, fewer than two samples left...)."""
    check_values(times, values, label)  # NaN times cannot be ordered: say so, as for values
    keep = increasing_samples(times)
    finding = timestamp_finding(times, keep, primitive, name, label)
    try:
        demo = Demonstration(times[keep], values[keep], tuple(columns), name=name)
    except ValueError as exc:
        raise ValueError(f"{label}: {exc}" + (f" ({finding.message})" if finding else "")) from exc
    if finding is not None:
        findings.append(finding)
    return demo


def sorted_files(folder: Path, pattern: str) -> list[Path]:
    return natural_sorted(
        (p for p in folder.rglob(pattern) if p.is_file() and not p.name.startswith(".")),
        key=lambda p: p.relative_to(folder),
    )


def class_folders(root: Path) -> list[Path]:
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"dataset folder {root} does not exist")
    return natural_sorted(
        (p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")),
        key=lambda p: p.name,
    )


def demo_name(path: Path, class_folder: Path) -> str:
    """The file's path below its class folder, without the suffix (``person1/record0``)."""
    return path.relative_to(class_folder).with_suffix("").as_posix()


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
