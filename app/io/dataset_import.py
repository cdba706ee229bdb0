"""Bringing a researcher's own recordings into the studio: a dataset becomes a new workspace.

A dataset is a folder in one of the formats of :mod:`promp.datasets` (``csv``:
``<primitive>/<demo>.csv``; ``records``: the 13-column lab records, ``<class>/.../<record>.txt``;
the recordings of a rig, :mod:`promp.rigs`: YARP dumps, ROS bags, XDF, C3D), read by the same
:func:`promp.datasets.read_dataset` as ``python -m promp.evaluate``, with a layout of
modalities given or guessed from the columns (from the streams). It arrives either as a folder
on the server (``python -m app --import-dataset DIR``) or as an uploaded zip of that folder (the
Data tab), checked member by member like a workspace archive (no absolute paths, ``..``, links
or encrypted members; bounded) and extracted into a temporary folder the studio removes; a
session file (``.bag``, ``.mcap``, ``.db3``, ``.xdf``, ``.c3d``: cut by its markers) as it is.

The source is only read. Names become safe file names (``person1/record0`` becomes
``person1_record0``). Refused, with the file or class named and nothing written: no
demonstration, an unreadable or non-numeric file, a class of fewer than two demonstrations, a
modality naming a column the files lack, a ``hand`` that is not 3 columns in metres.
"""

from __future__ import annotations

import dataclasses
import io
import re
import shutil
import tempfile
import zipfile
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from app.io.demo_checks import DemoChecks
from app.io.demo_scores import DemoScores
from app.io.demo_sources import DemoSources
from app.io.hand_frame import HandFrame, imported_frame
from app.io.workspace import WorkspaceData
from app.io.workspace_index import PALETTE, PrimitiveEntry, check_layout
from app.io.zip_members import Limits, check_member, format_size
from promp.data import Demonstration, Layout, Modality
from promp.datasets import FORMATS, RECORD_COLUMNS, Dataset, dataset_columns, read_dataset
from promp.quality import Finding
from promp.rigs import RigOptions
from promp.rigs.mapping import unique_name
from promp.units import unitless_note

MIN_DEMOS = 2
MAX_DATASET_UPLOAD_BYTES = 200 * 2**20
# A session file uploaded on its own, by suffix; and how a zip's files tell its format.
SESSION_FILES = {".bag": "rosbag", ".mcap": "rosbag", ".db3": "rosbag", ".xdf": "xdf",
                 ".xdfz": "xdf", ".c3d": "c3d"}  # fmt: skip


def safe_name(raw: str, taken: set[str]) -> str:
    """``raw`` as a studio name (1-40 of letters, digits, '_', '-'), unique among ``taken``."""
    return unique_name(raw, taken, "demo", "d", "-", letter_first=False)


@dataclass(frozen=True)
class DatasetSummary:
    """What an import would create: one line per primitive, for the GUI's preview."""

    source: str
    format: str
    layout: Layout
    counts: dict[str, int]
    columns: tuple[str, ...]
    findings: tuple[Finding, ...] = ()  # what the checks found, named by the dataset's files
    mapping: str = ""  # recordings: the mapping of streams to modalities used
    notes: tuple[str, ...] = ()  # recordings: streams found, what was left out, the clock
    files: dict[tuple[str, str], str] = field(default_factory=dict)  # demo -> its source

    @property
    def n_demos(self) -> int:
        return sum(self.counts.values())

    @property
    def unused(self) -> tuple[str, ...]:
        """The dataset's columns that no modality uses (left out of the workspace)."""
        used = set(self.layout.columns)
        return tuple(c for c in self.columns if c not in used)

    def findings_lines(self, limit: int = 12) -> list[str]:
        """The checks' findings in words: a headline, then one line per finding (at most
        ``limit``, then how many more)."""
        if not self.findings:
            return ["Checks: nothing found (no gap, jump, still take, odd rate or duration, "
                    "round trip, nor start or end far from the others')."]
        flagged = {f.key for f in self.findings}
        lines = [
            f"Checks: {len(self.findings)} finding(s) in {len(flagged)} demonstration(s); "
            "these are left out of learning until kept in Teach > Demonstrations (their "
            "files are imported as they are):"
        ]
        if note := unitless_note(self.layout.modalities):
            lines.append(f"({note})")
        lines += [f"{f.where}: {f.message}" for f in self.findings[:limit]]
        if len(self.findings) > limit:
            lines.append(f"... and {len(self.findings) - limit} more")
        return lines

    def demonstrations_lines(self, limit: int = 12) -> list[str]:
        """The demonstrations found, one line each with where they come from (at most
        ``limit``, then how many more)."""
        items = list(self.files.items())
        lines = [f"{primitive}/{demo} ← {source}" for (primitive, demo), source in items[:limit]]
        if len(items) > limit:
            lines.append(f"... and {len(items) - limit} more")
        return lines

    def describe(self) -> str:
        classes = ", ".join(f"{name} ({n})" for name, n in self.counts.items())
        modalities = "; ".join(
            f"{m.name} = {','.join(m.columns)}" + (f" ({m.unit})" if m.unit else "")
            for m in self.layout.modalities
        )
        return (
            f"{len(self.counts)} primitives, {self.n_demos} demonstrations: {classes}. "
            f"Modalities: {modalities}."
        )


