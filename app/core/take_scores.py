"""The takes whose typicality the learner is asked for: each take scored once, oldest first.

A take (a demonstration recorded in this run, :attr:`app.core.store_state.StoreState.takes`)
is scored against its primitive's other demonstrations that learning uses, with the current
model's choice of the automatic settings (:func:`promp.typicality.typicality`). A take is known
by the id of its demonstration, not by its name: a take recorded again under the same name is
another demonstration, scored anew. The learner's worker runs the scorings
(:class:`app.core.learner.Learner`); this queue is guarded by the learner's lock.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Collection
from dataclasses import dataclass

from app.core.learner_state import resolved_settings
from app.core.store_state import StoreState
from promp.data import Demonstration
from promp.model import ProMPModel
from promp.typicality import Typicality, typicality

# (primitive, the demonstration scored, its typicality or None: too few others)
Scored = list[tuple[str, Demonstration, Typicality | None]]


@dataclass(frozen=True, eq=False)
class TakeJob:
    """The scoring of one take."""

    primitive: str
    demo: Demonstration
    scoring: Callable[[], Typicality | None]

    @property
    def scored(self) -> tuple[Demonstration, ...]:
        return (self.demo,)

    def run(self, model: ProMPModel | None) -> Scored:
        """Its score (with the settings chosen when it was asked for: ``model`` unused)."""
        return [(self.primitive, self.demo, self.scoring())]


def take_scoring(
    store: StoreState, primitive: str, name: str, model: ProMPModel | None
) -> tuple[Demonstration, Callable[[], Typicality | None]] | None:
    """(the take ``name`` of ``primitive``, its scoring), None if ``store`` no longer holds
    it: against its primitive's other demonstrations that learning uses, with the settings
    ``model`` chose (:func:`app.core.learner_state.resolved_settings`)."""
    demo = next((d for d in store.demos.get(primitive, ()) if d.name == name), None)
    if demo is None:
        return None
    others = [d for d in store.learned.get(primitive, []) if d.name != name]
    settings = resolved_settings(store.learning_settings(), store.layout, model)
    return demo, lambda: typicality(demo, others, store.layout, settings)


class TakeScores:
    """The scorings asked for and not yet run (see the module docstring). Not thread-safe:
    its owner's lock guards it."""

    def __init__(self) -> None:
        self._jobs: deque[TakeJob] = deque()
        self._queued: set[int] = set()  # ids of the takes whose score is asked for

    def __bool__(self) -> bool:
        return bool(self._jobs)

    def ask(self, store: StoreState, model: ProMPModel | None, scored: Collection[int]) -> None:
        """Queue the scoring of every take of ``store`` neither ``scored`` (ids) nor queued
        already, with the settings ``model`` chose."""
        for key in sorted(store.takes):
            if (found := take_scoring(store, *key, model)) is None:
                continue  # gone from the workspace (a state that kept its key)
            demo, scoring = found
            if id(demo) not in self._queued and id(demo) not in scored:
                self._queued.add(id(demo))  # the same name may come back anew: by id
                self._jobs.append(TakeJob(key[0], demo, scoring))

    def next(self) -> TakeJob:
        """The oldest scoring asked for (:meth:`done` once it has run)."""
        return self._jobs.popleft()

    def done(self, job: TakeJob) -> None:
        """``job`` has run: its take may be asked for again (when its score is dropped)."""
        self._queued.discard(id(job.demo))
