"""The viewer file formats, by suffix: ``.rrd`` (Rerun) and ``.mcap`` (Foxglove, PlotJuggler,
ROS 2 tools), each written by its writer from the same
:class:`promp.viewers.scene_log.SceneLog`."""

from __future__ import annotations

from pathlib import Path

from promp.viewers.new_file import log_bytes, write_log
from promp.viewers.scene_log import SceneLog

__all__ = ["SUFFIXES", "viewer_file_bytes", "write_viewer_file", "writer_for"]

SUFFIXES = (".rrd", ".mcap")


def writer_for(suffix: str):
    """The writer class of ``suffix``, its library imported.

    Raises
    ------
    ValueError
        Another suffix; the extra that installs the library is missing (named).
    """
    if suffix == ".rrd":
        from promp.viewers.rerun_writer import RerunWriter, needs_rerun

        needs_rerun()
        return RerunWriter
    if suffix == ".mcap":
        from promp.viewers.mcap_writer import McapWriter, needs_foxglove

        needs_foxglove()
        return McapWriter
    raise ValueError(f"a viewer file ends in {' or '.join(SUFFIXES)}, got {suffix!r}")


def write_viewer_file(log: SceneLog, path: Path | str, suffix: str | None = None) -> Path:
    """Write ``log`` to the new file ``path`` in the format of its suffix (or ``suffix``,
    which ``path`` must then end in); never over an existing file.

    Raises
    ------
    ValueError
        ``path`` exists or ends in another suffix; the format's extra is not installed.
    """
    suffix = suffix or Path(path).suffix.lower()
    return write_log(writer_for(suffix), log, path, suffix)


def viewer_file_bytes(log: SceneLog, suffix: str) -> bytes:
    """``log`` as the bytes of a ``suffix`` file (what the studio sends for download)."""
    return log_bytes(writer_for(suffix), log, suffix)
