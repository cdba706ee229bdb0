"""One immutable picture of the studio's state: the store's, the learner's and the view's.

The studio's loop takes one :class:`Snapshot` per frame (:meth:`app.core.session.Session.
snapshot`) and hands it to the scene and to every panel, so everything drawn in a frame comes
from the same state, and a test can compare what was drawn with the snapshot it came from.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

from app.core.learner import LearnerState, resolved_settings
from app.core.store_state import Key, StoreState
from app.core.view_state import ImportedModel, ViewState
from promp.model import ProMPModel, Settings


@dataclass(frozen=True, eq=False)
class Snapshot:
    """The state of the studio at one moment (see the module docstring)."""

    store: StoreState
    learner: LearnerState
    view: ViewState

    @property
    def model(self) -> ProMPModel | None:
        """The latest learned model of the workspace's modalities (it may lag one refit
        behind the demonstrations: :attr:`refitting`)."""
        model = self.learner.model
        return model if model is not None and model.layout == self.store.layout else None

    @property
    def refitting(self) -> bool:
        """True while the model does not yet answer the latest change."""
        return self.learner.learn_version != self.store.learn_version

    @property
    def imported(self) -> ImportedModel | None:
        """The imported model inference uses, while what is learned from is unchanged."""
        imported = self.view.imported
        return imported if imported is not None and imported.valid_for(self.store) else None

    @property
    def inference_model(self) -> ProMPModel | None:
        """The model inference uses: the imported one if any, else the learned one."""
        imported = self.imported
        return imported.model if imported is not None else self.model

    @cached_property
    def hidden(self) -> frozenset[Key]:
        """The hidden demonstrations that the workspace holds."""
        keys = {(p, d.name) for p, items in self.store.demos.items() for d in items}
        return self.view.hidden & keys

    @property
    def primitive(self) -> str | None:
        """The primitive chosen in Teach, if the workspace has it, else its first one."""
        names = self.store.names
        chosen = self.view.primitive
        return chosen if chosen in names else (names[0] if names else None)

    def resolved_settings(self) -> Settings:
        """The learning settings with every automatic one at the value the model chose
        (:func:`app.core.learner.resolved_settings`)."""
        return resolved_settings(self.store, self.learner.model)
