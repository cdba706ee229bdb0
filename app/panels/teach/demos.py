"""The Teach tab's Demonstrations folder: the selected primitive's demonstrations, newest first.

Each row shows a demonstration's typicality (how it compares with the primitive's others,
scored by the learner: a take when recorded, an import's demonstrations once imported, "scoring"
until then; :mod:`app.io.demo_scores`) and offers Hide/Show
(:meth:`app.core.view_state.View.set_hidden`: its line in the 3D view) and Delete, after a
confirmation (:meth:`app.core.store.Store.delete_demo`: to the workspace's trash). *Undo delete*
brings back the latest deletion (:meth:`app.core.store.Store.undo_delete`). The list is drawn
from the frame's snapshot, again only when what it shows changed.

A demonstration the checks flag (:mod:`promp.quality`: a gap, a jump, one that does not move, a
rate or a duration far from the others'; :mod:`promp.endpoints`: a round trip, a start or an end
far from the others') is marked "left out" and listed above the rows with what was found, where
and how big (in the modality's units); its row offers *Keep* (learn from it anyway) and, once kept,
*Leave out* (:meth:`app.core.store.Store.set_kept`); one with a gap in its timestamps offers
*Repair gap* (cut at the gap, or split: new demonstrations beside it). Its file is never
touched.
"""

from __future__ import annotations

import viser

from app.core.snapshot import Snapshot
from app.ui.context import PanelContext
from app.ui.text import GREEN, ORANGE, RED, colored, escape
from promp.gaps import duration_text
from promp.typicality import Typicality

TYPICALITY_COLORS = {"typical": GREEN, "unusual": ORANGE, "outlier": RED}
NOTIFY_COLORS = {"typical": "green", "unusual": "yellow", "outlier": "red"}
DELETE, KEEP = "Delete demonstration", "Keep it"
KEEP_FLAGGED, LEAVE_OUT, REPAIR = "Keep", "Leave out", "Repair gap"
CUT, SPLIT, CANCEL = "Cut at the gap", "Split at the gap", "Cancel"


def typicality_text(typicality: Typicality | None) -> str:
    """E.g. ``typical (64th pct)``; '' without a score."""
    if typicality is None:
        return ""
    return f"{typicality.label} ({100 * typicality.percentile:.0f}th pct)"


def row_label(row) -> str:
    """A demonstration's row label (``row`` as :meth:`DemoList.show` builds it): its name,
    whether it is left out (or kept despite its findings), its typicality (or that it is being
    scored), whether it is hidden; e.g. ``record1 · ⚠ left out · ⚠ outlier (0th pct)``."""
    demo_name, _, hidden, typicality, findings, kept, pending = row
    label = demo_name
    if findings:
        label += " · ⚠ kept despite findings" if kept else " · ⚠ left out"
    if typicality is not None:
        flag = "" if typicality.label == "typical" else "⚠ "
        label += f" · {flag}{typicality_text(typicality)}"
    elif pending:
        label += " · typicality: scoring..."
    return label + (" · hidden" if hidden else "")


def findings_text(rows) -> str:
    """The flagged demonstrations of ``rows`` (as :meth:`DemoList.show` builds them) and what
    was found in each, as markdown ('' when none is flagged)."""
    flagged = [(r[0], r[4], r[5]) for r in rows if r[4]]
    if not flagged:
        return ""
    lines = []
    for demo_name, findings, kept in flagged:
        status = "kept" if kept else "left out of learning"
        messages = "; ".join(message for _, message in findings)
        lines.append(f"**{escape(demo_name)}** ({status}): " + escape(messages))
    return "  \n" + colored(
        f"⚠ {len(flagged)} flagged (Keep learns from one anyway):", ORANGE, True
    ) + "  \n" + "  \n".join(lines)


