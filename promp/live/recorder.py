"""The recorder sink: the samples of each movement handed out as a demonstration, safe
against a kill.

While a movement goes on, its rows are appended to a :class:`promp.live.journal.Journal` in
the recorder's folder as they come (acknowledged once written, :attr:`Recorder.acknowledged`).
When it ends, :meth:`Recorder.finish` gives its :class:`promp.data.Demonstration` (times from
its first row; the movement's own rows, which the segmenter may have cut before a still tail
the journal already holds) and, given a path, writes it atomically as a CSV demonstration and
removes the journal; the studio, which writes into its workspace itself, calls
:meth:`Recorder.release` once it has. After a kill, :func:`recover` reads back what each
journal left holds: every acknowledged row.

A session hands a recorder the movements through :class:`RecorderSink`, on the sink's own
thread (:mod:`promp.live.sinks`): a disk that blocks or is full never stalls the prediction.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from promp.data import Demonstration
from promp.datasets import write_csv_demo
from promp.live.journal import SUFFIX, Journal, journals, read_journal
from promp.live.segmenter import Movement
from promp.live.sinks import Output

__all__ = ["free_path", "movement_of", "Recorded", "Recorder", "RecorderSink", "Records", "recover"]


@dataclass(frozen=True, eq=False)
class Recorded:
    """A movement recorded: its number, its class (the start marker's, '' otherwise), its
    demonstration, and the journal that keeps it until :meth:`Recorder.release` (None once
    written to ``path`` and released)."""

    number: int
    label: str
    demo: Demonstration
    journal: Path | None
    path: Path | None = None


class Recorder:
    """Records movements (see the module docstring).

    Parameters
    ----------
    folder : Path
        Where the journals are kept (created when needed).
    columns : tuple of str
        The demonstrations' columns (the rows' columns, in order).
    prefix : str
        Demonstrations are named ``<prefix>-<movement number>``.
    output : Path, optional
        Where :meth:`finish` writes each demonstration when no path is given:
        ``<output>/<class>/<name>.csv``, the class its start marker named (else ``live``),
        never over an existing file.
    """

    def __init__(self, folder: Path, columns: tuple[str, ...], prefix: str = "live",
                 output: Path | None = None):  # fmt: skip
        if not re.fullmatch(r"[A-Za-z0-9_-]{1,40}", prefix):
            raise ValueError(f"the recordings' prefix must be 1-40 letters, digits, - or _: "
                             f"{prefix!r}")  # fmt: skip
        self.folder = Path(folder)
        self.columns = tuple(columns)
        self.prefix = prefix
        self.output = None if output is None else Path(output)
        self._journal: Journal | None = None
        self._number = 0
        self._stamp = ""

    @property
    def acknowledged(self) -> int:
        """Rows of the movement going on that a kill would not lose."""
        return self._journal.acknowledged if self._journal else 0

    def name_of(self, number: int) -> str:
        return f"{self.prefix}-{number:03d}"

    def journal_path(self, number: int) -> Path:
        return self.folder / f"{self.name_of(number)}{self._stamp}{SUFFIX}"

    def append(self, movement: Movement) -> int:
        """Journal the rows of ``movement`` not journalled yet; the rows acknowledged."""
        if len(movement) == 0:
            return 0
        if self._journal is None or self._number != movement.number:
            self.close()
            self._number = movement.number
            self._stamp = ""
            path = self.journal_path(movement.number)
            k = 1
            while path.exists():  # never over another's file
                self._stamp, k = f"-{k}", k + 1
                path = self.journal_path(movement.number)
            self._journal = Journal(path, self.columns, self.name_of(movement.number),
                                    movement.label, movement.start)  # fmt: skip
        done = self._journal.acknowledged
        return self._journal.append(movement.times[done:], movement.values[done:])

    def finish(self, movement: Movement, path: Path | None = None) -> Recorded | None:
        """The ended ``movement`` as a demonstration (None with fewer than 2 rows); with
        ``path`` (or an ``output`` folder), written there atomically and its journal
        removed."""
        if len(movement) > 0:
            self.append(movement)
        self.close()
        if len(movement) < 2:
            self.release(movement.number)
            return None
        demo = Demonstration(movement.times - movement.times[0], movement.values, self.columns,
                             name=self.name_of(movement.number))  # fmt: skip
        journal = self.journal_path(movement.number)
        if path is None and self.output is not None:
            path = free_path(self.output / (movement.label or "live") / f"{demo.name}.csv")
        if path is not None:
            write_csv_demo(Path(path), demo)
            self.release(movement.number)
            journal = None
        return Recorded(movement.number, movement.label, demo, journal,
                        None if path is None else Path(path))  # fmt: skip

    def release(self, number: int) -> None:
        """Remove movement ``number``'s journal (its demonstration is safe elsewhere)."""
        if self._journal is not None and self._number == number:
            self.close()
        self.journal_path(number).unlink(missing_ok=True)

    def close(self) -> None:
        if self._journal is not None:
            self._journal.close()
            self._journal = None


def free_path(path: Path) -> Path:
    """``path``, or ``path`` with ``-2``, ``-3``... before its suffix: never over a file."""
    k, candidate = 2, Path(path)
    while candidate.exists():
        candidate, k = path.with_name(f"{path.stem}-{k}{path.suffix}"), k + 1
    return candidate


def recover(folder: Path) -> list[tuple[Path, Demonstration | str]]:
    """Each journal left in ``folder`` and its demonstration (every acknowledged row), or why
    it cannot be read."""
    out: list[tuple[Path, Demonstration | str]] = []
    for path in journals(folder):
        try:
            out.append((path, read_journal(path)[0]))
        except ValueError as exc:
            out.append((path, str(exc)))
    return out


def movement_of(demo: Demonstration, number: int, label: str = "") -> Movement:
    """A demonstration as the rows of a movement (tests, replays)."""
    return Movement(number, label, np.asarray(demo.times), np.asarray(demo.values))


class Records(Protocol):
    """What :class:`RecorderSink` needs of a recorder (:class:`Recorder`, the studio's take
    recorder)."""

    def append(self, movement: Movement) -> int: ...

    def finish(self, movement: Movement) -> Recorded | None: ...

    def close(self) -> None: ...


class RecorderSink:
    """The recorder as a session's sink: each ended movement finished, then the rows of the
    movement going on journalled. Lossless: when it falls behind, the outputs queued are
    folded into one (the movement going on carries all its rows so far)."""

    name = "recorder"
    lossless = True

    def __init__(self, recorder: Records):
        self.recorder = recorder

    def view(self, output: Output) -> Output | None:
        ends = tuple(b for b in output.boundaries if b.movement is not None)
        if not ends and output.movement is None:
            return None
        return Output(output.time, boundaries=ends, movement=output.movement)

    def take(self, output: Output) -> Sequence[Recorded]:
        recorded = [self.recorder.finish(b.movement) for b in output.boundaries]
        if output.movement is not None:
            self.recorder.append(output.movement)
        return [r for r in recorded if r is not None]

    def close(self) -> None:
        self.recorder.close()
