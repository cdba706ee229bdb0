"""Which columns form which modality: the ``NAME=COL,COL,...`` syntax of the command line, the
studio and mapping files, the units and kinds column names imply, and the layout a header
suggests."""

from __future__ import annotations

import re
import shlex
from collections.abc import Iterable, Sequence
from pathlib import Path

from promp.data import Kind, Layout, Modality
from promp.rigs.mapping import parse_sourced

__all__ = [
    "GUESSED", "KNOWN_COLUMNS", "MODALITY_NAME", "command_line_modalities", "format_modalities",
    "given_modalities", "guess_layout", "modality_from_columns", "modality_options",
    "modality_specs", "parse_modalities", "parse_modality", "read_mapping_file",
]  # fmt: skip

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


def modality_options(text: str) -> str:
    """A mapping (``"hand=x,y,z; head=roll,pitch,yaw"``) as ``--modality`` options to paste
    on a command line, each quoted for the shell where it needs it: the inverse of
    :func:`command_line_modalities`."""
    return " ".join(f"--modality {shlex.quote(spec)}" for spec in modality_specs(text))


_EXPECTED = (
    "Modality objects or mapping strings, e.g. 'hand=x,y,z' (columns) or "
    "'hand=/pose:pose.position.{x,y,z}@mm' (a recording's stream and fields)"
)


def given_modalities(modalities: object) -> tuple[Modality, ...] | None:
    """The modalities a caller gave, as :class:`Modality` objects: a mapping string (one
    modality, or several separated by ``;`` or new lines) is parsed (:func:`parse_modalities`),
    a :class:`Modality` kept; None, or nothing, is None (guess them).

    Raises
    ------
    ValueError
        A mapping string that does not parse, or anything else than modalities and strings
        (saying what is expected).
    """
    if modalities is None:
        return None
    if isinstance(modalities, (str, Modality)):
        modalities = [modalities]
    if not isinstance(modalities, Iterable) or isinstance(modalities, (bytes, dict)):
        raise ValueError(f"modalities: expected {_EXPECTED}; got {type(modalities).__name__}")
    given: list[Modality] = []
    for item in modalities:
        if isinstance(item, Modality):
            given.append(item)
        elif isinstance(item, str):
            given += parse_modalities(item) if item.strip() else ()
        else:
            raise ValueError(
                f"modalities: expected {_EXPECTED}; got {type(item).__name__} {item!r}"
            )
    return tuple(given) or None


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
