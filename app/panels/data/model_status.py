"""The Data tab's line on the model inference uses: the one learned from the demonstrations,
or one imported (with "Use the learned model" to go back to the learned one)."""

from __future__ import annotations

from collections.abc import Callable

import viser

from app.core.snapshot import Snapshot
from app.ui.context import PanelContext
from app.ui.text import escape

Notify = Callable[[viser.ClientHandle | None, str, str, str], None]


class ModelStatus:
    """The model status line and its "Use the learned model" button."""

    def __init__(self, ctx: PanelContext, notify: Notify):
        self.ctx, self.notify = ctx, notify
        self._status: tuple = ()  # what the status shows
        self.text = ctx.gui.add_markdown("")
        self.use_learned_button = ctx.gui.add_button(
            "Use the learned model", icon=viser.Icon.ARROW_BACK_UP, visible=False
        )
        self.use_learned_button.on_click(lambda event: self.use_learned_model(event.client))

    def use_learned_model(self, client: viser.ClientHandle | None) -> None:
        self.ctx.view.use_imported(None, "", self.ctx.store.state)
        self.notify(
            client, "Learned model", "Inference uses the model learned from the demos.", "blue"
        )

    def step(self, snapshot: Snapshot) -> None:
        imported, model = snapshot.imported, snapshot.model
        status = (imported, model, snapshot.learner.error)
        if self._status and all(a is b for a, b in zip(status, self._status, strict=True)):
            return
        self._status = status
        if imported is not None:
            names = ", ".join(p.name for p in imported.model.primitives)
            text = (
                f"**Inference model:** imported from `{imported.source}` ({names}), used until "
                "the demonstrations change."
            )
        elif model is not None:
            names = ", ".join(p.name for p in model.primitives)
            text = f"**Inference model:** learned from the demonstrations ({names})."
        else:
            text = f"**Inference model:** none yet ({escape(str(snapshot.learner.error))})."
        self.text.content = text
        self.use_learned_button.visible = imported is not None