def compact_columns(columns: Sequence[str]) -> str:
    """``columns`` listed, runs of numbered ones shortened: ``hx, hy, hz, e0..e7``."""
    parts: list[str] = []
    run: list[tuple[str, int]] = []  # (prefix, number) of consecutive numbered columns

    def flush() -> None:
        if len(run) > 2:
            parts.append(f"{run[0][0]}{run[0][1]}..{run[-1][0]}{run[-1][1]}")
        else:
            parts.extend(f"{prefix}{n}" for prefix, n in run)
        run.clear()

    for column in columns:
        match = re.fullmatch(r"(.*?)(\d+)", column)
        if match and run and match.group(1) == run[-1][0] and int(match.group(2)) == run[-1][1] + 1:
            run.append((match.group(1), int(match.group(2))))
            continue
        flush()
        if match and match.group(2) == str(int(match.group(2))):
            run.append((match.group(1), int(match.group(2))))
        else:
            parts.append(column)
    flush()
    return ", ".join(parts)


def placed(data: WorkspaceData, frame: HandFrame) -> WorkspaceData:
    """``data`` (imported, as recorded) with the hand in the iCub's frame by ``frame`` and the
    partner's positions beside the partner (:func:`app.io.hand_frame.imported_frame`), which
    the workspace keeps (:mod:`app.io.hand_frame`)."""
    frame = imported_frame(frame, data.demos, data.layout)
    return dataclasses.replace(data, demos=frame.placed(data.demos, data.layout), frame=frame)


def dataset_to_workspace(
    dataset: Dataset, layout: Layout, findings: Sequence[Finding] = ()
) -> WorkspaceData:
    """The workspace holding ``dataset`` with ``layout`` (names made safe, colours assigned,
    each one's path below its class folder in ``data.sources``), the readers' ``findings``
    (:func:`promp.datasets.read_dataset`) not found again from the stored files, under the
    new names (``data.checks.imported``); each is to be scored (:mod:`app.io.demo_scores`).

    Raises
    ------
    ValueError
        A class with fewer than two demonstrations, or a layout the studio cannot use.
    """
    check_layout(layout)
    small = {name: len(demos) for name, demos in dataset.items() if len(demos) < MIN_DEMOS}
    if small:
        listed = ", ".join(
            f"{name!r} ({n}: {dataset[name][0].name if dataset[name] else 'none'})"
            for name, n in small.items()
        )
        raise ValueError(
            f"class {listed} has fewer than {MIN_DEMOS} demonstrations; a primitive is learned "
            "from at least two. Add demonstrations or leave the class out of the dataset"
        )
    taken: set[str] = set()
    primitives: list[PrimitiveEntry] = []
    demos: dict[str, list[Demonstration]] = {}
    renamed: dict[tuple[str, str], tuple[str, str]] = {}
    sources: dict[tuple[str, str], str] = {}
    for k, (raw, items) in enumerate(dataset.items()):
        name = safe_name(raw, taken)
        primitives.append(PrimitiveEntry(name, PALETTE[k % len(PALETTE)]))
        names: set[str] = set()
        demos[name] = []
        for d in items:
            demo_name = safe_name(d.name, names)
            renamed[(raw, d.name)] = (name, demo_name)
            sources[(name, demo_name)] = d.name
            demos[name].append(
                Demonstration(
                    d.times - d.times[0], d.select(layout.columns), layout.columns, demo_name
                )
            )
    imported = tuple(
        dataclasses.replace(f, primitive=renamed[f.key][0], demo=renamed[f.key][1])
        for f in findings
        if f.kind == "timestamps" and f.key in renamed
    )
    to_score = DemoScores(pending=frozenset(renamed.values()))
    return WorkspaceData(
        primitives=primitives,
        demos=demos,
        settings={},
        layout=layout,
        checks=DemoChecks(imported=imported, scores=to_score),
        sources=DemoSources.of(sources),
    )


