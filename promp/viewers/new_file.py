"""A viewer file written whole into a path that did not exist, or as bytes.

A writer that is given a path writes a temporary file beside it, then links it into place:
an existing file is never overwritten (:class:`FileExistsError` is a ValueError here, before
any work when the caller checks first with :func:`check_new`), and a crash leaves no half file
under the name asked for. The studio's downloads are the same file's bytes
(:func:`file_bytes`).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

__all__ = ["check_new", "file_bytes", "log_bytes", "write_log", "write_new"]


def check_new(path: Path | str, suffix: str) -> Path:
    """``path`` as a Path if it ends in ``suffix`` and names no existing file or folder;
    ValueError otherwise."""
    path = Path(path)
    if path.suffix.lower() != suffix:
        raise ValueError(f"{path}: a {suffix} file is expected (its name ends in {suffix})")
    if path.exists() or path.is_symlink():
        raise ValueError(f"{path} already exists: a viewer file is written as a new file, "
                         "nothing is overwritten")  # fmt: skip
    return path


def write_new(path: Path | str, suffix: str, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` for a temporary path beside ``path``, then link it to ``path``,
    which must not exist (:func:`check_new`); the folder is created when missing."""
    path = check_new(path, suffix)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
    os.close(fd)
    tmp = Path(name)
    try:
        tmp.unlink()  # the writers create their file themselves
        write(tmp)
        try:
            os.link(tmp, path)  # fails, rather than replaces, when path appeared meanwhile
        except FileExistsError:
            raise ValueError(f"{path} already exists: nothing is overwritten") from None
        except OSError:  # a file system without hard links: renamed, checked just before
            check_new(path, suffix)
            os.rename(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def file_bytes(suffix: str, write: Callable[[Path], None]) -> bytes:
    """The bytes ``write(path)`` writes to a new file (in a temporary folder, removed)."""
    with tempfile.TemporaryDirectory(prefix="viewer-") as folder:
        path = Path(folder) / f"export{suffix}"
        write(path)
        return path.read_bytes()


def _write_log(writer, log, path: Path) -> None:
    with writer(path, log.name, log.timelines) as opened:
        opened.describe(log)
        for item in log.items:
            opened.write(item)


def write_log(writer, log, path: Path | str, suffix: str) -> Path:
    """Write every item of ``log`` (a :class:`promp.viewers.scene_log.SceneLog`) with
    ``writer`` (a writer class: ``writer(path, name, timelines)``, ``write``, ``close``) to
    the new file ``path``."""
    return write_new(path, suffix, lambda tmp: _write_log(writer, log, tmp))


def log_bytes(writer, log, suffix: str) -> bytes:
    """:func:`write_log`'s file as bytes."""
    return file_bytes(suffix, lambda path: _write_log(writer, log, path))
