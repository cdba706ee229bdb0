"""A recording's journal: every row appended to a file as it comes, so that a kill loses
nothing acknowledged.

A journal is a text file the recorder owns (``<folder>/<name>.journal``): a first line
``# promp-live journal 1 {"name": ..., "label": ..., "start": ...}`` (JSON: the
demonstration's name, its class, the session-clock time of its first row), the CSV header
``t,<columns>``, then one line per row, times in seconds from the first row and numbers with
17 significant digits (the CSV demonstrations' format, :func:`promp.datasets.demo_to_csv`: an
exact round trip). Each :meth:`Journal.append` is one ``write`` to the operating system: when
it returns, the rows are **acknowledged**, and survive the process being killed; the file is
also ``fsync``-ed every :data:`FSYNC_S` and when closed (a power cut may lose the last
second). A write that fails (a full disk: ``OSError`` ENOSPC, after writing part of the rows)
is cut back to the rows acknowledged before it raises, so that the next append, once there is
room, follows them: a torn row never stays in the middle of a journal. :func:`read_journal`
reads one back, a last line cut short by a kill left out.
"""

from __future__ import annotations

import io
import json
import os
import time
from pathlib import Path

import numpy as np

from promp.data import Demonstration
from promp.datasets import demo_from_csv

__all__ = ["AppendFile", "FSYNC_S", "Journal", "journals", "MAGIC", "read_journal", "SUFFIX"]

MAGIC = "# promp-live journal 1 "
SUFFIX = ".journal"
FSYNC_S = 1.0


class AppendFile:
    """A file created new (never over one) and only appended to (see the module docstring):
    each :meth:`write` is one ``write`` to the operating system, acknowledged when it returns,
    cut back on failure so the file ends with whole records; ``fsync``-ed every
    :data:`FSYNC_S` and when closed. A recording's :class:`Journal` and a live session's
    (:mod:`promp.live.session_file`) are both one."""

    def __init__(self, path: Path, header: str):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND, 0o644)
        self._size = 0  # bytes acknowledged
        self._synced = time.monotonic()
        try:
            self.write(header)
            os.fsync(self._fd)
        except Exception:  # the file it created holds nothing: it goes
            os.close(self._fd)
            self.path.unlink(missing_ok=True)
            raise

    def write(self, text: str) -> None:
        """Append ``text`` (whole records); acknowledged when this returns."""
        if self._fd < 0:
            raise ValueError(f"{self.path}: the journal is closed")
        data = text.encode("utf-8")
        size = len(data)
        try:
            while data:
                data = data[os.write(self._fd, data):]
        except Exception:
            try:  # what was written of it goes: the file ends with whole records
                os.ftruncate(self._fd, self._size)
            except OSError:
                pass
            raise
        self._size += size
        if time.monotonic() - self._synced > FSYNC_S:
            os.fsync(self._fd)
            self._synced = time.monotonic()

    @property
    def closed(self) -> bool:
        return self._fd < 0

    def close(self) -> None:
        if self._fd >= 0:
            os.fsync(self._fd)
            os.close(self._fd)
            self._fd = -1


class Journal:
    """An open journal (see the module docstring); created new, never over a file."""

    def __init__(self, path: Path, columns: tuple[str, ...], name: str, label: str, start: float):
        self.path = Path(path)
        self.columns = tuple(columns)
        self.start = float(start)
        header = {"name": name, "label": label, "start": self.start, "columns": list(columns)}
        self._file = AppendFile(
            self.path, f"{MAGIC}{json.dumps(header)}\n{','.join(('t', *self.columns))}\n"
        )
        self.acknowledged = 0

    def append(self, times: np.ndarray, values: np.ndarray) -> int:
        """Append rows (times on the session's clock (n,), values (n, n_columns)); returns
        the rows acknowledged so far."""
        if self._file.closed:
            raise ValueError(f"{self.path}: the journal is closed")
        times = np.asarray(times, dtype=float)
        if times.size == 0:
            return self.acknowledged
        buffer = io.StringIO()
        table = np.column_stack([times - self.start, np.asarray(values, dtype=float)])
        np.savetxt(buffer, table, delimiter=",", fmt="%.17g")
        self._file.write(buffer.getvalue())
        self.acknowledged += int(times.shape[0])
        return self.acknowledged

    def close(self) -> None:
        self._file.close()


def read_journal(path: Path) -> tuple[Demonstration, dict]:
    """The demonstration a journal holds, and its header (name, label, start, columns).

    Raises
    ------
    ValueError
        Not a journal, a broken header, or fewer than 2 whole rows.
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: cannot read the journal ({exc})") from None
    if not text.startswith(MAGIC):
        raise ValueError(f"{path}: not a promp-live journal (no {MAGIC.strip()!r} line)")
    first, _, rest = text.partition("\n")
    try:
        header = json.loads(first[len(MAGIC):])
        name = str(header["name"])
        str(header["label"])
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise ValueError(f"{path}: the journal's header is broken ({exc})") from None
    if not rest.endswith("\n"):
        rest = rest[: rest.rfind("\n") + 1]  # a row cut short by a kill: never acknowledged
    return demo_from_csv(rest, name=name, label=str(path)), header


def journals(folder: Path) -> list[Path]:
    """The journals left in ``folder`` (a recording a kill interrupted), oldest first."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    return sorted(folder.glob(f"*{SUFFIX}"), key=lambda p: (p.stat().st_mtime, p.name))
