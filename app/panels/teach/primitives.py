"""The Teach tab's Primitive folder: the primitive being taught, and creating, renaming,
recolouring and deleting primitives.

Each control makes one session mutation (:meth:`app.core.session.Session.create_primitive`,
``rename_primitive``, ``recolor_primitive``, ``delete_primitive`` after a confirmation); a
refused one is a notification to the client who made it and changes nothing. The selection is
the browser's dropdown; a primitive just created, renamed or recorded into is selected at the
next step (:meth:`PrimitiveSection.select`).
"""

from __future__ import annotations

import threading

import viser

from app.ui.context import PanelContext

NO_PRIMITIVE = "(no primitive)"
NO_COLOR = (128, 128, 128)
CREATE, RENAME = "Create", "Rename"


class PrimitiveSection:
    """The Primitive folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext):
        self.ctx = ctx
        self._lock = threading.Lock()
        self._select: str | None = None  # to select at the next sync
        self.dirty = True  # the selection changed: the tab redraws
        self._pending_delete: str | None = None
        self._synced: str | None = None
        gui, names = ctx.gui, ctx.session.names()
        with gui.add_folder("Primitive"):
            self.dropdown = gui.add_dropdown(
                "Primitive",
                tuple(names) or (NO_PRIMITIVE,),
                hint="The movement being taught; recordings go into it.",
            )
            self.color = gui.add_rgb(
                "Colour", ctx.session.color(names[0]) if names else NO_COLOR
            )
            self.new_name = gui.add_text(
                "Name", "", hint="1-40 letters, digits, '_' or '-', e.g. to_bin_2"
            )
            self.name_actions = gui.add_button_group("", (CREATE, RENAME))
            self.delete = gui.add_button("Delete primitive", color="gray", icon=viser.Icon.TRASH)
            self.confirm_text = gui.add_markdown("", visible=False)
            self.confirm = gui.add_button_group("", ("Yes, delete", "Cancel"), visible=False)
        self.dropdown.on_update(self._selection_changed)
        self.color.on_update(self._recolor)
        self.name_actions.on_click(self._name_action)
        self.delete.on_click(self._ask_delete)
        self.confirm.on_click(self._confirmed)

    def selected(self) -> str | None:
        """The selected primitive's name (None when there is none)."""
        value = self.dropdown.value
        return None if value == NO_PRIMITIVE else value

    def select(self, name: str) -> None:
        """Select ``name`` at the next sync (from any thread)."""
        with self._lock:
            self._select = name

    @property
    def pending(self) -> bool:
        """A selection to apply or redraw at the next sync."""
        return self.dirty or self._select is not None

    # ------------------------------------------------------------------ callbacks

    def _selection_changed(self, _event) -> None:
        self.dirty = True

    def _recolor(self, event) -> None:
        session, name = self.ctx.session, self.selected()
        rgb = tuple(int(c) for c in self.color.value)
        if name is None or name not in session.names():
            return
        if rgb != tuple(session.color(name)):
            self.ctx.attempt(event, "recolour", lambda: session.recolor_primitive(name, rgb))

    def _name_action(self, event) -> None:
        session, new = self.ctx.session, self.new_name.value.strip()
        if event.target.value == CREATE:
            done = self.ctx.attempt(event, "create", lambda: session.create_primitive(new))
        else:
            old = self.selected()
            if old is None:
                self.ctx.tell(event, "Nothing to rename", "Create a primitive first.")
                return
            done = self.ctx.attempt(event, "rename", lambda: session.rename_primitive(old, new))
        if done:
            self.select(new)
            self.new_name.value = ""

    def _ask_delete(self, event) -> None:
        name = self.selected()
        if name is None:
            self.ctx.tell(event, "Nothing to delete", "There is no primitive.")
            return
        n = len(self.ctx.session.demos.get(name, []))
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
            self.ctx.attempt(event, "delete", lambda: self.ctx.session.delete_primitive(name))

    # ------------------------------------------------------------------ the loop

    def sync(self) -> str | None:
        """Show the session's primitives, apply a pending selection, show its colour; a
        confirmation to delete another primitive is withdrawn. Returns the selection."""
        self.dirty = False
        session = self.ctx.session
        with self._lock:
            select, self._select = self._select, None
        names = session.names()
        options = tuple(names) or (NO_PRIMITIVE,)
        if tuple(self.dropdown.options) != options:
            self.dropdown.options = options
        if select is not None and select in names:
            self.dropdown.value = select
        name = self.selected()
        if name != self._synced and self._pending_delete is not None:
            self._pending_delete = None
            self.confirm.visible = self.confirm_text.visible = False
        if name is not None and name in names:
            self.color.value = session.color(name)
        self._synced = name
        return name
