"""The demonstrations waiting for their typicality (an import's), scored a primitive at a time.

An imported dataset's demonstrations are listed as pending in the workspace
(:attr:`app.io.demo_scores.DemoScores.pending`) until scored, like a take that the studio
stopped before its score came. Each primitive's pending demonstrations are scored together
(:func:`promp.typicality.typicalities`: one fit per demonstration of the primitive, not one per
pair), with the current model's choice of the automatic settings, against the demonstrations
learning uses. This run's takes are scored one by one (:mod:`app.core.take_scores`), not here.
The learner's worker runs the scorings after its refits, the takes and the held-out models
(:class:`app.core.learner.Learner`); this queue is guarded by the learner's lock.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Collection
from dataclasses import dataclass

from app.core.learner_state import resolved_settings
from app.core.store_state import StoreState
from app.core.take_scores import Scored
from promp.data import Demonstration
from promp.model import ProMPModel
from promp.typicality import typicalities


@dataclass(frozen=True, eq=False)
class PendingJob:
    """The scoring of one primitive's pending demonstrations.

    Attributes
    ----------
    primitive : str
    store : StoreState
        The workspace when it was asked for (its layout and learning settings).
    demos : tuple of Demonstration
        The primitive's demonstrations, all of them (each scored against the others).
    learned : tuple of bool
        Which of them learning uses (the others are no one's reference).
    targets : tuple of int
        The indices of those to score.
    """

    primitive: str
    store: StoreState
    demos: tuple[Demonstration, ...]
    learned: tuple[bool, ...]
    targets: tuple[int, ...]

    @property
    def scored(self) -> tuple[Demonstration, ...]:
        return tuple(self.demos[i] for i in self.targets)

    def run(self, model: ProMPModel | None) -> Scored:
        """The scores, with the settings ``model`` (the latest) chose."""
        store = self.store
        settings = resolved_settings(store.learning_settings(), store.layout, model)
        given = typicalities(self.demos, store.layout, settings, self.learned)
        return [(self.primitive, self.demos[i], given[i]) for i in self.targets]


class PendingScores:
    """The primitives' scorings asked for and not yet run (see the module docstring). Not
    thread-safe: its owner's lock guards it."""

    def __init__(self) -> None:
        self._jobs: deque[PendingJob] = deque()
        self._queued: set[int] = set()  # ids of the demonstrations whose score is asked for

    def __bool__(self) -> bool:
        return bool(self._jobs)

    def ask(self, store: StoreState, scored: Collection[int]) -> None:
        """Queue the scoring of ``store``'s pending demonstrations neither ``scored`` (ids)
        nor queued already nor this run's takes, a job per primitive."""
        pending = store.checks.scores.pending - store.takes
        for primitive in store.names:
            demos = tuple(store.demos.get(primitive, ()))
            targets = tuple(
                i for i, d in enumerate(demos)
                if (primitive, d.name) in pending and id(d) not in scored
                and id(d) not in self._queued
            )  # fmt: skip
            if not targets:
                continue
            learned = {id(d) for d in store.learned.get(primitive, ())}
            job = PendingJob(
                primitive, store, demos, tuple(id(d) in learned for d in demos), targets
            )
            self._queued.update(id(d) for d in job.scored)
            self._jobs.append(job)

    def next(self) -> PendingJob:
        """The oldest scoring asked for (:meth:`done` once it has run)."""
        return self._jobs.popleft()

    def done(self, job: PendingJob) -> None:
        """``job`` has run: its demonstrations may be asked for again."""
        self._queued.difference_update(id(d) for d in job.scored)
