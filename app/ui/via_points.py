"""The "Via-points" folder Teach and Infer share: make a primitive's hand pass through points.

A via-point is added at a phase (% of the movement), a position (cm, in the iCub's frame; filled
in with the primitive's mean hand at that phase, to be changed by typing or by dragging the
point's handle in 3D) and a precision (± cm, one standard deviation). The list names each one;
one chosen in the "Via-point" dropdown shows its values, to retype (Update), or is removed;
"Remove all" gives the primitive its prior back. Teach shapes the primitive it shows, Infer
the one it recognises (:mod:`app.core.via_state`: one set, in the view state, that both tabs
show). Every change is one
mutation of the view state, refused with a notification when a value is out of bounds
(:func:`app.core.via_state.checked`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import viser

from app.core.snapshot import Snapshot
from app.core.via_state import StudioViaPoint, of_primitive
from app.scene.look import ViaShown
from app.scene.via_layer import via_label
from app.ui.chart_marks import PointMark
from app.ui.charts import N_SIGMA
from app.ui.context import PanelContext
from app.ui.display import Quantity
from app.ui.text import escape_html
from promp.data import Layout
from robots.icub.layout import HAND

NEW = "(a new point)"
UPDATE, REMOVE, REMOVE_ALL = "Update", "Remove", "Remove all"
HINT = (
    "Make the primitive's hand pass through a point at a phase of the movement: the prior (in "
    "Teach) or the prediction (in Infer) is conditioned on it (Eq. 8 of the paper). Drag a "
    "point's handle in 3D to move it."
)


def via_marks(
    points: Sequence[StudioViaPoint],
    quantity: Quantity,
    layout: Layout,
    duration: float,
    color: tuple[int, int, int],
) -> tuple[PointMark, ...]:
    """The via-points ``points`` (one primitive's, numbered in their order as the list names
    them) on the chart of ``quantity``: each at the time of its phase in a movement of
    ``duration`` seconds, at its position's coordinate in the quantity's display unit, its bar
    ± :data:`~app.ui.charts.N_SIGMA` of its precision (the bands' width). None on a chart of
    another modality than the hand."""
    if quantity.modality != HAND.name:
        return ()
    axis = layout.modality(HAND.name).columns.index(quantity.name)
    return tuple(
        PointMark(via_label(i, p), p.phase * duration, quantity.scale * p.position[axis],
                  quantity.scale * N_SIGMA * p.std, color)
        for i, p in enumerate(points, start=1)
    )  # fmt: skip


@dataclass(frozen=True, eq=False)
class ViaPointControls:
    """The folder's controls."""

    note: viser.GuiMarkdownHandle
    phase: viser.GuiSliderHandle
    position: viser.GuiVector3Handle
    precision: viser.GuiNumberHandle
    add: viser.GuiButtonHandle
    choice: viser.GuiDropdownHandle
    actions: viser.GuiButtonGroupHandle
    list: viser.GuiMarkdownHandle


class ViaPointSection:
    """The folder (built in the current container; see the module docstring)."""

    def __init__(self, ctx: PanelContext, panel: str, expand: bool = False):
        self.ctx, self.panel = ctx, panel
        gui = ctx.gui
        self.primitive: str | None = None  # the primitive shaped (the loop sets it)
        self.mean_at: Callable[[float], np.ndarray | None] = lambda _phase: None
        self._listed: tuple | None = None  # the via-points the list shows
        self._listed_for: str | None = None  # and their primitive
        self._filled = None  # the via-point whose values the fields show
        with gui.add_folder("Via-points", expand_by_default=expand):
            self.controls = ViaPointControls(
                note=gui.add_markdown(""),
                phase=gui.add_slider(
                    "Phase %", min=0, max=100, step=1, initial_value=50,
                    hint="Where in the movement: 0 % its start, 100 % its end",
                ),
                position=gui.add_vector3(
                    "Position (cm)", (0.0, 0.0, 0.0), step=0.1,
                    hint="x, y, z of the hand in the iCub's frame, centimetres",
                ),
                precision=gui.add_number(
                    "± cm", 1.0, min=0.1, max=100.0, step=0.1,
                    hint="How closely the hand must pass: one standard deviation, centimetres",
                ),
                add=gui.add_button("Add via-point", hint=HINT),
                choice=gui.add_dropdown(
                    "Via-point", (NEW,),
                    hint="A via-point to retype (Update) or remove; a new point to add one",
                ),
                actions=gui.add_button_group("", (UPDATE, REMOVE, REMOVE_ALL)),
                list=gui.add_markdown(""),
            )  # fmt: skip
        c = self.controls
        c.add.on_click(self._add)
        c.actions.on_click(self._act)
        c.choice.on_update(self._chosen)
        c.phase.on_update(self._phase_moved)

    # ------------------------------------------------------------------ callbacks (viser's threads)

    def _typed(self) -> tuple[float, tuple, float]:
        c = self.controls
        position = tuple(float(v) / 100.0 for v in c.position.value)
        return float(c.phase.value) / 100.0, position, float(c.precision.value) / 100.0

    def _add(self, event) -> None:
        primitive = self.primitive
        if primitive is None:
            self.ctx.tell(event, "Cannot add a via-point", "There is no primitive to shape yet.")
            return
        phase, position, std = self._typed()
        self.ctx.attempt(event, "add the via-point",
                         lambda: self.ctx.view.add_via_point(primitive, phase, position, std))

    def _chosen_id(self) -> int | None:
        listed = self._listed or ()
        labels = [label for label, _ in listed]
        if self.controls.choice.value not in labels:
            return None
        return listed[labels.index(self.controls.choice.value)][1].id

    def _act(self, event) -> None:
        view, action = self.ctx.view, str(event.target.value)
        if action == REMOVE_ALL:
            view.remove_via_points([v.id for v in of_primitive(view.state.via_points,
                                                                 self.primitive)])  # fmt: skip
            return
        id = self._chosen_id()
        if id is None:
            self.ctx.tell(event, f"Cannot {action.lower()}", "Choose a via-point in the list.")
        elif action == REMOVE:
            view.remove_via_points([id])
        else:
            phase, position, std = self._typed()
            self.ctx.attempt(event, "change the via-point", lambda: view.change_via_point(
                id, phase=phase, position=position, std=std))  # fmt: skip

    def _chosen(self, _event) -> None:
        """A via-point chosen in the list (or dragged since): the fields show its values, to
        retype."""
        id = self._chosen_id()
        point = next((v for v in self.ctx.view.state.via_points if v.id == id), None)
        if point is None:
            self._filled = None
        elif point != self._filled:
            self._filled = point
            self.controls.phase.value = round(point.phase * 100.0)
            self.controls.position.value = tuple(round(v * 100.0, 1) for v in point.position)
            self.controls.precision.value = round(point.std * 100.0, 1)

    def _phase_moved(self, event) -> None:
        """A phase chosen in a browser for a new point: the position follows the mean there."""
        if event.client is not None and self._chosen_id() is None:
            self.fill_position()

    def fill_position(self) -> None:
        """The position fields at the shaped primitive's mean hand at the chosen phase."""
        mean = self.mean_at(float(self.controls.phase.value) / 100.0)
        if mean is not None:
            self.controls.position.value = tuple(round(float(v) * 100.0, 1) for v in mean)

    # ------------------------------------------------------------------ the frame

    def step(
        self,
        snapshot: Snapshot,
        primitive: str | None,
        color: tuple[int, int, int],
        mean_at: Callable[[float], np.ndarray | None],
    ) -> ViaShown:
        """Shape ``primitive`` (None: nothing to shape), whose mean hand at a phase is
        ``mean_at(phase)``; list its via-points. What the 3D view shows of them."""
        self.mean_at = mean_at
        has_hand = HAND.name in snapshot.store.layout.names
        if primitive != self.primitive:
            self.primitive = primitive
            self.fill_position()
        points = of_primitive(snapshot.view.via_points, primitive) if has_hand else ()
        listed = tuple((via_label(i, p), p) for i, p in enumerate(points, start=1))
        if listed != self._listed or primitive != self._listed_for:
            self._listed, self._listed_for = listed, primitive
            self._show_list(listed, primitive, has_hand)
        return ViaShown(self.panel, primitive if has_hand else None, color)

    def _show_list(self, listed: tuple, primitive: str | None, has_hand: bool) -> None:
        labels = (NEW, *(label for label, _ in listed))
        if tuple(self.controls.choice.options) != labels:
            keep = self.controls.choice.value if self.controls.choice.value in labels else NEW
            self.controls.choice.options = labels
            self.controls.choice.value = keep
        enabled = has_hand and primitive is not None
        # (viser's button groups cannot be disabled)
        for handle in (self.controls.add, self.controls.choice):
            if handle.disabled == enabled:
                handle.disabled = not enabled
        if not has_hand:
            self.controls.note.content = (
                "Via-points shape the hand: this workspace has no hand modality."
            )
        elif primitive is None:
            self.controls.note.content = "No primitive to shape yet."
        else:
            self.controls.note.content = (f"Shaping **{escape_html(primitive)}**: "
                                 + ("its prior." if not listed else
                                    f"through {len(listed)} point(s), drag a handle in 3D to "
                                    "move one."))  # fmt: skip
        self._chosen(None)  # the chosen one's values, when it moved
        rows = [f"{label}: ({', '.join(f'{v * 100:.1f}' for v in p.position)}) cm "
                f"± {p.std * 100:.1f} cm" for label, p in listed]  # fmt: skip
        self.controls.list.content = "  \n".join(rows)
