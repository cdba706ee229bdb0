"""Which group each demonstration belongs to, for an evaluation that holds out a whole group at
a time (``python -m promp.evaluate --group-by``; the studio's Group by).

Leave-one-out within a session flatters a method: a held-out take has near-twins from its own
session (the same person, the same sensor baselines) among the training takes. Studies of
human-robot interaction and EMG report the held-out subject or session instead. A
demonstration's group is read from where it came from, its path below its class folder (the
name the folder readers give it: ``person1/record0`` for ``<class>/person1/record0.txt``):

``folder``
    the first folder below the class folder (``person1``);
``LEVEL``
    a number: the folder at that level below the class folder (1 is ``folder``; for
    ``<goal>/<path>/<session>/record0``, 2 is the session);
``REGEX``
    a regular expression with one group, searched in the path (``S(\\d+)_`` in
    ``S03_trial2``): the group is what it captured.

A group is named by what it is called, whatever the class: ``top/person2`` and
``bottom/person2`` are one subject, held out together.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import PurePosixPath

from promp.data import Demonstration
from promp.names import natural_sorted

__all__ = ["GROUP_BY_HELP", "GroupBy", "group_of", "group_pairs", "parse_group_by"]

GROUP_BY_HELP = (
    "hold out a whole group at a time, beside leave-one-out: 'folder' (the first folder below "
    "the class folder: a subject's or a session's), LEVEL (a number: the folder at that level "
    "below the class folder) or REGEX (a regular expression with one group, searched in each "
    "demonstration's path below its class folder, e.g. 'S(\\d+)_')"
)


@dataclass(frozen=True)
class GroupBy:
    """A rule that names each demonstration's group (module docstring).

    Attributes
    ----------
    text : str
        As given (``folder``, ``2``, ``S(\\d+)_``).
    level : int
        The folder level below the class folder (1: the first), 0 for a pattern.
    pattern : re.Pattern or None
        The regular expression, with one group.
    """

    text: str
    level: int = 0
    pattern: re.Pattern | None = None

    def describe(self) -> str:
        """How the rule reads in a table's title, e.g. "grouped by folder"."""
        if self.pattern is not None:
            return f"grouped by pattern {self.text}"
        return "grouped by folder" if self.level == 1 else f"grouped by folder level {self.level}"


def parse_group_by(text: str) -> GroupBy:
    """The rule ``text`` names (``folder``, a level, or a pattern).

    Raises
    ------
    ValueError
        Empty, a level below 1, a pattern that does not compile or has not exactly one group.
    """
    text = str(text).strip()
    if not text:
        raise ValueError("--group-by: give 'folder', a folder level (1, 2, ...) or a pattern")
    if text == "folder":
        return GroupBy(text, level=1)
    if text.isdigit():
        level = int(text)
        if level < 1:
            raise ValueError(f"--group-by: a folder level is 1 or more (1: the first folder "
                             f"below the class folder), got {text}")  # fmt: skip
        return GroupBy(text, level=level)
    try:
        pattern = re.compile(text)
    except re.error as exc:
        raise ValueError(f"--group-by: {text!r} is not a regular expression ({exc})") from None
    if pattern.groups != 1:
        raise ValueError(
            f"--group-by: the pattern {text!r} has {pattern.groups} groups; it needs exactly "
            "one, the part of the path that names the group, e.g. 'S(\\d+)_'"
        )
    return GroupBy(text, pattern=pattern)


def group_of(path: str, rule: GroupBy) -> str:
    """The group of the demonstration at ``path`` (below its class folder, e.g.
    ``person1/record0``) under ``rule``.

    Raises
    ------
    ValueError
        The path has no folder at the rule's level, or the pattern does not match it.
    """
    if rule.pattern is not None:
        match = rule.pattern.search(path)
        if match is None or not match.group(1):
            raise ValueError(f"{path}: the pattern {rule.text!r} does not match it (or captures "
                             "nothing); every demonstration needs a group")  # fmt: skip
        return match.group(1)
    folders = PurePosixPath(path).parts[:-1]
    if len(folders) < rule.level:
        where = "no folder" if not folders else f"{len(folders)} folder level(s)"
        raise ValueError(
            f"{path}: {where} below its class folder, so no group at level {rule.level}; "
            "group by a pattern in the name instead (--group-by REGEX)"
        )
    return folders[rule.level - 1]


def group_pairs(
    dataset: Mapping[str, Sequence[Demonstration]],
    rule: GroupBy,
    path: Callable[[str, Demonstration], str] | None = None,
) -> dict[str, list[tuple[int, int]]]:
    """Every group's (primitive index, demonstration index) pairs, the groups in natural
    order of their names (what :func:`promp.evaluate.sweep.run_sweep` takes as ``groups``).

    ``path(primitive, demo)`` says where a demonstration came from, below its class folder
    (default: its name, which the folder readers make its path; the studio passes the path
    its workspace kept).

    Raises
    ------
    ValueError
        A demonstration without a group (its primitive and name in the message), or fewer
        than two groups.
    """
    path = path or (lambda _primitive, demo: demo.name)
    groups: dict[str, list[tuple[int, int]]] = {}
    for k, (primitive, demos) in enumerate(dataset.items()):
        for j, demo in enumerate(demos):
            try:
                group = group_of(path(primitive, demo), rule)
            except ValueError as exc:
                raise ValueError(f"{primitive}/{exc}") from None
            groups.setdefault(group, []).append((k, j))
    if len(groups) < 2:
        found = f"one group, {next(iter(groups))!r}" if groups else "no group"
        raise ValueError(f"--group-by {rule.text}: {found}; holding out a group needs two or "
                         "more")  # fmt: skip
    return {name: groups[name] for name in natural_sorted(groups)}