def read_folder(
    source: Path,
    format: str,
    modalities: Sequence[Modality] | None = None,
    rig: RigOptions | None = None,
) -> tuple[WorkspaceData, DatasetSummary]:
    """Read the dataset folder (or session file) ``source`` as a workspace's content, and its
    summary (with what the checks found, named by the dataset's files)."""
    read = read_dataset(Path(source), format, modalities, rig)
    dataset, layout = read.dataset, read.layout
    data = dataset_to_workspace(dataset, layout, read.findings)
    columns = RECORD_COLUMNS[1:] if format == "records" else dataset_columns(dataset)
    summary = DatasetSummary(
        str(source), format, layout, {p.name: len(data.demos[p.name]) for p in data.primitives},
        tuple(columns), read.findings, read.mapping, read.notes, dict(read.files),
    )  # fmt: skip
    return data, summary


def detect_format(folder: Path) -> str:
    """The format of the files under ``folder`` (or of the session file ``folder``): a rig's
    recordings by their files (``data.log``, ``.bag``/``.mcap``/``.db3``/``metadata.yaml``,
    ``.xdf``, ``.c3d``), else ``csv`` when it holds .csv files, ``records`` for .txt files."""
    folder = Path(folder)
    paths = [folder] if folder.is_file() else [p for p in folder.rglob("*") if p.is_file()]
    suffixes = {p.suffix.lower() for p in paths}
    names = {p.name for p in paths}
    if "data.log" in names:
        return "yarp"
    if "metadata.yaml" in names:
        return "rosbag"
    for suffix, format in SESSION_FILES.items():
        if suffix in suffixes:
            return format
    if ".csv" in suffixes:
        return "csv"
    if ".txt" in suffixes:
        return "records"
    raise ValueError(
        "no .csv or .txt files nor recordings: a dataset is <primitive>/<demo>.csv files, lab "
        "records <class>/.../<record>.txt, or a rig's recordings (YARP data.log folders, ROS "
        "bags, .xdf, .c3d)"
    )


@dataclass
class DatasetUpload:
    """An uploaded dataset zip, extracted into a temporary folder the studio owns; re-read
    with other settings through :meth:`read`, then :meth:`close` removes the folder.

    ``root`` is the dataset's folder inside it: the temporary folder itself, or the one folder
    it holds when the zip was made of the dataset's folder.
    """

    filename: str
    tempdir: Path
    root: Path
    format: str
    ignored: list[str] = field(default_factory=list)

    def read(
        self,
        format: str | None = None,
        modalities: Sequence[Modality] | None = None,
        rig: RigOptions | None = None,
    ) -> tuple[WorkspaceData, DatasetSummary]:
        format = format or self.format
        if format not in FORMATS:
            raise ValueError(f"unknown dataset format {format!r}; expected one of {FORMATS}")
        try:
            data, summary = read_folder(self.root, format, modalities, rig)
        except ValueError as exc:
            # Paths inside the temporary folder mean nothing to the user: name the member.
            raise ValueError(str(exc).replace(str(self.root), self.filename)) from None
        return data, dataclasses.replace(summary, source=self.filename)

    def close(self) -> None:
        if self.tempdir.exists():
            shutil.rmtree(self.tempdir)  # the temporary folder this object made


_ZIP_ERRORS = (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, NotImplementedError,
               RuntimeError, EOFError, OSError)  # fmt: skip


