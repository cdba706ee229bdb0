"""Where the takes of a YARP dump are: the two layouts a dump comes in.

``yarpdatadumper`` writes one folder per port it listens to, named after the port, and numbers
the folder of every later dump of the same port (``state:o``, then ``state:o_00001``,
``state:o_00002``, ...). A dataset of dumps arrives in one of two layouts:

* **take folders**: ``<class>/<take>/<port>/data.log``, one folder per take holding one folder
  per port (a session to cut by its markers: ``<session>/<port>/data.log``, or a folder
  holding ``data.log`` itself); each take folder is a recording;
* **numbered ports**, as an iCub's dumpers leave them when started in the class's folder:
  ``<class>/<port>/<port name>_NNNNN/data.log``, one folder per port holding one numbered
  folder per take (the first dump of a port unnumbered: take ``00000``). Every number is a
  take: the ports of a class are matched by their number, and the take is named by it
  (``reach/00003``, the same demonstration as ``reach/00003/<port>/`` in the take folders).

A dump in the numbered-port layout reads the same demonstrations as the same dump rearranged
into take folders (``tests/test_promp_yarp_layout.py``). Refused, with the layouts expected and what
was found: a folder that holds numbered takes of several ports, or both take folders and
numbered port folders, or its own ``data.log`` beside port folders; a class whose port folders
do not hold the same numbers (a port lacks a take another one has: the pairing by number would
be a guess).
"""

from __future__ import annotations

import re
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

from promp.names import natural_sorted

__all__ = ["find_takes", "FIRST", "layout_notes", "LAYOUTS", "LOG", "NUMBERED", "NumberedTake"]

LOG = "data.log"
NUMBERED = re.compile(r"^(?P<stem>.+)_(?P<number>[0-9]{5})$")
FIRST = "00000"  # the number of a port's unnumbered first dump
LAYOUTS = (
    "a YARP dump is read in one of two layouts: take folders, <class>/<take>/<port>/data.log "
    "(a session: <session>/<port>/data.log), or numbered port folders as yarpdatadumper "
    "writes them, <class>/<port>/<port name>_NNNNN/data.log (each number a take, matched "
    "across the class's ports)"
)


@dataclass(frozen=True)
class NumberedTake:
    """One take of the numbered-port layout: the folder of the same number in every port
    folder of a class.

    Attributes
    ----------
    where : Path
        ``<class folder>/<number>``: not on disk; it names the take as a take folder would.
    ports : tuple of (str, Path, str)
        Each port: its stream name (the port folder's name), the numbered folder holding its
        ``data.log``, and that folder as messages name it (relative to the dataset).
    aliases : tuple of (str, str)
        Other names of a port's stream: the numbered folder's stem (``state:o``).
    """

    where: Path
    ports: tuple[tuple[str, Path, str], ...]
    aliases: tuple[tuple[str, str], ...] = ()


def _refused(root: Path, found: str) -> ValueError:
    return ValueError(f"{root}: {LAYOUTS}; found {found}")


def _shown(folder: Path, root: Path) -> str:
    return folder.relative_to(root).as_posix() if folder != root else root.name


def _number(leaf: Path, stem: str) -> str | None:
    """The take number of the dump folder ``leaf`` of a port whose dumps are named ``stem``
    (None when it is not one of them)."""
    if leaf.name == stem:
        return FIRST
    match = NUMBERED.match(leaf.name)
    return match.group("number") if match and match.group("stem") == stem else None


def _port_stem(folder: Path, leaves: list[Path], root: Path) -> str | None:
    """The stem of the numbered dumps in ``folder`` (None when none of ``leaves`` is
    numbered); refused when they are not all of one port."""
    stems = {m.group("stem") for leaf in leaves if (m := NUMBERED.match(leaf.name))}
    if not stems:
        return None
    if len(stems) > 1 or any(_number(leaf, next(iter(stems))) is None for leaf in leaves):
        listed = ", ".join(leaf.name for leaf in natural_sorted(leaves, key=lambda p: p.name))
        raise _refused(root, f"{_shown(folder, root)}/ holding the dumps of several ports "
                             f"({listed}): a port folder holds the numbered dumps of one "
                             "port")  # fmt: skip
    return stems.pop()


