"""Export and import files of the studio, built and checked without a browser.

Two kinds of file leave and enter the studio:

* a **model**, ``model-YYYYmmdd-HHMMSS.json``: :func:`promp.io.model_to_json` of the model
  learned from the demonstrations; robot-side code loads it with :func:`promp.io.load_model`;
* a **workspace**, ``workspace-YYYYmmdd-HHMMSS.zip`` (deflated)::

      studio.json                     layout, primitives (name, colour, order), settings
      demos/<primitive>/<demo>.csv    t and the layout's columns
      model.json                      the learned model, when there is one
      runs/<time>-<name>/...          the saved evaluation runs (app.io.runs_folder)

  the workspace folder's own format (:mod:`app.io.workspace`) plus the model; a hand placed
  in the iCub's frame at import goes back to the frame it was recorded in
  (:mod:`app.io.hand_frame`), and is placed again when the archive is read.

Reading an upload validates **everything** in memory before anything may change: a model must
parse (:func:`promp.io.model_from_json`) with primitive names the studio can use (the session
checks that its modalities are the workspace's); a workspace archive must pass the extraction
rules (:func:`check_member`: no absolute paths, ``..``, symlinks, encrypted or unexpected
members; bounded member count and uncompressed size against zip bombs) and every member must
parse (UTF-8 CSV with exactly the layout's columns, valid names, a valid ``studio.json``, a
valid ``model.json``, every run folder a ``run.json`` that reads as a run). Every problem is a
``ValueError`` whose message names the file and says what is wrong. Nothing is ever unpickled.
"""

from __future__ import annotations

import io
import json
import stat
import time
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import PurePosixPath

from app.io.runs_folder import RUNS_DIR, RunFiles, listing, run_path
from app.io.workspace import DEMOS_DIR, WorkspaceData
from app.io.workspace_index import INDEX_NAME, Index, check_index, check_name, index_json

# MAX_UPLOAD_BYTES and format_size are the callers' too (exchange.MAX_UPLOAD_BYTES...).
from app.io.zip_members import (  # noqa: F401
    MAX_UPLOAD_BYTES,
    Limits,
    check_member,
    format_size,
    member_text,
    read_member,
)
from promp.data import Demonstration, Layout
from promp.datasets import demo_from_csv, demo_to_csv
from promp.evaluate.runs import RUN_FILE, run_from_json
from promp.io import model_from_json, model_to_json
from promp.model import ProMPModel
from promp.names import natural_sorted

MODEL_NAME = "model.json"


@dataclass(frozen=True, eq=False)
class ModelUpload:
    """A validated model file."""

    filename: str
    model: ProMPModel


@dataclass(eq=False)
class WorkspaceUpload:
    """A validated workspace archive, parsed into memory; ``model`` is its model.json, if any
    (validated; the studio re-learns from the demonstrations, which are the source of truth)."""

    filename: str
    data: WorkspaceData
    model: ProMPModel | None = None
    ignored: list[str] = field(default_factory=list)  # __MACOSX/ and hidden files skipped
    runs: dict[str, dict[str, bytes]] = field(default_factory=dict)  # runs/: folder -> files

    @property
    def n_demos(self) -> int:
        return sum(len(v) for v in self.data.demos.values())


# ---------------------------------------------------------------------------------- export


