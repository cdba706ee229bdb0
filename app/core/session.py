"""The studio's state, three small things: the store (the workspace), the learner (the model,
in the background) and the view state (what the user looks at).

One :class:`Session` per server, shared by every browser tab, so two tabs always show the same
state. The loop reads it as one :meth:`Session.snapshot` per frame; panels change it through
the store's mutations and the view's setters, never under a lock of their own.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from app.core.fits import FitCache
from app.core.learner import REFIT_TIMEOUT_S, Learner
from app.core.snapshot import Snapshot
from app.core.store import Store
from app.core.view_state import View
from app.io.workspace import WorkspaceData
from promp.model import ProMPModel


class Session:
    """The store, the learner and the view state (see the module docstring).

    The first model is learned before the constructor returns. ``fits``: where fits are
    kept and reused (sessions given the same cache reuse each other's fits).
    """

    def __init__(self, store: Store, fits: FitCache | None = None):
        self.store = store
        self.learner = Learner(fits if fits is not None else FitCache())
        self.view = View()
        store.on_change(self.learner.follow)
        self.learner.on_scored(store.keep_scores)  # the scores kept in the workspace
        self.wait_for_model()

    @classmethod
    def open(
        cls,
        root: Path,
        default: Callable[[], WorkspaceData] | None = None,
        fits: FitCache | None = None,
    ) -> Session:
        """The session of the workspace at ``root`` (:meth:`app.core.store.Store.open`)."""
        return cls(Store.open(root, default), fits)

    def snapshot(self) -> Snapshot:
        """The state now: three references to immutable values, no lock."""
        return Snapshot(self.store.state, self.learner.state, self.view.state)

    def wait_for_model(self, timeout: float = REFIT_TIMEOUT_S) -> ProMPModel | None:
        """The model of the workspace as it is now, once learned (None when nothing can be
        learned).

        Raises
        ------
        TimeoutError
            If the refit takes longer than ``timeout`` seconds.
        """
        self.learner.wait(self.learner.follow(self.store.state), timeout)
        return self.snapshot().model

    def refit(self) -> ProMPModel | None:
        """Learn the model again (never a reused one) and wait for it (e.g. to time it:
        the learner state's ``fit_ms``)."""
        self.learner.wait(self.learner.follow(self.store.state, reuse=False))
        return self.snapshot().model

    def close(self) -> None:
        """Stop the learner (a job under way finishes first)."""
        self.learner.close()
