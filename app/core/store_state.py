"""The workspace at one moment, as one immutable value (:class:`StoreState`), which
:class:`app.core.store.Store` publishes after every change; and the helpers that derive one
state from another."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace
from functools import cached_property
from types import MappingProxyType

from app.io.demo_checks import DemoChecks
from app.io.demo_sources import DemoSources
from app.io.hand_frame import ICUB_FRAME, HandFrame
from app.io.trash import TrashEntry
from app.io.workspace import Workspace, WorkspaceData
from app.io.workspace_index import PrimitiveEntry
from promp.data import Demonstration, Layout
from promp.model import Settings
from promp.quality import Finding, split_flagged
from promp.typicality import Typicality

Key = tuple[str, str]  # (primitive, demonstration)


@dataclass(frozen=True, eq=False)
class StoreState:
    """The workspace at one moment (see the module docstring). Equal only to itself.

    Attributes
    ----------
    version : int
        Counts the store's changes (0 when opened).
    learn_version : int
        Counts the changes of what is learned from (demonstrations, settings, checks, layout).
    workspace : Workspace
        The folder (its ``root``, paths, trash).
    layout : Layout
    primitives : tuple of PrimitiveEntry
    demos : mapping of str to tuple of Demonstration
        Every primitive's demonstrations, in the order recorded.
    settings : mapping
        The learning settings the workspace sets (the engine's defaults fill the rest).
    checks : DemoChecks
        The user's Keep and the import's findings (``studio.json``).
    findings : tuple of Finding
        What the checks found in the demonstrations now.
    takes : frozenset of (primitive, demo)
        The takes recorded in this run: the learner scores each (their scores are the
        learner's, :attr:`app.core.learner.LearnerState.scores`).
    deleted : tuple of TrashEntry
        This run's deletions, newest last ("Undo delete").
    trash : tuple of TrashEntry
        Everything in the workspace's trash, newest first.
    problems : tuple of str
        Files the workspace could not read when opened.
    frame : HandFrame
        Where the hand was recorded (``studio.json``): the iCub's frame, placed there, or its
        own (drawn without the robot).
    sources : DemoSources
        Where the imported demonstrations came from, below their class folders
        (``studio.json``): what their groups are read from.
    """

    version: int
    learn_version: int
    workspace: Workspace
    layout: Layout
    primitives: tuple[PrimitiveEntry, ...]
    demos: Mapping[str, tuple[Demonstration, ...]]
    settings: Mapping[str, object]
    checks: DemoChecks
    findings: tuple[Finding, ...]
    takes: frozenset[Key] = frozenset()
    deleted: tuple[TrashEntry, ...] = ()
    trash: tuple[TrashEntry, ...] = ()
    problems: tuple[str, ...] = ()
    frame: HandFrame = ICUB_FRAME
    sources: DemoSources = DemoSources()

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.primitives)

    def color(self, name: str) -> tuple[int, int, int]:
        """The colour of primitive ``name`` (ValueError when there is none)."""
        for p in self.primitives:
            if p.name == name:
                return p.color
        raise ValueError(f"unknown primitive {name!r}")

    @cached_property
    def _split(self) -> tuple[dict, dict]:
        return split_flagged(self.demos, list(self.findings), self.checks.kept)

    @property
    def learned(self) -> dict[str, list[Demonstration]]:
        """Every primitive's demonstrations that learning uses: all but :attr:`left_out`."""
        return self._split[0]

    @property
    def left_out(self) -> dict[Key, list[Finding]]:
        """The flagged demonstrations the user did not keep (left out of learning)."""
        return self._split[1]

    def findings_of(self, primitive: str, demo: str) -> list[Finding]:
        return [f for f in self.findings if f.key == (primitive, demo)]

    def learning_settings(self) -> Settings:
        """Every stored setting honoured (an imported workspace may set the ridge or the
        noise, for example); absent ones take the engine's defaults."""
        return Settings(**self.settings)


def frozen_demos(
    demos: Mapping[str, list[Demonstration]],
) -> Mapping[str, tuple[Demonstration, ...]]:
    """``demos`` as the state holds them: read-only, tuples."""
    return MappingProxyType({name: tuple(items) for name, items in demos.items()})




def adopted(
    workspace: Workspace, data: WorkspaceData, version: int, learn_version: int, **kept
) -> StoreState:
    """The state of ``data``, read from (or just written to) ``workspace``; ``kept``: fields
    carried over (takes, deleted), pruned to the demonstrations ``data`` holds."""
    demos = {p.name: list(data.demos.get(p.name, [])) for p in data.primitives}
    keys = {(p, d.name) for p, items in demos.items() for d in items}
    takes = frozenset(kept.pop("takes", frozenset())) & keys
    return StoreState(
        version=version,
        learn_version=learn_version,
        workspace=workspace,
        layout=data.layout,
        primitives=tuple(data.primitives),
        demos=frozen_demos(demos),
        settings=MappingProxyType(dict(data.settings)),
        checks=data.checks,
        findings=tuple(data.checks.findings(demos, data.layout)),
        takes=takes,
        trash=tuple(workspace.trash.entries()),
        problems=tuple(data.problems),
        frame=data.frame,
        sources=data.sources,
        **kept,
    )


def workspace_data(state: StoreState) -> WorkspaceData:
    """Everything ``state`` holds of its workspace, as its files would (its own layout, checks
    and every other field :class:`WorkspaceData` has, not the studio's defaults): what an
    export writes."""
    held = {f.name: getattr(state, f.name) for f in fields(WorkspaceData) if hasattr(state, f.name)}
    held.update(
        primitives=list(state.primitives),
        demos={p.name: list(state.demos.get(p.name, ())) for p in state.primitives},
        settings=dict(state.settings),
        problems=list(state.problems),
    )
    return WorkspaceData(**held)


def next_demo_name(state: StoreState, primitive: str) -> str:
    existing = {d.name for d in state.demos.get(primitive, ())}
    i = len(existing)
    while (
        f"{primitive}_{i:03d}" in existing
        or state.workspace.demo_path(primitive, f"{primitive}_{i:03d}").exists()
    ):
        i += 1
    return f"{primitive}_{i:03d}"


def save_index(state: StoreState) -> None:
    state.workspace.save_index(
        state.primitives, state.settings, state.layout, state.checks, state.frame, state.sources
    )


def after_trashing(state: StoreState, entry: TrashEntry) -> StoreState:
    """``state`` after ``entry`` went to the trash (this run's deletions, the trash list;
    its takes those still in the workspace)."""
    keys = {(p, d.name) for p, items in state.demos.items() for d in items}
    return replace(
        state,
        deleted=(*state.deleted, entry),
        trash=tuple(state.workspace.trash.entries()),
        takes=state.takes & keys,
    )


def to_score(state: StoreState, keys: set[Key]) -> DemoChecks:
    """``state``'s checks with ``keys``, new demonstrations, to score (:mod:`app.io.demo_scores`:
    a score given before to their names goes)."""
    return state.checks.with_scores(state.checks.scores.asked(keys))


def with_scores(
    state: StoreState, scored: Sequence[tuple[str, Demonstration, Typicality | None]]
) -> StoreState | None:
    """``state`` keeping the typicality the learner gave (primitive, the demonstration scored,
    its score or None: too few others) to the demonstrations it still holds (these very ones:
    one recorded again under the name is another); None when that changes nothing."""
    held = {(p, d.name): d for p, items in state.demos.items() for d in items}
    given = {(p, demo.name): score for p, demo, score in scored
             if held.get((p, demo.name)) is demo}  # fmt: skip
    scores = state.checks.scores.scored(given)
    if not given or scores == state.checks.scores:
        return None
    return replace(state, checks=state.checks.with_scores(scores))
