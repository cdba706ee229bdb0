"""Takes recorded from the live streams: journalled as they come, then saved as takes are.

The live session's recorder sink is a :class:`TakeRecorder`: while Teach arms it (a primitive
chosen, *Record live movements* on), each movement the session finds (by stillness, the marker
stream, or Begin / End take) is journalled row by row in the workspace's
``live-journals/<primitive>/`` folder (:class:`promp.live.recorder.Recorder`: a row is
**acknowledged** once written, and survives a kill), into the armed primitive, or into the
primitive its start marker names (``start CLASS``) when the workspace has one of that name.
When the movement ends, :func:`save_recorded` hands its demonstration to the store (written
atomically, checked like every take, learned from) and :meth:`TakeRecorder.release` removes
its journal, only then.

After a kill, :func:`recover_takes` (at the next start of the studio, and whenever another
workspace is opened) makes each journal left a take of its primitive: every acknowledged row,
in the store as any take; a journal already saved (the kill came between the save and the
journal's removal) is only removed; one that cannot be saved (its primitive is gone, its
columns are not the workspace's) stays where it is, and the message says where.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from app.core.store import Store
from promp.data import Demonstration
from promp.live.recorder import Recorded, Recorder, recover
from promp.live.segmenter import Movement

__all__ = ["JOURNALS_DIR", "recover_takes", "save_recorded", "TakeRecorder", "UnderWay"]

JOURNALS_DIR = "live-journals"

UnderWay = tuple[int, str, int]  # (movement, primitive, rows acknowledged)


class TakeRecorder:
    """The live session's recorder (see the module docstring); thread-safe.

    Parameters
    ----------
    root : Path
        The journals' folder (``<workspace>/live-journals``).
    columns : tuple of str
        The rows' columns (the session's, in its inputs' order).
    names : callable
        The workspace's primitives now.
    prefix : str
        The journals' names start with it (a session's: ``live-<time>``).
    """

    def __init__(self, root: Path, columns: Sequence[str], names: Callable[[], Sequence[str]],
                 prefix: str):  # fmt: skip
        self.root = Path(root)
        self.columns = tuple(columns)
        self._names = names
        self._prefix = prefix
        self._lock = threading.Lock()
        self._target: str | None = None
        self._recorders: dict[str, Recorder] = {}
        self._current: tuple[int, str | None] = (0, None)
        self._under_way: UnderWay | None = None
        self._primitives: dict[Path, str] = {}

    @property
    def target(self) -> str | None:
        return self._target

    def arm(self, primitive: str | None) -> None:
        """Record the movements that start from now on into ``primitive`` (None: none; a take
        under way ends with its movement)."""
        self._target = primitive

    def under_way(self) -> UnderWay | None:
        """The take being journalled: its movement, primitive and rows acknowledged."""
        return self._under_way

    def _choose(self, label: str) -> str | None:
        target = self._target
        if target is None:
            return None
        names = tuple(self._names())
        return label if label in names else (target if target in names else None)

    def _recorder(self, primitive: str) -> Recorder:
        if primitive not in self._recorders:
            self._recorders[primitive] = Recorder(self.root / primitive, self.columns,
                                                  self._prefix)  # fmt: skip
        return self._recorders[primitive]

    def append(self, movement: Movement) -> int:
        """Journal the new rows of ``movement`` when it is recorded (the session's thread)."""
        with self._lock:
            number, primitive = self._current
            if movement.number != number or primitive is None:
                primitive = self._choose(movement.label)
                self._current = (movement.number, primitive)
            if primitive is None:
                return 0
            rows = self._recorder(primitive).append(movement)
            self._under_way = (movement.number, primitive, rows)
            return rows

    def finish(self, movement: Movement) -> Recorded | None:
        """``movement`` ended: its demonstration, its journal kept until :meth:`release`
        (None when it was not recorded, or has fewer than 2 rows)."""
        with self._lock:
            number, primitive = self._current
            if movement.number != number:
                primitive = self._choose(movement.label)
            self._current, self._under_way = (0, None), None
            if primitive is None:
                return None
            recorded = self._recorder(primitive).finish(movement)
            if recorded is not None and recorded.journal is not None:
                self._primitives[recorded.journal] = primitive
            return recorded

    def primitive_of(self, recorded: Recorded) -> str:
        """The primitive ``recorded`` was journalled into."""
        return self._primitives[recorded.journal]

    def release(self, recorded: Recorded) -> None:
        """Remove ``recorded``'s journal: its take is safe in the workspace."""
        if recorded.journal is not None:
            with self._lock:
                self._primitives.pop(recorded.journal, None)
            recorded.journal.unlink(missing_ok=True)

    def close(self) -> None:
        """Close the journals (a take under way stays in its journal)."""
        with self._lock:
            for recorder in self._recorders.values():
                recorder.close()
            self._current, self._under_way = (0, None), None


def save_recorded(store: Store, primitive: str, demo: Demonstration) -> Demonstration:
    """``demo`` (a recorded movement's, its columns the session's) as a new take of
    ``primitive``, in the workspace's column order.

    Raises
    ------
    ValueError
        The workspace has no such primitive, or ``demo`` lacks some of its columns (the
        store's own refusals too: values it cannot keep).
    """
    state = store.state
    if primitive not in state.names:
        raise ValueError(f"the workspace has no primitive {primitive!r} any more")
    values = demo.select(state.layout.columns)
    return store.add_demo(primitive, demo.times, values)


def _saved_before(demos: Sequence[Demonstration], demo: Demonstration, values: np.ndarray) -> bool:
    """Whether one of ``demos`` holds the first rows of ``demo`` exactly (saved, and the kill
    came before its journal was removed)."""
    for d in demos:
        k = d.n_samples
        if 2 <= k <= demo.n_samples and np.array_equal(d.times, demo.times[:k]) and \
                np.array_equal(d.values, values[:k]):  # fmt: skip
            return True
    return False


def recover_takes(root: Path, store: Store) -> list[tuple[str, str]]:
    """Each journal left under ``root / JOURNALS_DIR`` made a take (see the module docstring);
    what happened to each, as (colour, message)."""
    folder = Path(root) / JOURNALS_DIR
    if not folder.is_dir():
        return []
    out: list[tuple[str, str]] = []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        primitive = sub.name
        for path, demo in recover(sub):
            kept = f"the journal stays at {path}"
            if isinstance(demo, str):
                out.append(("red", f"An interrupted live take cannot be read ({demo}); {kept}"))
                continue
            state = store.state
            try:
                values = demo.select(state.layout.columns)
                if primitive in state.names and _saved_before(state.demos[primitive], demo,
                                                              values):  # fmt: skip
                    path.unlink()
                    out.append(("gray", f"A live take of {primitive} was saved before the "
                                        "studio stopped; its journal is removed"))  # fmt: skip
                    continue
                saved = save_recorded(store, primitive, demo)
            except (ValueError, OSError) as exc:
                out.append(("red", f"An interrupted live take of {primitive} cannot be saved "
                                   f"({exc}); {kept}"))  # fmt: skip
                continue
            path.unlink()
            out.append(("green", f"Recovered {saved.name} into {primitive}: {demo.n_samples} "
                                 f"samples ({demo.duration:.1f} s) of a live take the studio "
                                 "was stopped during"))  # fmt: skip
    return out
