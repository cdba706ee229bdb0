"""The typicality scorings the learner runs, and who hears of the scores.

This run's takes are scored one by one as they come (:mod:`app.core.take_scores`), the
workspace's pending demonstrations (an import's) a primitive at a time
(:mod:`app.core.pending_scores`): the learner's worker runs the takes' before the held-out model
the Infer tab waits for, the pending ones after it (:class:`app.core.learner.Learner`). Each
job says which demonstrations it scores and computes their scores from the latest model; the
scores, once published, are handed to the listeners (the session's store keeps them in the
workspace). Not thread-safe: the learner's lock guards it.
"""

from __future__ import annotations

from collections.abc import Callable, Collection

from app.core.pending_scores import PendingScores
from app.core.store_state import StoreState
from app.core.take_scores import Scored, TakeScores
from promp.model import ProMPModel


class Scorings:
    """The two queues of scorings, and the listeners (see the module docstring).

    Attributes
    ----------
    takes : TakeScores
        This run's takes, first.
    pending : PendingScores
        The workspace's pending demonstrations, last.
    """

    def __init__(self) -> None:
        self.takes = TakeScores()
        self.pending = PendingScores()
        self._listeners: list[Callable[[Scored], None]] = []

    def ask(self, store: StoreState, model: ProMPModel | None, scored: Collection[int]) -> None:
        """Queue the scoring of ``store``'s takes and pending demonstrations neither
        ``scored`` (ids) nor queued already (the takes with the settings ``model`` chose)."""
        self.takes.ask(store, model, scored)
        self.pending.ask(store, scored)

    def on_scored(self, callback: Callable[[Scored], None]) -> None:
        self._listeners.append(callback)

    def tell(self, scored: Scored) -> None:
        """Hand ``scored`` to every listener (no lock held)."""
        for callback in list(self._listeners):
            callback(scored)
