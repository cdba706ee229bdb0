"""The workspace's evaluation runs: ``runs/<YYYYmmdd-HHMMSS>-<name>/``, one folder per run.

::

    WORKSPACE/runs/<YYYYmmdd-HHMMSS>-<name>/
        run.json, results.csv, trials.csv, figures/     (promp.evaluate.runs)

The studio writes a run after every evaluation it runs to its end (and a cancelled one with
results, marked partial) with the command line's writer (:func:`promp.evaluate.runs.write_run`:
built beside, renamed into place); ``python -m promp.evaluate ... --run WORKSPACE/runs/NAME``
writes the same. The loader of demonstrations never reads ``runs/``. A run is listed from its
``run.json``; one that cannot be read is listed with the reason and opens nowhere. Deleting a
run moves its folder to the workspace's trash (:mod:`app.io.trash`, kind ``run``), whence it
can be restored. Exporting the workspace carries its readable runs (:func:`run_files`), and
importing that archive adds them back (:func:`add_runs`): each as a new folder, built beside
and renamed into place; never over an existing run (the same run already there is left as it
is; another run of that name comes in as ``<name>-imported``). Pure: no viser.
"""

from __future__ import annotations

import datetime as _dt
import io
import math
import os
import threading
import time
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from app.io.trash import Trash, TrashEntry
from promp.evaluate.runs import Run, folder_name, read_run, write_new_folder, write_run
from promp.names import natural_sorted

RunFiles = Mapping[str, Mapping[str, bytes]]  # run folder -> its files (relative path -> bytes)

RUNS_DIR = "runs"
RUN_KIND = "run"  # the trash entry's kind
PARTIAL = "partial"  # the report's key marking a cancelled run's results


@dataclass(frozen=True)
class RunListing:
    """One folder of ``runs/`` as the Data tab lists it.

    Attributes
    ----------
    folder : str
        The folder's name under ``runs/`` (sorts by time).
    name, created : str
        The run's name and time (ISO 8601), from its ``run.json``.
    observed : tuple of tuple of str
        The observed modality sets swept, e.g. ``(("hand", "head"),)``.
    alpha : tuple of str
        The alpha methods (``"ml"``, ``"model"``).
    percents : tuple of float
    errors, trials : int
        Recognition errors and trials, summed over every result row.
    methods : tuple of (str, int, int)
        Per method the run compared (in its order): its name, its errors and its trials
        summed over its rows (one entry for a run of one method).
    partial : bool
        A cancelled evaluation's results (fewer trials than asked for).
    problem : str
        Why the run cannot be read ("" when it can); the other fields are then empty.
    """

    folder: str
    name: str = ""
    created: str = ""
    observed: tuple[tuple[str, ...], ...] = ()
    alpha: tuple[str, ...] = ()
    percents: tuple[float, ...] = ()
    errors: int = 0
    trials: int = 0
    partial: bool = False
    problem: str = ""
    methods: tuple[tuple[str, int, int], ...] = ()


def runs_root(workspace: Path) -> Path:
    return Path(workspace) / RUNS_DIR


def run_path(workspace: Path, folder: str) -> Path:
    """The folder of run ``folder`` (a plain name under ``runs/``).

    Raises
    ------
    ValueError
        ``folder`` is not a plain folder name.
    """
    if not folder or folder.startswith(".") or "/" in folder or "\\" in folder:
        raise ValueError(f"{folder!r} is not the name of a run folder")
    return runs_root(workspace) / folder


def listing(run: Run) -> RunListing:
    """What the list shows of ``run``."""
    report = run.report
    settings = report.get("settings") or {}
    rows = report["results"]
    observed = settings.get("observe") or sorted({tuple(r["observed"]) for r in rows})
    alpha = settings.get("alpha") or sorted({r["alpha_method"] for r in rows})
    percents = settings.get("percents") or sorted({float(r["percent"]) for r in rows})
    return RunListing(
        folder=run.folder.name, name=run.name, created=run.created,
        observed=tuple(tuple(str(n) for n in names) for names in observed),
        alpha=tuple(str(a) for a in alpha), percents=tuple(float(p) for p in percents),
        errors=sum(_count(r.get("recognition_errors")) for r in rows),
        trials=sum(_count(r.get("trials")) for r in rows), partial=bool(report.get(PARTIAL)),
        methods=_per_method(rows),
    )  # fmt: skip