def export_filename(kind: str, extension: str, when: float | None = None) -> str:
    """``<kind>-YYYYmmdd-HHMMSS.<extension>`` in local time (now by default)."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(when))
    return f"{kind}-{stamp}.{extension}"


def model_bytes(model: ProMPModel) -> bytes:
    """The model file: UTF-8 JSON (:func:`promp.io.model_to_json`)."""
    return model_to_json(model).encode("utf-8")


def workspace_zip(
    data: WorkspaceData,
    model: ProMPModel | None = None,
    when: float | None = None,
    runs: RunFiles | None = None,
) -> bytes:
    """The workspace archive of ``data`` (and ``model``), deflated.

    Parameters
    ----------
    data : WorkspaceData
        Primitives, their demonstrations (columns in any order, at least the layout's), the
        learning settings, the layout and the hand's frame: a hand placed in the iCub's frame
        at import is written back in the frame it was recorded in, the placement in
        ``studio.json`` (:mod:`app.io.hand_frame`; reading the archive places it again).
    model : ProMPModel, optional
        Stored as ``model.json`` (as learned: in the iCub's frame, the one the robot uses).
    when : float, optional
        Time stamp of the members (seconds since the epoch; now by default).
    runs : mapping of str to mapping of str to bytes, optional
        The evaluation runs, by folder under ``runs/``: their files as they are
        (:func:`app.io.runs_folder.run_files`).
    """
    stamp = time.localtime(when)[:6]
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:

        def add(name: str, content: str | bytes) -> None:
            info = zipfile.ZipInfo(name, date_time=stamp)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (stat.S_IFREG | 0o644) << 16
            archive.writestr(info, content.encode("utf-8") if isinstance(content, str) else content)

        add(INDEX_NAME, index_json(data.primitives, data.settings, data.layout, data.checks,
                                   data.frame, data.sources))  # fmt: skip
        columns = data.layout.columns
        recorded = data.frame.as_recorded(data.demos, data.layout)  # back in the data's frame
        for entry in data.primitives:
            check_name(entry.name)
            for demo in recorded.get(entry.name, []):
                check_name(demo.name, "demonstration")
                ordered = Demonstration(demo.times, demo.select(columns), columns, name=demo.name)
                add(f"{DEMOS_DIR}/{entry.name}/{demo.name}.csv", demo_to_csv(ordered))
        if model is not None:
            add(MODEL_NAME, model_to_json(model))
        for folder, files in (runs or {}).items():
            run_path(PurePosixPath("."), folder)  # a plain folder name
            for relative, content in files.items():
                add(f"{RUNS_DIR}/{folder}/{relative}", content)
    return buffer.getvalue()


# ---------------------------------------------------------------------------------- import


def read_upload(
    filename: str, content: bytes, limits: Limits | None = None
) -> ModelUpload | WorkspaceUpload:
    """Validate an uploaded file: a model (``.json``) or a workspace archive (``.zip``).

    Raises
    ------
    ValueError
        Empty or too large, an unknown extension, or any problem :func:`read_model` or
        :func:`read_workspace_zip` finds. The message says what is wrong (the caller adds the
        file name).
    """
    limits = limits or Limits()
    size = len(content)
    if size > limits.max_upload_bytes:
        raise ValueError(
            f"the file is {format_size(size)}, over the {format_size(limits.max_upload_bytes)} "
            "upload limit"
        )
    if size == 0:
        raise ValueError("the file is empty")
    suffix = PurePosixPath(filename).suffix.lower()
    if suffix == ".json":
        return ModelUpload(filename, read_model(content))
    if suffix == ".zip":
        return read_workspace_zip(content, filename, limits)
    raise ValueError(
        f"expected a model (.json) or a workspace (.zip), not a {suffix or 'extension-less'} file"
    )


def read_model(content: bytes) -> ProMPModel:
    """Parse a model file and check the studio can name its primitives.

    Raises
    ------
    ValueError
        Not a model file (see :func:`promp.io.model_from_dict`), or a primitive name the
        studio could not use.
    """
    try:
        text = content.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"not a model file: not UTF-8 text ({exc})") from None
    try:
        model = model_from_json(text)
    except (TypeError, AttributeError, KeyError, IndexError, OverflowError) as exc:
        # promp.io checks the schema; a value of the wrong JSON type can still slip through.
        raise ValueError(f"malformed model file ({type(exc).__name__}: {exc})") from None
    except RecursionError:
        raise ValueError("not valid JSON (nested too deeply)") from None
    check_model(model)
    return model


def check_model(model: ProMPModel) -> ProMPModel:
    """Raise ValueError unless the studio can use ``model``'s primitive names."""
    for primitive in model.primitives:
        check_name(primitive.name)
    return model


def read_workspace_zip(
    content: bytes, filename: str = "workspace.zip", limits: Limits | None = None
) -> WorkspaceUpload:
    """Parse a workspace archive into memory, checking everything (module docstring).

    Raises
    ------
    ValueError
        The first problem found, naming the archive member it concerns.
    """
    limits = limits or Limits()
    try:
        archive = zipfile.ZipFile(io.BytesIO(content))
    except (zipfile.BadZipFile, zipfile.LargeZipFile, ValueError, EOFError, OSError,
            NotImplementedError) as exc:  # (NotImplementedError: e.g. an unknown zip version)
        raise ValueError(f"not a zip archive ({exc})") from None  # fmt: skip
    with archive:
        members, prefix, ignored = _members(archive, limits)
        if INDEX_NAME not in members:
            raise ValueError(
                f"no {INDEX_NAME}: not a studio workspace (a workspace archive holds "
                f"{INDEX_NAME}, {DEMOS_DIR}/<primitive>/<demo>.csv and optionally {MODEL_NAME})"
            )
        budget = [limits.max_uncompressed_bytes]

        def read(inner: str) -> bytes:
            return read_member(archive, members[inner], prefix + inner, budget)

        index = _parse_index(read(INDEX_NAME), prefix + INDEX_NAME)
        demos: dict[str, list[Demonstration]] = {p.name: [] for p in index.primitives}
        model = None
        runs: dict[str, dict[str, bytes]] = {}
        for inner in natural_sorted(members, key=PurePosixPath):
            label = prefix + inner
            if inner == INDEX_NAME:
                continue
            if inner.startswith(f"{RUNS_DIR}/"):
                folder, relative = _run_member(inner, label)
                runs.setdefault(folder, {})[relative] = read(inner)
                continue
            if inner == MODEL_NAME:
                try:
                    model = read_model(read(inner))
                except ValueError as exc:
                    raise ValueError(f"{label}: {exc}") from None
                continue
            primitive, stem = _demo_member(inner, label)
            if primitive not in demos:
                raise ValueError(f"{label}: primitive {primitive!r} is not listed in {INDEX_NAME}")
            demos[primitive].append(_parse_demo(read(inner), stem, label, index.layout))
        for folder, files in runs.items():
            _check_run(folder, files, f"{prefix}{RUNS_DIR}/{folder}")
    data = WorkspaceData(
        index.primitives, index.frame.placed(demos, index.layout), index.settings,
        layout=index.layout, checks=index.checks, frame=index.frame, sources=index.sources,
    )  # fmt: skip
    return WorkspaceUpload(filename, data, model, ignored, runs)


# ---------------------------------------------------------------------------------- helpers


def _members(
    archive: zipfile.ZipFile, limits: Limits
) -> tuple[dict[str, zipfile.ZipInfo], str, list[str]]:
    """The archive's files by their name in its root folder, that root, the files left out
    (Finder's, hidden); ValueError on too many entries, too many bytes, a bad or repeated name."""
    infos = archive.infolist()
    if len(infos) > limits.max_members:
        raise ValueError(
            f"the archive holds {len(infos)} entries; at most {limits.max_members} allowed"
        )
    total = sum(info.file_size for info in infos)
    if total > limits.max_uncompressed_bytes:
        raise ValueError(
            f"the archive expands to {format_size(total)}, over the "
            f"{format_size(limits.max_uncompressed_bytes)} limit"
        )
    files: dict[str, zipfile.ZipInfo] = {}
    ignored: list[str] = []
    for info in infos:
        name = check_member(info)
        if info.is_dir():
            continue
        if name in files:
            raise ValueError(f"{name}: appears twice in the archive")
        files[name] = info
    for name in list(files):
        parts = name.split("/")
        if parts[0] == "__MACOSX" or parts[-1].startswith("."):  # Finder's and hidden files
            ignored.append(name)
            del files[name]
    prefix = _common_root(files)
    return {name[len(prefix) :]: info for name, info in files.items()}, prefix, ignored


def _run_member(inner: str, label: str) -> tuple[str, str]:
    """``(run folder, file in it)`` of a member under ``runs/``; ValueError naming ``label``
    for a file directly in ``runs/`` or a folder's name the runs folder refuses."""
    folder, _, relative = inner[len(RUNS_DIR) + 1 :].partition("/")
    if not relative:
        raise ValueError(f"{label}: unexpected file; a run is a folder, "
                         f"{RUNS_DIR}/<run>/{RUN_FILE} and its files")  # fmt: skip
    try:
        run_path(PurePosixPath("."), folder)
    except ValueError as exc:
        raise ValueError(f"{label}: {exc}") from None
    return folder, relative


def _demo_member(inner: str, label: str) -> tuple[str, str]:
    """``(primitive, demonstration)`` of a member that must be ``demos/<primitive>/<demo>.csv``;
    ValueError naming ``label`` for any other file or a name the workspace refuses."""
    parts = inner.split("/")
    if len(parts) != 3 or parts[0] != DEMOS_DIR or not parts[2].endswith(".csv"):
        raise ValueError(
            f"{label}: unexpected file; a workspace archive holds {INDEX_NAME}, "
            f"{DEMOS_DIR}/<primitive>/<demo>.csv and optionally {MODEL_NAME} and "
            f"{RUNS_DIR}/<run>/"
        )
    primitive, stem = parts[1], parts[2][: -len(".csv")]
    try:
        check_name(primitive)
        check_name(stem, "demonstration")
    except ValueError as exc:
        raise ValueError(f"{label}: {exc}") from None
    return primitive, stem


def _common_root(files: Mapping[str, zipfile.ZipInfo]) -> str:
    """``"<folder>/"`` when every file is under one folder that holds studio.json (a zipped
    workspace folder), else ``""``."""
    if INDEX_NAME in files or not files:
        return ""
    roots = {name.split("/", 1)[0] for name in files}
    if len(roots) == 1 and all("/" in name for name in files):
        root = roots.pop() + "/"
        if root + INDEX_NAME in files:
            return root
    return ""


def _parse_demo(data: bytes, name: str, label: str, layout: Layout) -> Demonstration:
    columns = layout.columns
    demo = demo_from_csv(member_text(data, label), name=name, label=label)
    missing = [c for c in columns if c not in demo.columns]
    extra = [c for c in demo.columns if c not in columns]
    if missing or extra:
        problem = []
        if missing:
            problem.append(f"lacks column(s) {missing}")
        if extra:
            problem.append(f"has unknown column(s) {extra}")
        raise ValueError(
            f"{label}: {' and '.join(problem)}; the workspace's demonstrations have the "
            f"columns t, {', '.join(columns)}"
        )
    return Demonstration(demo.times, demo.select(columns), columns, name=name)


def _check_run(folder: str, files: Mapping[str, bytes], label: str) -> None:
    """ValueError naming ``label`` unless ``files`` are an evaluation run's: a ``run.json``
    that reads as a run, with rows the Data tab can list."""
    if RUN_FILE not in files:
        raise ValueError(f"{label}/: not an evaluation run (it has no {RUN_FILE})")
    run = run_from_json(member_text(files[RUN_FILE], f"{label}/{RUN_FILE}"), PurePosixPath(folder),
                        f"{label}/{RUN_FILE}")  # fmt: skip
    try:
        listing(run)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ValueError(f"{label}/{RUN_FILE}: its result rows cannot be read ({exc!r})") from None


def _parse_index(data: bytes, label: str) -> Index:
    try:
        index = json.loads(member_text(data, label))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{label}: not valid JSON ({exc})") from None
    except RecursionError:
        raise ValueError(f"{label}: not valid JSON (nested too deeply)") from None
    return check_index(index, label)
