"""Where each imported demonstration came from: its path below its class folder in the dataset
it was imported from (``person1/record0`` for ``top/person1/record0.txt``), which names its
subject or session when the evaluation holds out a whole group at a time
(:mod:`promp.evaluate.groups`; the Data tab's Group by, the Infer tab's Hold out).

The import makes every name a safe file name (``person1/record0`` becomes
``person1_record0``), so the path is kept apart, in the workspace's ``studio.json``::

    "sources": [["top", "person1_record0", "person1/record0"], ...]

A workspace written before, and a take recorded in the studio, have none: a demonstration's
path is then its name (one with no folder: grouping by folder refuses it, saying so).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType

from promp.evaluate.groups import group_of, parse_group_by

Key = tuple[str, str]  # (primitive, demonstration)


@dataclass(frozen=True)
class DemoSources:
    """The source path of each imported demonstration (see the module docstring).

    Attributes
    ----------
    entries : tuple of (primitive, demonstration, path)
        Sorted. An entry stays while its demonstration is in the trash (it comes back with it).
    """

    entries: tuple[tuple[str, str, str], ...] = field(default_factory=tuple)

    def __bool__(self) -> bool:
        return bool(self.entries)

    @cached_property
    def _paths(self) -> dict[Key, str]:
        return {(p, d): path for p, d, path in self.entries}

    @classmethod
    def of(cls, paths: Mapping[Key, str]) -> DemoSources:
        """The sources ``{(primitive, demonstration): path}``."""
        return cls(tuple(sorted((p, d, str(path)) for (p, d), path in paths.items())))

    @cached_property
    def folder_groups(self) -> Mapping[int, Mapping[Key, str]]:
        """``{level: {(primitive, demonstration): group}}``: the group of each demonstration
        at every folder level of the paths (:func:`promp.evaluate.groups.group_of` under the
        rule ``folder``, ``2``, ...; one with no folder at a level is in no group there). Read
        once per sources, however often asked (the Infer tab's Hold out, at every frame)."""
        depth = max((path.count("/") for _, _, path in self.entries), default=0)
        levels: dict[int, Mapping[Key, str]] = {}
        for level in range(1, depth + 1):
            rule, groups = parse_group_by(str(level)), {}
            for primitive, demo, path in self.entries:
                try:
                    groups[(primitive, demo)] = group_of(path, rule)
                except ValueError:
                    continue  # no folder at this level
            levels[level] = MappingProxyType(groups)
        return MappingProxyType(levels)

    def path(self, primitive: str, demo: str) -> str:
        """Where ``demo`` of ``primitive`` came from, below its class folder (its name when
        the workspace does not know)."""
        return self._paths.get((primitive, demo), demo)

    def to_json(self) -> list[list[str]]:
        return [list(entry) for entry in self.entries]

    @classmethod
    def from_json(cls, data: object, label: str) -> DemoSources:
        """The inverse of :meth:`to_json`; a ``ValueError`` starting with ``label``."""
        if not isinstance(data, list) or not all(
            isinstance(e, list) and len(e) == 3 and all(isinstance(s, str) and s for s in e)
            for e in data
        ):
            raise ValueError(f"{label}: 'sources' must be a list of [primitive, demo, path]")
        return cls.of({(p, d): path for p, d, path in data})

    def renamed(self, old: str, new: str) -> DemoSources:
        """The same sources with primitive ``old`` called ``new``."""
        return DemoSources.of({(new if p == old else p, d): path
                               for (p, d), path in self._paths.items()})  # fmt: skip
