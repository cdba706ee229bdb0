"""The groups of a workspace's demonstrations: a subject's or a session's folder of the dataset
the workspace was imported from (:mod:`app.io.demo_sources`, read by the rules of
:mod:`promp.evaluate.groups`). What the Data tab's Group by and the Infer tab's Hold out offer,
and which demonstrations share a demonstration's group.
"""

from __future__ import annotations

from app.core.store_state import Key, StoreState
from promp.evaluate.groups import parse_group_by

MAX_GROUP_LEVELS = 4  # the folder levels offered


def group_levels(store: StoreState) -> int:
    """How many folder levels below their class folders the imported demonstrations came
    from (at most :data:`MAX_GROUP_LEVELS`; 0: none, nothing to group by)."""
    depth = max((path.count("/") for _, _, path in store.sources.entries), default=0)
    return min(depth, MAX_GROUP_LEVELS)


def group_choices(store: StoreState, alone: str, prefix: str = "") -> dict[str, str | None]:
    """``{label: rule}``: ``alone`` (no group: None), then one choice per folder level of
    ``store``'s sources (``folder``, ``folder level 2``, each after ``prefix``), its rule in
    ``--group-by``'s syntax (``folder``, ``2``)."""
    choices: dict[str, str | None] = {alone: None}
    for level in range(1, group_levels(store) + 1):
        label = "folder" if level == 1 else f"folder level {level}"
        choices[f"{prefix}{label}"] = "folder" if level == 1 else str(level)
    return choices


def rule_of(label: str, prefix: str = "") -> str | None:
    """The rule of a label :func:`group_choices` made (after ``prefix``): ``folder``, a level,
    or None for any other label (no group)."""
    label = label.removeprefix(prefix)
    if label == "folder":
        return "folder"
    level = label.removeprefix("folder level ")
    return level if level != label and level.isdigit() else None


def group_members(store: StoreState, primitive: str, demo: str, rule: str) -> tuple[str, list[Key]]:
    """The group of ``demo`` of ``primitive`` under ``rule`` (``--group-by``'s syntax) and
    every demonstration of ``store`` in it, of any primitive, as (primitive, name) keys.

    Raises
    ------
    ValueError
        The demonstration has no group under the rule (its path has no such folder), or the
        rule is a pattern (the studio offers folder levels: :func:`group_choices`).
    """
    level = parse_group_by(rule).level
    if level < 1:
        raise ValueError(f"a group is held out by its folder ('folder', a level), not by the "
                         f"pattern {rule!r}")  # fmt: skip
    groups = store.sources.folder_groups.get(level, {})  # read once per workspace state
    group = groups.get((primitive, demo))
    if group is None:
        raise ValueError(f"{store.sources.path(primitive, demo)}: no folder at level {level} "
                         "below its class folder, so no group to hold out")  # fmt: skip
    members = [(name, d.name) for name, demos in store.demos.items() for d in demos
               if groups.get((name, d.name)) == group]  # a take with no folder: in no group
    return group, members