def _matched(klass: Path, ports: dict[str, dict[str, Path]], root: Path) -> list[NumberedTake]:
    """The takes of the class folder ``klass`` whose port folders hold ``ports`` ({port:
    {number: dump folder}}); refused when their numbers differ."""
    numbers = natural_sorted({n for dumps in ports.values() for n in dumps})
    lacking = [(port, [n for n in numbers if n not in dumps]) for port, dumps in ports.items()]
    lacking = [(port, missing) for port, missing in lacking if missing]
    if lacking:
        said = "; ".join(
            f"{port} lacks take{'s' if len(missing) > 1 else ''} {', '.join(missing[:5])}"
            + (" ..." if len(missing) > 5 else "")
            for port, missing in lacking[:4]
        )
        raise ValueError(
            f"{_shown(klass, root)}: its numbered port folders do not hold the same takes "
            f"({said}; the takes are {', '.join(numbers[:8])}{' ...' if len(numbers) > 8 else ''})"
            ": each number is a take, matched across the ports, so every port needs every "
            "number; remove the incomplete take or rearrange the dump as <class>/<take>/<port>/"
        )
    takes = []
    for number in numbers:
        items = natural_sorted(ports.items(), key=lambda item: item[0])
        takes.append(NumberedTake(
            klass / number if klass != root else root / number,
            tuple((port, dumps[number], _shown(dumps[number], root)) for port, dumps in items),
            tuple((dumps[number].name, port) for port, dumps in items
                  if dumps[number].name != port),
        ))  # fmt: skip
    return takes


def find_takes(root: Path) -> list[Path | NumberedTake]:
    """The recordings of the dump at ``root`` in natural order: take folders (a path) and
    numbered takes (:class:`NumberedTake`).

    Raises
    ------
    ValueError
        A folder matching neither layout, or numbered ports whose numbers differ (see the
        module docstring).
    """
    root = Path(root)
    logs = [p for p in root.rglob(LOG) if p.is_file()
            and not any(part.startswith(".") for part in p.relative_to(root).parts)]  # fmt: skip
    leaves = {log.parent for log in logs}
    for leaf in leaves:
        nested = [other for other in leaves if leaf in other.parents]
        if nested:
            raise _refused(root, f"{_shown(leaf, root)}/ holding its own {LOG} beside folders "
                                 f"with theirs ({_shown(nested[0], root)}/)")  # fmt: skip
    by_folder: dict[Path, list[Path]] = defaultdict(list)
    for leaf in leaves:
        by_folder[leaf.parent if leaf != root else leaf].append(leaf)
    numbered: dict[Path, dict[str, dict[str, Path]]] = defaultdict(dict)  # class -> ports
    takes: list[Path] = []
    for folder, inside in by_folder.items():
        if folder == root and root in leaves:
            takes.append(root)  # a folder holding data.log itself: one port's recording
            continue
        stem = _port_stem(folder, inside, root)
        if stem is None:
            takes.append(folder)
            continue
        klass = folder.parent if folder != root else root
        numbered[klass][folder.name] = {_number(leaf, stem): leaf for leaf in inside}
    for klass, ports in numbered.items():
        # A port dumped only once has one unnumbered folder: take 00000 of a numbered class.
        for once in [t for t in takes if t.parent == klass and len(by_folder[t]) == 1]:
            ports[once.name] = {FIRST: by_folder[once][0]}
            takes.remove(once)
        mixed = [t for t in takes if t.parent == klass and t != klass]
        if mixed:
            raise _refused(root, f"{_shown(klass, root)}/ holding both numbered port folders "
                                 f"({', '.join(natural_sorted(numbered[klass]))}) and take "
                                 f"folders ({', '.join(t.name for t in mixed[:4])})")  # fmt: skip
        if klass in takes or any(t in klass.parents for t in takes):
            raise _refused(root, f"{_shown(klass, root)}/ holding numbered port folders inside "
                                 "a take folder")  # fmt: skip
    found: list[Path | NumberedTake] = list(takes)
    for klass, ports in numbered.items():
        found += _matched(klass, ports, root)
    return natural_sorted(found, key=lambda u: (u.where if isinstance(u, NumberedTake) else u)
                          .relative_to(root))  # fmt: skip


def layout_notes(takes: list[Path | NumberedTake], root: Path) -> list[str]:
    """What the preview says of the numbered takes found: per class folder, its port folders
    and its takes (nothing for take folders, which name themselves)."""
    classes: dict[Path, list[NumberedTake]] = defaultdict(list)
    for take in takes:
        if isinstance(take, NumberedTake):
            classes[take.where.parent].append(take)
    notes = []
    for klass, found in classes.items():
        ports = ", ".join(port for port, _, _ in found[0].ports)
        numbers = [t.where.name for t in found]
        notes.append(
            f"{_shown(klass, root)}: numbered port folders ({ports}), {len(found)} take(s) "
            f"matched by their number ({', '.join(numbers[:6])}{' ...' if len(numbers) > 6 else ''}"
            f"), each named {_shown(klass, root)}/<number>"
        )
    return notes
