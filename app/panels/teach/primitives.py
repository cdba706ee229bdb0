"""The Teach tab's Primitive folder: the primitive being taught, and creating, renaming,
recolouring and deleting primitives.

Each control makes one store mutation (:meth:`app.core.store.Store.create_primitive`,
``rename_primitive``, ``recolor_primitive``, ``delete_primitive`` after a confirmation); a
refused one is a notification to the client who made it and changes nothing. The primitive
being taught is the view state's (:meth:`app.core.view_state.View.choose`): the dropdown sets
it, and each frame shows it (a primitive just created, renamed or recorded into is chosen).
"""

from __future__ import annotations

import viser

from app.core.snapshot import Snapshot
from app.ui.context import PanelContext
from app.ui.text import chosen_hint

NO_PRIMITIVE = "(no primitive)"
NO_COLOR = (128, 128, 128)
CREATE, RENAME = "Create", "Rename"
HINT = "The movement being taught; recordings go into it."


class PrimitiveSection:
    """The Primitive folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext):
        self.ctx = ctx
        self._pending_delete: str | None = None
        self._shown: tuple = (None, None)  # the primitive the folder shows, its colour
        state = ctx.store.state
        names = state.names
        gui = ctx.gui
        with gui.add_folder("Primitive"):
            self.dropdown = gui.add_dropdown(
                "Primitive",
                tuple(names) or (NO_PRIMITIVE,),
                hint=HINT,
            )
            self.color = gui.add_rgb("Colour", state.color(names[0]) if names else NO_COLOR)
            self.new_name = gui.add_text(
                "Name", "", hint="1-40 letters, digits, '_' or '-', e.g. to_bin_2"
            )
            self.name_actions = gui.add_button_group("", (CREATE, RENAME))
            self.delete = gui.add_button("Delete primitive", color="gray", icon=viser.Icon.TRASH)
            self.confirm_text = gui.add_markdown("", visible=False)
            self.confirm = gui.add_button_group("", ("Yes, delete", "Cancel"), visible=False)
        self.dropdown.on_update(self._chosen)
        self.color.on_update(self._recolor)
        self.name_actions.on_click(self._name_action)
        self.delete.on_click(self._ask_delete)
        self.confirm.on_click(self._confirmed)

    def selected(self) -> str | None:
        """The primitive the dropdown shows (None when there is none)."""
        value = self.dropdown.value
        return None if value == NO_PRIMITIVE else value

    # ------------------------------------------------------------------ callbacks

    def _chosen(self, _event) -> None:
        if self.selected() is not None:
            self.ctx.view.choose(self.selected())

    def _recolor(self, event) -> None:
        store, name = self.ctx.store, self.selected()
        rgb = tuple(int(c) for c in self.color.value)
        if name is None or name not in store.state.names:
            return
        if rgb != tuple(store.state.color(name)):
            self.ctx.attempt(event, "recolour", lambda: store.recolor_primitive(name, rgb))

    def _name_action(self, event) -> None:
        store, view, new = self.ctx.store, self.ctx.view, self.new_name.value.strip()
        if event.target.value == CREATE:
            done = self.ctx.attempt(event, "create", lambda: store.create_primitive(new))
        else:
            old = self.selected()
            if old is None:
                self.ctx.tell(event, "Nothing to rename", "Create a primitive first.")
                return
            done = self.ctx.attempt(event, "rename", lambda: store.rename_primitive(old, new))
            if done:
                view.renamed(old, new)
        if done:
            view.choose(new)
            self.new_name.value = ""

    def _ask_delete(self, event) -> None:
        name = self.selected()
        if name is None:
            self.ctx.tell(event, "Nothing to delete", "There is no primitive.")
            return
        n = len(self.ctx.store.state.demos.get(name, ()))
        self._pending_delete = name
        self.confirm_text.content = (
            f"Delete **{name}** and its {n} demonstration(s)? They move to the "
            "workspace's trash: *Undo delete* brings them back."
        )
        self.confirm_text.visible = True
        self.confirm.visible = True

    def _confirmed(self, event) -> None:
        name, self._pending_delete = self._pending_delete, None
        self.confirm_text.visible = False
        self.confirm.visible = False
        if event.target.value.startswith("Yes") and name is not None:
            self.ctx.attempt(event, "delete", lambda: self.ctx.store.delete_primitive(name))

    # ------------------------------------------------------------------ the frame

    def step(self, snapshot: Snapshot) -> str | None:
        """Show ``snapshot``'s primitives and the one taught, in its colour; a confirmation to
        delete another primitive is withdrawn. Returns the primitive taught.

        A control is set only when what it shows changed in the state: a choice the user made
        after this frame's snapshot was taken is not undone."""
        store = snapshot.store
        options = store.names or (NO_PRIMITIVE,)
        if tuple(self.dropdown.options) != options:
            self.dropdown.options = options
        name = snapshot.primitive
        shown = (name, store.color(name) if name is not None else None)
        if shown != self._shown:
            if name != self._shown[0] and self._pending_delete is not None:
                self._pending_delete = None
                self.confirm.visible = self.confirm_text.visible = False
            self._shown = shown
            if name is not None:
                self.dropdown.value = name
                self.color.value = shown[1]
                self.dropdown.hint = chosen_hint(HINT, name)  # the field may cut it
        return name
