"""Which stream and which fields of a recording become which modality, and in which unit.

The syntax extends the CSV import's ``NAME=COL,COL`` with the stream the columns come from::

    NAME=STREAM:FIELD,FIELD,...[@UNIT]

``STREAM`` is a ROS topic (``/icub/left_arm/pose``), an XDF stream's name, a YARP port (its
folder in the dump, or the port name its ``info.log`` gives) or a C3D marker label; everything
before the **last** ``:`` is the stream, so a Vicon label ``Subject1:LHAND`` works as it is
(``hand=Subject1:LHAND:x,y,z``). ``FIELD`` is a ROS message's dotted field path
(``pose.position.x``, ``position[3]`` for an array element, ``orientation.roll``/``pitch``/
``yaw`` for the Euler angles of a quaternion, and on ``/tf`` the child frame first:
``left_hand.translation.x``), an XDF channel label (or its index ``0, 1, ...``), a YARP value's
index (``0`` is the first value after the time stamp) or ``x``/``y``/``z`` of a C3D marker
(a C3D's analog channels are the stream ``ANALOG``, each named by its label:
``emg=ANALOG:EMG1,EMG2@V``). Braces repeat a path:
``pose.position.{x,y,z}`` is ``pose.position.x,pose.position.y,pose.position.z``, and so is
``pose.position.x,y,z`` (bare axis names, x y z w roll pitch yaw, after a dotted path share
it). ``@UNIT`` says
what the values are in when the file does not: ``@mm`` and ``@cm`` are converted to metres,
``@deg`` to radians; any other unit (``@N``, ``@V``) is kept as it is. A recording's own units
(a C3D's ``POINT:UNITS``, an XDF channel's ``unit``) are converted the same way.

Without a stream (``hand=x,y,z``) the fields are looked for in every stream, and the one stream
that has them all is used. Several modalities are separated by ``;`` or new lines (a mapping
file holds one per line; ``#`` starts a comment).

The columns of the demonstrations are the fields' last names (``pose.position.x`` is ``x``)
when those are unique names, otherwise ``<modality>_<name>`` (``hand_0``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from promp.data import Modality

__all__ = [
    "column_names",
    "compress_fields",
    "field_leaf",
    "mapping_text",
    "MODALITY_NAME",
    "modality_name",
    "parse_sourced",
    "SHARED_LEAVES",
    "si_unit",
    "sourced",
    "SourcedModality",
    "split_fields",
    "unique_name",
    "UNITS",
]

# Units a recording or a mapping may state, and the unit they become with the factor.
UNITS: dict[str, tuple[str, float]] = {
    **dict.fromkeys(("m", "meter", "meters", "metre", "metres"), ("m", 1.0)),
    **dict.fromkeys(("mm", "millimeter", "millimeters", "millimetre", "millimetres"),
                    ("m", 1e-3)),  # fmt: skip
    **dict.fromkeys(("cm", "centimeter", "centimeters", "centimetre", "centimetres"),
                    ("m", 1e-2)),  # fmt: skip
    **dict.fromkeys(("rad", "radian", "radians"), ("rad", 1.0)),
    **dict.fromkeys(("deg", "degree", "degrees", "°"), ("rad", math.pi / 180.0)),
}
MODALITY_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,39}$")
# Axis names that, bare after a dotted field, share its path (``pose.position.x,y,z``).
SHARED_LEAVES = ("x", "y", "z", "w", "roll", "pitch", "yaw")


def si_unit(unit: str) -> tuple[str, float]:
    """The unit ``unit`` is converted to, and the factor: ``"mm"`` is ``("m", 0.001)``,
    ``"deg"`` is ``("rad", pi / 180)``; an unknown unit stays as it is (factor 1)."""
    unit = str(unit).strip()
    return UNITS.get(unit.lower(), (unit, 1.0))


@dataclass(frozen=True)
class SourcedModality(Modality):
    """A modality named with its source in a recording (``NAME=STREAM:FIELD,...``).

    ``columns`` holds the fields as written until the recording is read; ``stream`` is empty
    when the mapping leaves it to be found; ``stated_unit`` is the ``@UNIT`` (empty: the
    recording's own unit, if it says one)."""

    stream: str = ""
    stated_unit: str = ""

    @property
    def fields(self) -> tuple[str, ...]:
        return self.columns

    def spec(self) -> str:
        """The modality in the mapping syntax (the inverse of :func:`parse_sourced`)."""
        source = f"{self.stream}:" if self.stream else ""
        unit = f"@{self.stated_unit}" if self.stated_unit else ""
        return f"{self.name}={source}{compress_fields(self.fields)}{unit}"


def split_fields(text: str) -> list[str]:
    """``text`` split at the commas outside braces, each part's braces expanded:
    ``"a.{x,y},b"`` is ``["a.x", "a.y", "b"]``."""
    parts, depth, current = [], 0, ""
    for char in text:
        if char == "{":
            depth += 1
        elif char == "}":
            depth -= 1
            if depth < 0:
                raise ValueError(f"unbalanced braces in {text!r}")
        if char == "," and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += char
    if depth:
        raise ValueError(f"unbalanced braces in {text!r}")
    parts.append(current)
    fields = []
    for part in (p.strip() for p in parts):
        match = re.fullmatch(r"([^{}]*)\{([^{}]*)\}([^{}]*)", part)
        if match:
            head, inner, tail = match.groups()
            fields += [f"{head}{item.strip()}{tail}" for item in inner.split(",") if item.strip()]
        elif "{" in part:
            raise ValueError(f"one pair of braces per field, got {part!r}")
        elif part:
            fields.append(part)
    # "pose.position.x,y,z": bare axis names after a dotted path share its path.
    head = fields[0].rpartition(".")[0] if fields else ""
    if head and len(fields) > 1 and all(f in SHARED_LEAVES for f in fields[1:]):
        fields = [fields[0], *(f"{head}.{f}" for f in fields[1:])]
    return fields


def compress_fields(fields: Sequence[str]) -> str:
    """``fields`` as written in a mapping: ``a.x,a.y,a.z`` as ``a.{x,y,z}`` when they share a
    dotted path."""
    heads = {f.rpartition(".")[0] for f in fields}
    if len(fields) > 1 and len(heads) == 1 and next(iter(heads)):
        head = next(iter(heads))
        return f"{head}.{{{','.join(f.rpartition('.')[2] for f in fields)}}}"
    return ",".join(fields)


def parse_sourced(spec: str) -> SourcedModality:
    """``"NAME=STREAM:FIELD,FIELD[@UNIT]"`` (see the module docstring) as a modality.

    Raises
    ------
    ValueError
        No ``=``, an invalid name, no field, unbalanced braces, or a field named twice.
    """
    name, sep, rest = str(spec).partition("=")
    name = name.strip()
    if not sep or not name:
        raise ValueError(f"a modality is NAME=STREAM:FIELD,FIELD,..., got {spec!r}")
    if not MODALITY_NAME.match(name):
        raise ValueError(
            f"invalid modality name {name!r}: use 1-40 letters, digits, '_' or '-', "
            "starting with a letter"
        )
    rest, at, unit = rest.rpartition("@") if "@" in rest else (rest, "", "")
    stream, colon, fields_text = rest.rpartition(":")
    if not colon:
        stream, fields_text = "", rest
    fields = split_fields(fields_text)
    if not fields:
        raise ValueError(f"modality {name!r} names no field: {spec!r}")
    if len(set(fields)) != len(fields):
        raise ValueError(f"modality {name!r} names a field twice: {fields}")
    if at and not unit.strip():
        raise ValueError(f"modality {name!r}: '@' must be followed by a unit, e.g. @mm")
    return SourcedModality(
        name, tuple(fields), unit="", kind="linear", stream=stream.strip(),
        stated_unit=unit.strip(),
    )  # fmt: skip


def sourced(modality: Modality) -> SourcedModality:
    """``modality`` as a sourced one (a plain ``NAME=COL,COL`` has no stream: it is looked for)."""
    if isinstance(modality, SourcedModality):
        return modality
    return SourcedModality(modality.name, modality.columns, unit="", kind=modality.kind)


def mapping_text(modalities: Iterable[SourcedModality]) -> str:
    """Several modalities in the mapping syntax, ``; `` between them."""
    return "; ".join(m.spec() for m in modalities)


def field_leaf(field: str) -> str:
    """The last name of a field path: ``pose.position.x`` is ``x``; ``position[3]`` is
    ``position_3``."""
    leaf = field.rpartition(".")[2]
    return re.sub(r"\[(\d+)\]", r"_\1", leaf).strip() or field


def column_names(modalities: Sequence[SourcedModality]) -> list[tuple[str, ...]]:
    """The demonstration columns of each modality (see the module docstring)."""
    leaves = [[field_leaf(f) for f in m.fields] for m in modalities]
    counts: dict[str, int] = {}
    for names in leaves:
        for leaf in names:
            counts[leaf] = counts.get(leaf, 0) + 1
    return [
        tuple(
            leaf if counts[leaf] == 1 and re.match(r"^[A-Za-z]", leaf) else f"{m.name}_{leaf}"
            for leaf in names
        )
        for m, names in zip(modalities, leaves, strict=True)
    ]


def unique_name(
    raw: str, taken: set[str], fallback: str, lead: str, sep: str, letter_first: bool
) -> str:
    """``raw`` as a name of 1-40 letters, digits, '_' and '-' (other characters become '_';
    ``lead`` put before one that does not start with a letter, or with a letter or digit when
    not ``letter_first``), unique among ``taken`` (``sep`` and a number added), and added to
    ``taken``."""
    name = re.sub(r"[^A-Za-z0-9_-]+", "_", raw).strip("_-") or fallback
    if not (name[0].isalpha() if letter_first else name[0].isalnum()):
        name = lead + name
    name = name[:40]
    candidate, i = name, 2
    while candidate in taken:
        tail = f"{sep}{i}"
        candidate = name[: 40 - len(tail)] + tail
        i += 1
    taken.add(candidate)
    return candidate


def modality_name(stream: str, taken: set[str]) -> str:
    """A modality name made from a stream's name, unique among ``taken`` (added to it)."""
    return unique_name(stream, taken, "signal", "s", "_", letter_first=True)
