"""The Data tab's "Recently deleted": the workspace's trash, restorable.

Every deleted demonstration or primitive and every replaced workspace is an entry of the
workspace's ``trash/`` folder (:mod:`app.io.trash`), kept on disk after the studio closes. The
list shows them newest first; *Restore* puts the chosen one back (a replaced workspace swaps
with the current one, which goes to the trash in turn).
"""

from __future__ import annotations

from collections.abc import Callable

import viser

from app.core.snapshot import Snapshot
from app.io.trash import TrashEntry
from app.ui.context import PanelContext
from app.ui.text import escape

Notify = Callable[[viser.ClientHandle | None, str, str, str], None]
NOTHING = "(the trash is empty)"
KIND_WORDS = {
    "demo": "demonstration", "primitive": "primitive", "workspace": "workspace", "run": "evaluation"
}  # fmt: skip


def entry_label(entry: TrashEntry) -> str:
    """E.g. ``2026-11-22 14:02:11 · demonstration curved_003 of curved``."""
    return f"{entry.when} · {KIND_WORDS.get(entry.kind, entry.kind)} {entry.label}"


class RecentlyDeleted:
    """The "Recently deleted" folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext, notify: Notify):
        self.store = ctx.store
        self.notify = notify
        self._entries: dict[str, TrashEntry] = {}
        self._shown: tuple | None = None  # the trash listed
        gui = ctx.gui
        with gui.add_folder("Recently deleted", expand_by_default=False):
            self.summary = gui.add_markdown("")
            self.choice = gui.add_dropdown("Entry", (NOTHING,))
            self.restore_button = gui.add_button(
                "Restore", icon=viser.Icon.ARROW_BACK_UP, disabled=True,
                hint="Put the chosen entry back where it was",
            )  # fmt: skip
        self.restore_button.on_click(lambda event: self.restore(event.client, self.choice.value))

    def step(self, snapshot: Snapshot) -> None:
        """List the trash of ``snapshot``'s workspace, when it changed."""
        entries = snapshot.store.trash
        if entries is self._shown:
            return
        self._shown = entries
        self._entries = {entry_label(e): e for e in entries}
        options = tuple(self._entries) or (NOTHING,)
        if tuple(self.choice.options) != options:
            self.choice.options = options
        self.restore_button.disabled = not entries
        folder = escape(str(snapshot.store.workspace.trash.root))
        self.summary.content = (
            f"{len(entries)} item(s) in {folder}, kept until you delete them yourself."
            if entries
            else "Deleted demonstrations, primitives and evaluation runs, and replaced "
            "workspaces, go to the workspace's trash folder and can be restored here."
        )

    def restore(self, client, label: str) -> TrashEntry | None:
        entry = self._entries.get(label)
        if entry is None:
            self.notify(client, "Nothing to restore", "Choose an entry of the trash.", "red")
            return None
        try:
            self.store.restore(entry.name)
        except (ValueError, OSError) as exc:
            self.notify(client, "Cannot restore", f"{exc}. Nothing was changed.", "red")
            return None
        self.notify(client, "Restored", f"{entry.label} is back.", "green")
        return entry
