"""Via-points in 3D: for each via-point of the primitive shown (Teach's, or the one Infer
recognises), a handle to drag it (a translation gizmo), a ball as large as its precision (one
standard deviation) and a label with its number and phase.

Dragging a handle moves the via-point in the view state (``on_moved``, from viser's thread: one
mutation, :meth:`app.core.view_state.View.change_via_point`); the tubes follow at the next
frames. The ball and the label are the handle's children, so they move with it in the browser
while it is dragged. A handle is put where its via-point is only while nobody drags it: a move
refused (a point 10 m away) puts it back once the drag ends.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence

import numpy as np
import viser

from app.core.via_state import StudioViaPoint

HANDLE_SCALE = 0.07  # metres: the length of a handle's arrows
MIN_BALL_M = 0.004  # a ball stays visible for the tightest precision
BALL_OPACITY = 0.55


def via_label(number: int, point: StudioViaPoint) -> str:
    """A via-point's label in 3D and in the list: ``via 1 · 50 %``."""
    return f"via {number} · {point.phase * 100:.0f} %"


class _Handle:
    """The nodes of one via-point."""

    def __init__(self, server: viser.ViserServer, point: StudioViaPoint, on_moved):
        root = f"/via_points/{point.id}"
        self.id = point.id
        self.dragging = False
        self.placed = np.asarray(point.position, dtype=float)  # where the handle was put
        self.scale, self.color, self.text = max(point.std, MIN_BALL_M), None, "via"
        self.gizmo = server.scene.add_transform_controls(
            root, scale=HANDLE_SCALE, line_width=2.5, disable_rotations=True, depth_test=False,
            position=self.placed,
        )  # fmt: skip
        self.ball = server.scene.add_icosphere(
            f"{root}/ball", radius=1.0, scale=max(point.std, MIN_BALL_M), opacity=BALL_OPACITY,
            cast_shadow=False, receive_shadow=False,
        )  # fmt: skip
        self.label = server.scene.add_label(f"{root}/label", text="via", anchor="bottom-left",
                                            position=(0.0, 0.0, 0.02))  # fmt: skip

        @self.gizmo.on_update
        def _(event) -> None:
            phase = getattr(event, "phase", "update")
            self.dragging = phase != "end"
            if not self.dragging:
                self.placed = np.full(3, np.nan)  # put where the via-point is, at the next draw
            on_moved(self.id, np.asarray(self.gizmo.position, dtype=float))

    def remove(self) -> None:
        for node in (self.label, self.ball, self.gizmo):
            node.remove()


class ViaPointLayer:
    """The handles of the via-points shown (see the module docstring); drawn on the loop."""

    def __init__(
        self, server: viser.ViserServer, on_moved: Callable[[int, np.ndarray], None]
    ) -> None:
        self.server = server
        self.on_moved = on_moved
        self.handles: dict[int, _Handle] = {}
        self.shown: tuple[StudioViaPoint, ...] = ()  # what the handles show
        self._lock = threading.Lock()  # the handles' dict: drawn on the loop, read by tests

    def _moved(self, id: int, position: np.ndarray) -> None:
        try:
            self.on_moved(id, position)
        except ValueError:
            pass  # refused (removed meanwhile, or absurdly far): the handle goes back

    def draw(self, points: Sequence[StudioViaPoint], color: tuple[int, int, int]) -> None:
        """Show a handle per via-point of ``points`` (numbered in their order), in ``color``."""
        points = tuple(points)
        with self._lock:
            for id in [i for i in self.handles if i not in {p.id for p in points}]:
                self.handles.pop(id).remove()
            for number, point in enumerate(points, start=1):
                handle = self.handles.get(point.id)
                if handle is None:
                    handle = self.handles[point.id] = _Handle(self.server, point, self._moved)
                position = np.asarray(point.position, dtype=float)
                if not handle.dragging and not np.array_equal(position, handle.placed):
                    handle.gizmo.position = position
                    handle.placed = position
                scale, text = max(point.std, MIN_BALL_M), via_label(number, point)
                if handle.scale != scale:
                    handle.ball.scale = handle.scale = scale
                if handle.color != tuple(color):
                    handle.ball.color = handle.color = tuple(color)
                if handle.text != text:
                    handle.label.text = handle.text = text
            self.shown = points
