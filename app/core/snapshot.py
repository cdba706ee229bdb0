"""One immutable picture of the studio's state: the store's, the learner's and the view's.

The studio's loop takes one :class:`Snapshot` per frame (:meth:`app.core.session.Session.
snapshot`) and hands it to the scene and to every panel, so everything drawn in a frame comes
from the same state, and a test can compare what was drawn with the snapshot it came from.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from types import MappingProxyType

from app.core.learner_state import LearnerState, resolved_settings
from app.core.store_state import Key, StoreState
from app.core.via_state import LayoutViaPoints, by_primitive
from app.core.view_state import ImportedModel, ViewState
from promp.data import Demonstration
from promp.model import ProMPModel, Settings
from promp.typicality import Typicality


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
    def typicality(self) -> Mapping[Key, Typicality]:
        """The demonstrations' scores, by key: those the learner has given in this run (of
        these very demonstrations: a take recorded again under a name is scored anew), else
        those the workspace keeps (:mod:`app.io.demo_scores`)."""
        scores, kept, out = self.learner.scores, self.store.checks.scores.given, {}
        for primitive, demos in self.store.demos.items():
            for demo in demos:
                key, entry = (primitive, demo.name), scores.get(id(demo))
                if entry is not None and entry[0] is demo:
                    if entry[1] is not None:
                        out[key] = entry[1]
                elif key in kept:
                    out[key] = kept[key]
        return MappingProxyType(out)

    @cached_property
    def scoring(self) -> frozenset[Key]:
        """This run's takes the learner has not scored yet."""
        scores = self.learner.scores
        return frozenset(
            (p, n) for p, n in self.store.takes
            if (demo := self._demo(p, n)) is None or scores.get(id(demo), (None,))[0] is not demo
        )  # fmt: skip

    def _demo(self, primitive: str, name: str) -> Demonstration | None:
        return next((d for d in self.store.demos.get(primitive, ()) if d.name == name), None)

    @cached_property
    def hidden(self) -> frozenset[Key]:
        """The hidden demonstrations that the workspace holds."""
        keys = {(p, d.name) for p, items in self.store.demos.items() for d in items}
        return self.view.hidden & keys

    @cached_property
    def via_points(self) -> LayoutViaPoints:
        """The view's via-points on the workspace's layout, as the studio draws them and as
        the method takes them (:func:`app.core.via_state.by_primitive`: made once a frame, for
        whichever inference asks; the model inferred with has the workspace's layout)."""
        return by_primitive(self.view.via_points, self.store.layout)

    @property
    def primitive(self) -> str | None:
        """The primitive chosen in Teach, if the workspace has it, else its first one."""
        names = self.store.names
        chosen = self.view.primitive
        return chosen if chosen in names else (names[0] if names else None)

    def resolved_settings(self) -> Settings:
        """The learning settings with every automatic one at the value the model chose
        (:func:`app.core.learner_state.resolved_settings`): the learner's, resolved once per refit
        (:attr:`LearnerState.settings`), resolved here only while the model does not yet
        answer the latest change."""
        settings, store = self.learner.settings, self.store
        if settings is None or self.refitting:
            settings = resolved_settings(store.learning_settings(), store.layout, self.model)
        return settings