class DemoList:
    """The Demonstrations folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext):
        self.ctx = ctx
        self._pending_delete: tuple[str, str] | None = None
        self._rows: list[tuple[tuple[str, str], viser.GuiButtonGroupHandle]] = []
        self._signature: tuple | None = None
        self._store = self._scores = self._inputs = None  # what the list was last drawn from
        gui = ctx.gui
        self.folder = gui.add_folder("Demonstrations")
        with self.folder:
            self.summary = gui.add_markdown("")
            self.undo_delete = gui.add_button(
                "Undo delete",
                icon=viser.Icon.ARROW_BACK_UP,
                visible=False,
                hint="Bring back the latest deleted demonstration or primitive from the trash",
            )
            self.confirm_text = gui.add_markdown("", visible=False)
            self.confirm = gui.add_button_group("", (DELETE, KEEP), visible=False)
            self.repair_text = gui.add_markdown("", visible=False)
            self.repair = gui.add_button_group("", (CUT, SPLIT, CANCEL), visible=False)
        self._pending_repair: tuple[str, str] | None = None
        self.undo_delete.on_click(self._undo)
        self.confirm.on_click(self._confirmed)
        self.repair.on_click(self._repair_chosen)

    # ------------------------------------------------------------------ callbacks

    def _undo(self, event) -> None:
        def undo() -> None:
            entry = self.ctx.store.undo_delete()
            self.ctx.tell(event, "Restored", f"{entry.label} is back.", "green")

        self.ctx.attempt(event, "undo", undo)

    def _confirmed(self, event) -> None:
        pending, self._pending_delete = self._pending_delete, None
        self.confirm_text.visible = self.confirm.visible = False
        if pending is None or event.target.value != DELETE:
            return
        primitive, demo = pending
        if self.ctx.attempt(event, "delete", lambda: self.ctx.store.delete_demo(primitive, demo)):
            self.ctx.tell(
                event, "Deleted",
                f"{demo} moved to the workspace's trash (Undo delete brings it back).", "gray",
            )  # fmt: skip

    def _repair_chosen(self, event) -> None:
        pending, self._pending_repair = self._pending_repair, None
        self.repair_text.visible = self.repair.visible = False
        choice = event.target.value
        if pending is None or choice == CANCEL:
            return
        primitive, demo = pending
        mode = "cut" if choice == CUT else "split"

        def apply() -> None:
            made = self.ctx.store.repair_gap(primitive, demo, mode)
            self.ctx.tell(
                event, "Gap repaired",
                f"{', '.join(d.name for d in made)} made from {demo}, which stays as it was "
                "(left out; delete it if you no longer need it).", "green",
            )  # fmt: skip

        self.ctx.attempt(event, "repair", apply)

    def _row_action(self, primitive: str, demo: str):
        def action(event) -> None:
            choice = event.target.value
            if choice == "Delete":
                self._pending_delete = (primitive, demo)
                self.confirm_text.content = (
                    f"Delete **{demo}** of **{primitive}**? It moves to the workspace's trash: "
                    "*Undo delete* brings it back."
                )
                self.confirm_text.visible = self.confirm.visible = True
            elif choice == REPAIR:
                self._pending_repair = (primitive, demo)
                self.repair_text.content = (
                    f"Repair the gap of **{demo}**? *Cut* makes a new demonstration of the part "
                    "before the gap; *Split* one of every part. The original stays as it is."
                )
                self.repair_text.visible = self.repair.visible = True
            elif choice in (KEEP_FLAGGED, LEAVE_OUT):
                keep = choice == KEEP_FLAGGED

                def apply() -> None:
                    self.ctx.store.set_kept(primitive, demo, keep)
                    what = "learned from despite its findings" if keep else "left out of learning"
                    self.ctx.tell(event, "Kept" if keep else "Left out", f"{demo} is {what}.",
                                  "green" if keep else "gray")  # fmt: skip

                self.ctx.attempt(event, "keep" if keep else "leave out", apply)
            else:
                hide = choice == "Hide"
                self.ctx.view.set_hidden(primitive, demo, hide)

        return action

    # ------------------------------------------------------------------ display

    def step(self, snapshot: Snapshot) -> bool:
        """The Undo button, labelled with the latest deletion of this run, and the list of the
        primitive taught; True when the list was drawn again."""
        deleted = snapshot.store.deleted
        label = f"Undo delete ({deleted[-1].label})" if deleted else self.undo_delete.label
        if (self.undo_delete.visible, self.undo_delete.label) != (bool(deleted), label):
            self.undo_delete.visible, self.undo_delete.label = bool(deleted), label
        return self.show(snapshot, snapshot.primitive)

    def show(self, snapshot: Snapshot, name: str | None) -> bool:
        """List the demonstrations of primitive ``name`` (rebuilt only when they change); True
        when it was drawn again."""
        store, scores = snapshot.store, snapshot.learner.scores
        inputs = (name, snapshot.hidden)
        if store is self._store and scores is self._scores and inputs == self._inputs:
            return False
        self._store, self._scores, self._inputs = store, scores, inputs
        demos = list(store.demos.get(name, ())) if name is not None else []
        rows = tuple(
            (
                d.name,
                duration_text(d.times),
                (name, d.name) in snapshot.hidden,
                snapshot.typicality.get((name, d.name)),
                tuple((f.kind, f.message) for f in store.findings_of(name, d.name)),
                (name, d.name) in store.checks.kept,
                (name, d.name) in store.checks.scores.pending,
            )
            for d in reversed(demos)  # newest first
        )
        signature = (name, rows)
        if signature == self._signature:
            return False
        self._signature = signature
        flagged = [r[0] for r in rows if r[3] is not None and r[3].label != "typical"]
        if name is None:
            summary = "No primitive."
        elif not rows:
            summary = f"No demonstration of **{name}** yet: press Record."
        else:
            summary = f"{len(rows)} demonstration(s) of **{name}**, newest first."
            if flagged:
                summary += "  \n" + colored("⚠ To check: " + ", ".join(flagged), ORANGE, True)
            summary += findings_text(rows)
        self.summary.content = summary
        # A row per demonstration, kept while its demonstration is there (a click on a row
        # being rebuilt would be lost): a take adds one row, a deletion removes one; their
        # order (newest first) is viser's ``order``, after the folder's other controls.
        keys = [(name, r[0]) for r in rows]
        current = dict(self._rows)
        for key in [k for k in current if k not in keys]:
            current.pop(key).remove()
        with self.folder:
            for key, (demo_name, duration, *_) in zip(keys, rows, strict=True):
                if key not in current:
                    current[key] = handle = self.ctx.gui.add_button_group(
                        demo_name,
                        ("Hide", "Delete"),
                        hint=f"{demo_name}: {duration}. Show or hide its line in the 3D "
                        "view, or delete it from the workspace. A flagged demonstration (left "
                        "out of learning) can be kept.",
                    )
                    handle.on_click(self._row_action(name, demo_name))
        self._rows = [(key, current[key]) for key in keys]
        for i, (_, handle) in enumerate(self._rows):
            if handle.order != self.repair.order + 1 + i:
                handle.order = self.repair.order + 1 + i
        for row, (_, handle) in zip(rows, self._rows, strict=True):
            hidden, findings, kept = row[2], row[4], row[5]
            handle.label = row_label(row)
            options = ("Show" if hidden else "Hide", "Delete")
            if any(kind == "gap" for kind, _ in findings):
                options = (REPAIR, *options)
            if findings:
                options = (LEAVE_OUT if kept else KEEP_FLAGGED, *options)
            handle.options = options
        return True