def extract_dataset_zip(
    content: bytes, filename: str, limits: Limits | None = None
) -> DatasetUpload:
    """Check and extract an uploaded dataset zip, or store an uploaded session file (a ROS
    bag, an XDF or C3D file) in a temporary folder (see the module docstring).

    Raises
    ------
    ValueError
        Empty, too large, not a zip, an unsafe or oversized member, or no data files; the
        message names the member. Nothing is left on disk then.
    """
    limits = limits or Limits(max_upload_bytes=MAX_DATASET_UPLOAD_BYTES)
    if len(content) > limits.max_upload_bytes:
        raise ValueError(
            f"the file is {format_size(len(content))}, over the "
            f"{format_size(limits.max_upload_bytes)} upload limit"
        )
    if not content:
        raise ValueError("the file is empty")
    suffix = PurePosixPath(filename).suffix.lower()
    if suffix in SESSION_FILES:
        return _session_file(content, filename, SESSION_FILES[suffix])
    if suffix != ".zip":
        raise ValueError(
            "a dataset is uploaded as a .zip of its folder, or a session file "
            f"({', '.join(SESSION_FILES)}) as it is"
        )
    try:
        archive = zipfile.ZipFile(io.BytesIO(content))
    except (*_ZIP_ERRORS, ValueError) as exc:
        raise ValueError(f"not a zip archive ({exc})") from None
    tempdir = Path(tempfile.mkdtemp(prefix="icub-studio-dataset-"))
    upload = DatasetUpload(filename, tempdir, tempdir, "csv")
    try:
        with archive:
            _extract(archive, tempdir, limits, upload.ignored)
        # A zip of the dataset folder itself (one folder holding folders): its classes are
        # one level down. (One folder of files is a dataset of one class.)
        entries = list(tempdir.iterdir())
        if len(entries) == 1 and entries[0].is_dir():
            if any(p.is_dir() for p in entries[0].iterdir()):
                upload.root = entries[0]
        upload.format = detect_format(upload.root)
    except ValueError:
        upload.close()
        raise
    except _ZIP_ERRORS as exc:
        upload.close()
        raise ValueError(f"cannot be read as a zip archive ({exc})") from None
    return upload


def _session_file(content: bytes, filename: str, format: str) -> DatasetUpload:
    """A session file in a temporary folder of its own (its name made safe)."""
    path = PurePosixPath(filename.replace("\\", "/"))
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", path.stem).strip("._") or "session"
    tempdir = Path(tempfile.mkdtemp(prefix="icub-studio-dataset-"))
    target = tempdir / f"{stem[:60]}{path.suffix.lower()}"
    try:
        target.write_bytes(content)
    except OSError as exc:
        shutil.rmtree(tempdir)
        raise ValueError(f"cannot be stored ({exc})") from None
    return DatasetUpload(filename, tempdir, tempdir, format)


def _extract(
    archive: zipfile.ZipFile, folder: Path, limits: Limits, ignored: list[str]
) -> None:
    infos = archive.infolist()
    if len(infos) > limits.max_members:
        raise ValueError(f"the archive holds {len(infos)} entries; at most {limits.max_members}")
    total = sum(info.file_size for info in infos)
    if total > limits.max_uncompressed_bytes:
        raise ValueError(
            f"the archive expands to {format_size(total)}, over the "
            f"{format_size(limits.max_uncompressed_bytes)} limit"
        )
    budget = limits.max_uncompressed_bytes
    seen: set[str] = set()
    for info in infos:
        name = check_member(info)
        parts = name.rstrip("/").split("/")
        if info.is_dir():
            continue
        if parts[0] == "__MACOSX" or any(p.startswith(".") for p in parts):
            ignored.append(name)  # Finder's and hidden files
            continue
        if name.lower() in seen:
            raise ValueError(f"{name}: appears twice in the archive")
        seen.add(name.lower())
        target = folder.joinpath(*parts)
        target.parent.mkdir(parents=True, exist_ok=True)
        with archive.open(info) as source:
            data = source.read(min(info.file_size, budget) + 1)
        if len(data) > info.file_size or len(data) > budget:
            raise ValueError(f"{name}: larger than the archive declares")
        budget -= len(data)
        with open(target, "xb") as sink:
            sink.write(data)
