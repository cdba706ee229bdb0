"""Dataset readers and writers: the CSV folder format (:mod:`promp.datasets.csv_folder`), the
lab-record format (:mod:`promp.datasets.records`), and the recordings of rigs (YARP logs, ROS
bags, XDF, C3D: :mod:`promp.rigs`); which columns form which modality
(:mod:`promp.datasets.modalities`).

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

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from promp.data import Layout, Modality
from promp.datasets.csv_folder import (
    demo_from_csv,
    demo_to_csv,
    load_csv_dataset,
    read_csv_demo,
    write_csv_dataset,
    write_csv_demo,
)
from promp.datasets.folders import Dataset, check_columns, class_folders, sorted_files
from promp.datasets.modalities import (
    GUESSED,
    KNOWN_COLUMNS,
    MODALITY_NAME,
    command_line_modalities,
    format_modalities,
    given_modalities,
    guess_layout,
    modality_from_columns,
    modality_options,
    modality_specs,
    parse_modalities,
    parse_modality,
    read_mapping_file,
)
from promp.datasets.records import (
    RECORD_COLUMNS,
    WRENCH_COLUMNS,
    load_records_dataset,
    read_record,
)
from promp.quality import Finding, dataset_findings
from promp.rigs import RIG_FORMATS, RigOptions, guessed_rig_mapping, read_rig_dataset
from promp.rigs.mapping import SourcedModality

__all__ = [
    "FORMATS", "GUESSED", "KNOWN_COLUMNS", "MODALITY_NAME", "RECORD_COLUMNS", "WRENCH_COLUMNS",
    "Dataset", "DatasetRead", "check_columns", "command_line_modalities", "dataset_columns",
    "demo_from_csv", "demo_to_csv", "format_modalities", "given_modalities", "guess_layout",
    "guessed_mapping", "load_csv_dataset", "load_records_dataset", "modality_from_columns",
    "modality_options", "modality_specs", "parse_modalities", "parse_modality",
    "read_csv_demo", "read_dataset", "read_mapping_file", "read_record", "refused_with_guess",
    "write_csv_dataset", "write_csv_demo",
]  # fmt: skip

FORMATS = ("records", "csv", *RIG_FORMATS)


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
    file of every demonstration (relative to the folder).

    Attributes
    ----------
    dataset : dict of str to list of Demonstration
        ``{primitive (class) name: demonstrations}``, in the natural order of their files.
    layout : Layout
        The modalities the demonstrations are used with (given, or guessed from the columns).
    findings : tuple of Finding
        Every finding of the checks, by demonstration in reading order.
    files : dict of (str, str) to str
        ``{(primitive, demonstration): its file, relative to the folder}``.
    mapping : str
        Recordings: the mapping used, in its syntax (guessed when not given).
    notes : tuple of str
        Recordings: the streams found, what was left out, the clock.
    """

    dataset: Dataset
    layout: Layout
    findings: tuple[Finding, ...]
    files: dict[tuple[str, str], str]
    mapping: str = ""  # recordings: the mapping used, in its syntax (guessed when not given)
    notes: tuple[str, ...] = ()  # recordings: streams found, what was left out, the clock


def read_dataset(
    root: Path,
    format: str,
    modalities: Sequence[Modality | str] | str | None = None,
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
    modalities : sequence of Modality or str, or str, optional
        Which columns form which modality (for recordings, which stream's fields:
        ``NAME=STREAM:FIELD,...``, :mod:`promp.rigs.mapping`): :class:`Modality` objects or
        mapping strings (``"hand=x,y,z"``, ``["hand=/pose:pose.position.{x,y,z}@mm"]``,
        parsed by :func:`given_modalities`). Default: guessed from the columns
        (:func:`guess_layout`; for records, ``hand`` = x, y, z, the hand in the robot's root
        frame) or from the first recording's streams (:func:`guessed_mapping` gives the
        guess alone).
    rig : RigOptions, optional
        For recordings: how sessions are cut and the time base (default: cut by markers when
        a recording has some, the slowest stream's times).

    Returns
    -------
    DatasetRead
        The demonstrations, their layout, the findings and the file of each.

    Raises
    ------
    ValueError
        Unknown format, no demonstrations, an unreadable file (named), modalities that are
        neither :class:`Modality` objects nor mapping strings, or a modality naming a column
        (a stream, a field) that a demonstration (a recording) lacks (named).
    """
    if format not in FORMATS:
        raise ValueError(f"unknown dataset format {format!r}; expected one of {FORMATS}")
    modalities = given_modalities(modalities)
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


def guessed_mapping(root: Path, format: str) -> str:
    """The modalities :func:`read_dataset` guesses for ``root`` when none is given, in the
    mapping syntax (``;`` between modalities): from the first recording's streams, the first
    CSV file's header, or the lab records' columns. '' when nothing can be guessed (no file,
    or the first one unreadable), so that a refusal can still show the guess to edit."""
    try:
        if format in RIG_FORMATS:
            return guessed_rig_mapping(Path(root), format)
        if format == "records":
            return format_modalities(guess_layout(RECORD_COLUMNS[1:]))
        if format == "csv":
            first = next(p for f in class_folders(Path(root)) for p in sorted_files(f, "*.csv"))
            return format_modalities(guess_layout(read_csv_demo(first).columns))
    except (ValueError, OSError, StopIteration):
        pass
    return ""


def refused_with_guess(exc: ValueError, root: Path, format: str) -> ValueError:
    """The refusal ``exc`` of reading ``root`` with guessed modalities, followed by the guess
    as ``--modality`` options to edit and paste (:func:`modality_options`); ``exc`` itself when
    nothing can be guessed."""
    guess = guessed_mapping(root, format)
    if not guess:
        return exc
    return ValueError(
        f"{exc}\nThe modalities guessed (edit them, then pass them back): "
        f"{modality_options(guess)}"
    )


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