def _per_method(rows: list) -> tuple[tuple[str, int, int], ...]:
    """(method, errors, trials) of each method of ``rows``, in the order they come."""
    totals: dict[str, list[int]] = {}
    for r in rows:
        total = totals.setdefault(str(r.get("method", "")), [0, 0])
        total[0] += _count(r.get("recognition_errors"))
        total[1] += _count(r.get("trials"))
    return tuple((method, errors, trials) for method, (errors, trials) in totals.items())


def _count(value: object) -> int:
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return 0
    return int(round(number)) if math.isfinite(number) else 0


def list_runs(
    workspace: Path, known: Mapping[str, tuple[float, RunListing]] | None = None
) -> dict[str, tuple[float, RunListing]]:
    """Every run folder of the workspace, newest first (by the time in its ``run.json``; those
    that cannot be read last): its name -> (the modification time of its ``run.json``, its
    listing). ``known`` (a previous answer) saves reading again the runs
    whose ``run.json`` has not changed. Hidden folders (a run being written) are left out."""
    root = runs_root(workspace)
    try:
        folders = sorted((p for p in root.iterdir() if p.is_dir()), reverse=True)
    except OSError:  # no runs/ yet, or unreadable: nothing to list
        return {}
    known = known or {}
    out: dict[str, tuple[float, RunListing]] = {}
    for folder in folders:
        if folder.name.startswith("."):
            continue
        try:
            mtime = (folder / "run.json").stat().st_mtime
        except OSError:
            mtime = math.nan
        if folder.name in known and known[folder.name][0] == mtime:
            out[folder.name] = known[folder.name]
            continue
        try:
            item = listing(read_run(folder))
        except (ValueError, KeyError, TypeError) as exc:
            item = RunListing(folder.name, problem=str(exc) or type(exc).__name__)
        out[folder.name] = (mtime, item)
    return dict(sorted(out.items(), key=lambda kv: (kv[1][1].created, kv[0]), reverse=True))


def open_run(workspace: Path, folder: str) -> Run:
    """Read run ``folder`` of the workspace (:func:`promp.evaluate.runs.read_run`).

    Raises
    ------
    ValueError
        No such run, or one that cannot be read (the message says why).
    """
    path = run_path(workspace, folder)
    if not path.is_dir():
        raise ValueError(f"the workspace has no run {folder!r} (deleted meanwhile?)")
    run = read_run(path)
    listing(run)  # the rows must be readable too
    return run


def save_run(
    workspace: Path,
    report: Mapping,
    name: str,
    figures=None,
    partial: bool = False,
    created: _dt.datetime | None = None,
) -> Run:
    """Write ``report`` as a new run of the workspace, ``runs/<time>-<name>/`` (``-2``,
    ``-3``... when that folder exists), with :func:`promp.evaluate.runs.write_run`;
    ``partial`` marks a cancelled evaluation's results."""
    created = created or _dt.datetime.now(_dt.UTC).astimezone()
    base = folder_name(name, created)
    report = {**report, PARTIAL: True} if partial else dict(report)
    for suffix in range(1, 100):
        path = runs_root(workspace) / (base if suffix == 1 else f"{base}-{suffix}")
        if not (path.exists() or path.is_symlink()):
            return write_run(path, report, name, figures=figures, created=created)
    raise ValueError(f"too many runs named {base} in {runs_root(workspace)}")


def run_zip(workspace: Path, folder: str) -> bytes:
    """The run's folder as a zip, its files under ``<folder>/``.

    Raises
    ------
    ValueError
        No such run.
    """
    path = run_path(workspace, folder)
    if not path.is_dir():
        raise ValueError(f"the workspace has no run {folder!r} (deleted meanwhile?)")
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for file in sorted(path.rglob("*")):
            if file.is_file() and not file.is_symlink():
                archive.write(file, f"{folder}/{file.relative_to(path).as_posix()}")
    return buffer.getvalue()


def _files_of(path: Path) -> dict[str, bytes]:
    """The files of the run folder ``path`` (relative POSIX path -> content), hidden files and
    links left out."""
    out = {}
    for file in natural_sorted(path.rglob("*"), key=lambda p: p.relative_to(path)):
        relative = file.relative_to(path)
        if file.is_file() and not file.is_symlink() and not any(
            part.startswith(".") for part in relative.parts
        ):
            out[relative.as_posix()] = file.read_bytes()
    return out


