"""Dataset readers and writers: the CSV folder format and the lab-record format, and the
recordings of rigs (YARP logs, ROS bags, XDF, C3D: :mod:`promp.rigs`).

CSV folder format (the engine's own)::

    DATASET/<primitive>/<demo>.csv      header row, column ``t`` (seconds) then named columns

Lab-record format (``lab-records-heights``)::

    DATASET/<class>/<any sub-folders>/<record>.txt   whitespace-separated, 13 columns

The class of a record is its first-level folder; deeper folders (one per person) are grouped
under it. Columns: 0 time (s), 1-3 hand in the haptic device's frame, 4-9 force and moment, 10-12
hand position in the robot's root frame. Rows whose six wrench values are all -1 have no wrench
reading: when a layout uses a wrench column those rows are **dropped** (the phase of every
sample comes from its time stamp, so the remaining samples keep their true phase); otherwise
they are kept, since their positions are valid.

:func:`read_dataset` is the one entry point of every format (the evaluation and the studio's
import use it): it reads a folder and pairs it with a layout of modalities, given or guessed
from the columns.
"""

from __future__ import annotations

import csv
import io
import os
import re
import tempfile
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from promp.data import Demonstration, Kind, Layout, Modality, check_values
from promp.names import natural_sorted
from promp.quality import Finding, dataset_findings, increasing_samples, timestamp_finding
from promp.rigs import RIG_FORMATS, RigOptions, read_rig_dataset
from promp.rigs.mapping import SourcedModality, parse_sourced

Dataset = dict[str, list[Demonstration]]

RECORD_COLUMNS = (
    "t", "device_x", "device_y", "device_z",
    "fx", "fy", "fz", "mx", "my", "mz",
    "x", "y", "z",
)  # fmt: skip
WRENCH_COLUMNS = ("fx", "fy", "fz", "mx", "my", "mz")


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