def run_files(workspace: Path) -> tuple[dict[str, dict[str, bytes]], list[str]]:
    """What an export of the workspace carries of ``runs/``: every run that can be read, by
    folder (its files), and the folders left out because they cannot be (with why)."""
    runs: dict[str, dict[str, bytes]] = {}
    left_out: list[str] = []
    for name, (_, item) in list_runs(workspace).items():
        if item.problem:
            left_out.append(f"{name} ({item.problem})")
            continue
        path = run_path(workspace, name)
        if path.is_symlink():
            left_out.append(f"{name} (a link)")
            continue
        try:
            runs[name] = _files_of(path)
        except OSError as exc:
            left_out.append(f"{name} ({exc})")
    return runs, left_out


def add_runs(workspace: Path, runs: RunFiles) -> tuple[list[str], list[str]]:
    """Add ``runs`` (checked: :func:`app.io.exchange.read_workspace_zip`) to the workspace's
    ``runs/``, each as a new folder written beside and renamed into place. Returns the folders
    written and the runs already there (the same files under the same name: left as they are).
    A different run of a name already taken comes in as ``<name>-imported`` (``-imported-2``,
    ...): nothing is ever overwritten.

    Raises
    ------
    ValueError
        A folder name that is not a plain one, or a file path leaving its folder (nothing of
        that run is written); an OSError of the disk stops there, the runs written staying.
    """
    root = runs_root(workspace)
    written: list[str] = []
    present: list[str] = []
    for name, files in runs.items():
        run_path(workspace, name)  # a plain folder name
        for relative in files:
            parts = PurePosixPath(relative).parts
            if not parts or any(p in ("", ".", "..") for p in parts) or relative.startswith("/"):
                raise ValueError(f"run {name}: {relative!r} is not a path inside its folder")
        target, k = root / name, 1
        while target.exists() or target.is_symlink():
            if target.is_dir() and not target.is_symlink() and _files_of(target) == dict(files):
                present.append(name)
                break
            k += 1
            target = root / (f"{name}-imported" if k == 2 else f"{name}-imported-{k - 1}")
        else:
            _write_run_folder(target, files)
            written.append(target.name)
    return written, present


def _write_run_folder(target: Path, files: Mapping[str, bytes]) -> None:
    """``files`` as the new folder ``target``, whole or not at all
    (:func:`promp.evaluate.runs.write_new_folder`; the lister skips the hidden staging)."""

    def fill(staging: Path) -> None:
        for relative, content in files.items():
            path = staging / relative
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(content)

    write_new_folder(target, fill)


def trash_run(trash: Trash, folder: str) -> TrashEntry:
    """Move run ``folder`` of ``trash``'s workspace to the trash (restorable as a whole).

    Raises
    ------
    ValueError
        No such run.
    """
    path = run_path(trash.workspace, folder)
    if not path.is_dir() or path.is_symlink():
        raise ValueError(f"the workspace has no run {folder!r} (deleted meanwhile?)")
    relative = Path(os.path.relpath(path, trash.workspace)).as_posix()
    return trash.put(RUN_KIND, f"run {folder}", [relative], {"run": folder})


class RunsScanner:
    """Lists a workspace's runs (:func:`list_runs`) on a worker thread, at most every
    ``interval_s`` seconds or when asked (:meth:`rescan`): the studio's loop polls for the
    latest listing and never waits for the disk (a long run's ``run.json`` takes a while to
    read)."""

    def __init__(self, interval_s: float = 2.0):
        self.interval_s = interval_s
        self._latest: tuple[Path, dict[str, tuple[float, RunListing]]] | None = None
        self._thread: threading.Thread | None = None
        self._due = 0.0

    def rescan(self) -> None:
        """Scan again at the next :meth:`poll` (or once the scan under way has ended)."""
        self._due = 0.0

    def poll(self, workspace: Path) -> dict[str, tuple[float, RunListing]] | None:
        """The latest listing of ``workspace``'s runs, the same object while nothing changed
        (None until a scan of it has ended); starts a scan when one is due."""
        now = time.monotonic()
        if now >= self._due and (self._thread is None or not self._thread.is_alive()):
            self._due = now + self.interval_s
            self._thread = threading.Thread(
                target=self._scan, args=(Path(workspace),), name="runs-scan", daemon=True
            )
            self._thread.start()
        latest = self._latest
        return latest[1] if latest is not None and latest[0] == Path(workspace) else None

    def _scan(self, workspace: Path) -> None:
        latest = self._latest
        known = latest[1] if latest is not None and latest[0] == workspace else None
        listed = list_runs(workspace, known)
        if listed != known:
            self._latest = (workspace, listed)