def _placed_in_time(
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


def _sorted_files(folder: Path, pattern: str) -> list[Path]:
    return natural_sorted(
        (p for p in folder.rglob(pattern) if p.is_file() and not p.name.startswith(".")),
        key=lambda p: p.relative_to(folder),
    )


def _class_folders(root: Path) -> list[Path]:
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"dataset folder {root} does not exist")
    return natural_sorted(
        (p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")),
        key=lambda p: p.name,
    )


def _demo_name(path: Path, class_folder: Path) -> str:
    """The file's path below its class folder, without the suffix (``person1/record0``)."""
    return path.relative_to(class_folder).with_suffix("").as_posix()


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
    for folder in _class_folders(root):
        demos = []
        for path in _sorted_files(folder, "*.csv"):
            name = _demo_name(path, folder)
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
                _placed_in_time(times, values, columns, name, label, folder.name, findings)
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
    ``findings``: as :func:`load_csv_dataset`.
    """
    dataset: Dataset = {}
    root = Path(root)
    for folder in _class_folders(root):
        demos = []
        for path in _sorted_files(folder, "*.txt"):
            name = _demo_name(path, folder)
            if findings is None:
                demos.append(read_record(path, drop_missing_wrench, name=name))
                continue
            table = _record_table(path, drop_missing_wrench)
            label = path.relative_to(root).as_posix()
            demos.append(
                _placed_in_time(
                    table[:, 0], table[:, 1:], RECORD_COLUMNS[1:], name, label, folder.name,
                    findings,
                )
            )  # fmt: skip
        if demos:
            dataset[folder.name] = demos
    if not dataset:
        raise ValueError(f"{root}: no <class>/.../<record>.txt files found")
    return dataset


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


# ------------------------------------------------------------------------------ modalities

FORMATS = ("records", "csv", *RIG_FORMATS)
# Unit and kind of the column names the readers know; any other column is a dimensionless
# linear signal unless a modality says otherwise.
KNOWN_COLUMNS: dict[str, tuple[str, Kind]] = {
    **{c: ("m", "linear") for c in ("x", "y", "z", "device_x", "device_y", "device_z")},
    **{c: ("rad", "angle") for c in ("roll", "pitch", "yaw")},
    **{c: ("N", "linear") for c in ("fx", "fy", "fz")},
    **{c: ("N m", "linear") for c in ("mx", "my", "mz")},
}
MODALITY_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,39}$")
# The modalities guessed from a header, in this order, when all their columns exist.
GUESSED = (
    ("hand", ("x", "y", "z")),
    ("head", ("roll", "pitch", "yaw")),
)


def modality_from_columns(name: str, columns: Sequence[str]) -> Modality:
    """A modality over ``columns`` with the unit and kind their names imply.

    Columns all named roll/pitch/yaw are angles (radians); columns of one known unit take it;
    mixed known units are joined with ``|``; unknown names have no unit.
    """
    if not MODALITY_NAME.match(name or ""):
        raise ValueError(
            f"invalid modality name {name!r}: use 1-40 letters, digits, '_' or '-', "
            "starting with a letter"
        )
    columns = tuple(columns)
    known = [KNOWN_COLUMNS.get(c) for c in columns]
    if columns and all(k is not None and k[1] == "angle" for k in known):
        return Modality(name, columns, unit="rad", kind="angle")
    units = list(dict.fromkeys(k[0] if k is not None else "" for k in known))
    return Modality(name, columns, unit="|".join(units) if any(units) else "", kind="linear")


def parse_modality(spec: str) -> Modality:
    """``"NAME=COL,COL,..."`` (as on the command line) as a :class:`Modality`; for
    recordings, ``"NAME=STREAM:FIELD,...[@UNIT]"`` (:mod:`promp.rigs.mapping`) as a
    :class:`promp.rigs.mapping.SourcedModality`."""
    name, sep, cols = str(spec).partition("=")
    if any(mark in cols for mark in ":@{"):
        return parse_sourced(spec)
    columns = tuple(c.strip() for c in cols.split(",") if c.strip())
    if not sep or not name.strip() or not columns:
        raise ValueError(f"a modality is NAME=COL,COL,..., got {spec!r}")
    return modality_from_columns(name.strip(), columns)


# Where one modality ends and the next begins inside a line: spaces before ``NAME=``.
_NEXT_MODALITY = re.compile(r"\s+(?=[A-Za-z][A-Za-z0-9_-]*\s*=)")


def modality_specs(text: str) -> list[str]:
    """The modalities of ``text``, one ``NAME=...`` each: they are separated by new lines,
    ``;`` or spaces (``"hand=x,y,z emg=e0,e1"``); ``#`` starts a comment."""
    lines = (line.partition("#")[0] for line in str(text).splitlines())
    parts = (part for line in lines for part in line.split(";"))
    return [s.strip() for part in parts for s in _NEXT_MODALITY.split(part) if s.strip()]


def parse_modalities(text: str) -> tuple[Modality, ...]:
    """Several modalities, one per line or separated by ``;`` or spaces
    (:func:`modality_specs`): ``"hand=x,y,z; head=roll,pitch,yaw"``."""
    specs = modality_specs(text)
    if not specs:
        raise ValueError("name at least one modality, e.g. hand=x,y,z")
    return tuple(parse_modality(s) for s in specs)


def read_mapping_file(path: Path) -> tuple[Modality, ...]:
    """The modalities of a mapping file: one per line (or ``;``-separated), ``#`` comments."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"mapping file {path}: cannot be read ({exc})") from None
    try:
        return parse_modalities(text)
    except ValueError as exc:
        raise ValueError(f"mapping file {path}: {exc}") from None


def command_line_modalities(
    specs: Sequence[str], mapping_file: Path | str | None = None
) -> list[Modality] | None:
    """The modalities of ``--modality`` options and a ``--mapping`` file (None: guess)."""
    modalities = [parse_modality(spec) for spec in specs]
    if mapping_file:
        modalities += read_mapping_file(Path(mapping_file))
    return modalities or None


def format_modalities(layout: Layout) -> str:
    """The inverse of :func:`parse_modalities`."""
    return "; ".join(f"{m.name}={','.join(m.columns)}" for m in layout.modalities)


def guess_layout(columns: Sequence[str]) -> Layout:
    """The modalities a header suggests: ``hand`` = x, y, z and ``head`` = roll, pitch, yaw when
    those columns exist; otherwise one modality ``signal`` over every column.

    Raises
    ------
    ValueError
        If there is no column at all.
    """
    available = [c for c in columns if c != "t"]
    modalities = [
        modality_from_columns(name, cols)
        for name, cols in GUESSED
        if set(cols) <= set(available)
    ]
    if not modalities:
        if not available:
            raise ValueError("the demonstrations have no column besides the time")
        modalities = [modality_from_columns("signal", available)]
    return Layout(tuple(modalities))


def dataset_columns(dataset: Dataset) -> tuple[str, ...]:
    """The columns every demonstration of ``dataset`` has, in the first one's order."""
    demos = [d for items in dataset.values() for d in items]
    if not demos:
        return ()
    common = set(demos[0].columns).intersection(*(d.columns for d in demos[1:]))
    return tuple(c for c in demos[0].columns if c in common)


@dataclass(frozen=True, eq=False)
class DatasetRead:
    """A dataset folder as read: the demonstrations, the layout they are used with, and every
    finding of the checks (:mod:`promp.quality`: the readers' and the comparisons'), with the
    file of every demonstration (relative to the folder)."""

    dataset: Dataset
    layout: Layout
    findings: tuple[Finding, ...]
    files: dict[tuple[str, str], str]
    mapping: str = ""  # recordings: the mapping used, in its syntax (guessed when not given)
    notes: tuple[str, ...] = ()  # recordings: streams found, what was left out, the clock


def read_dataset(
    root: Path,
    format: str,
    modalities: Sequence[Modality] | None = None,
    rig: RigOptions | None = None,
) -> DatasetRead:
    """Read a dataset folder, the layout of modalities it is used with, and its findings.

    The one reader behind ``python -m promp.evaluate`` and the studio's dataset import. A
    file whose timestamps do not always increase is read without the samples that cannot be
    placed in time, and says so in a finding; nothing is left out of the dataset here
    (:func:`promp.quality.split_flagged` decides what is learned from).

    Parameters
    ----------
    root : path
        ``records``: ``root/<class>/.../<record>.txt`` (13 columns, see the module docstring);
        ``csv``: ``root/<primitive>/.../<demo>.csv`` with a header row; ``yarp``, ``rosbag``,
        ``xdf``, ``c3d``: recordings of a rig, in ``<class>/`` folders or sessions cut by
        their markers (:mod:`promp.rigs`; ``root`` may be a session file).
    format : {"records", "csv", "yarp", "rosbag", "xdf", "c3d"}
    modalities : sequence of Modality, optional
        Which columns form which modality (for recordings, which stream's fields:
        ``NAME=STREAM:FIELD,...``, :mod:`promp.rigs.mapping`). Default: guessed from the
        columns (:func:`guess_layout`; for records, ``hand`` = x, y, z, the hand in the
        robot's root frame) or from the first recording's streams.
    rig : RigOptions, optional
        For recordings: how sessions are cut and the time base (default: cut by markers when
        a recording has some, the slowest stream's times).

    Raises
    ------
    ValueError
        Unknown format, no demonstrations, an unreadable file (named), or a modality naming a
        column (a stream, a field) that a demonstration (a recording) lacks (named).
    """
    if format not in FORMATS:
        raise ValueError(f"unknown dataset format {format!r}; expected one of {FORMATS}")
    root = Path(root)
    read_findings: list[Finding] = []
    mapping, notes = "", ()
    if format in RIG_FORMATS:
        rigs = read_rig_dataset(root, format, modalities, rig)
        dataset, layout, files = rigs.dataset, Layout(rigs.modalities), rigs.files
        mapping, notes = rigs.mapping, rigs.notes
    else:
        sourced = [m.name for m in modalities or () if isinstance(m, SourcedModality)]
        if sourced:
            raise ValueError(
                f"modality {sourced[0]!r}: NAME=STREAM:FIELD (or @UNIT) is for recordings "
                f"({', '.join(RIG_FORMATS)}); {format} takes NAME=COL,COL,..."
            )
        dataset, layout = _read_table_dataset(root, format, modalities, read_findings)
        suffix = ".txt" if format == "records" else ".csv"
        files = {
            (primitive, demo.name): f"{primitive}/{demo.name}{suffix}"
            for primitive, demos in dataset.items()
            for demo in demos
        }
    findings = read_findings + dataset_findings(dataset, layout, files)
    order = {key: i for i, key in enumerate(files)}
    findings.sort(key=lambda f: order[f.key])  # stable: by demonstration, in reading order
    return DatasetRead(dataset, layout, tuple(findings), files, mapping, notes)


def _read_table_dataset(
    root: Path, format: str, modalities: Sequence[Modality] | None, findings: list[Finding]
) -> tuple[Dataset, Layout]:
    """The lab records or CSV folder under ``root`` and their layout (see :func:`read_dataset`)."""
    if format == "records":
        names = RECORD_COLUMNS[1:]
        layout = Layout(tuple(modalities)) if modalities else guess_layout(names)
        unknown = [c for c in layout.columns if c not in names]
        if unknown:
            raise ValueError(
                f"lab records have no column(s) {unknown}; their columns are {list(names)}"
            )
        uses_wrench = bool(set(layout.columns) & set(WRENCH_COLUMNS))
        return load_records_dataset(root, uses_wrench, findings), layout
    dataset = load_csv_dataset(root, findings=findings)
    if modalities:
        layout = Layout(tuple(modalities))
    else:
        layout = guess_layout(dataset_columns(dataset))
    check_columns(dataset, layout.columns)
    return dataset, layout
