"""What the 3D view draws, once per frame: the partner (:mod:`app.scene.partner`), the
workspace's demonstrations and priors (:mod:`app.scene.workspace_layer`), the Infer tab's
inference (:mod:`app.scene.inference_layer`) and Teach's start pose
(:mod:`app.scene.start_marker`).

:class:`SceneView` owns every node of these and is the one place that decides what is shown:
:meth:`SceneView.draw` takes the frame (the snapshot of the state) and what the panels asked
for (:class:`app.scene.look.Shown`), redraws what changed since the frame it drew last (the
inputs are immutable: compared by identity) and applies the look of the panel in use
(:func:`look`, pure; the panels and options are named in :mod:`app.scene.look`) once. Panels
never touch the nodes; the Infer panel alone hands its result to the Infer layer
(:meth:`app.scene.inference_layer.InferenceLayer.draw`, which says what it draws), which the
look then shows or hides. Everything runs on the studio's loop thread except
:meth:`SceneView.use_panel`, which only records. The robot (:mod:`app.scene.robot`) is drawn
unless the workspace's hand stays in its own frame (:attr:`app.io.hand_frame.HandFrame.own`);
the simulated scene around it (table, object, bins, the partner's head) as the view says
(:func:`app.core.view_state.scene_shown`: by default only for data recorded in it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import viser

from app.core.snapshot import Snapshot
from app.core.via_state import of_primitive
from app.core.view_state import scene_shown
from app.scene.inference_layer import DEFAULT_COLOR, InferenceLayer
from app.scene.look import INFER, PANELS, PRIOR_MODES, SHOWN, TEACH, InferenceShown, Shown
from app.scene.partner import PartnerView
from app.scene.robot import RobotView
from app.scene.start_marker import StartMarker
from app.scene.via_layer import ViaPointLayer
from app.scene.workspace_layer import NO_COLOR, WorkspaceLayer
from robots.icub.layout import HEAD

NOTHING_INFERRED = InferenceShown(None, DEFAULT_COLOR, False, SHOWN)


@dataclass(frozen=True)
class Look:
    """What is drawn.

    Attributes
    ----------
    demos : bool
        The demonstration lines (each still hidden when the user hid it).
    priors : {"shown", "faded", "hidden"}
        The prior tubes: at their own opacity, dimmed, or not drawn.
    inference : bool
        The Infer layer: observation, posterior tube, predicted path and end point.
    start : bool
        The ghost of the selected primitive's start pose (Teach).
    """

    demos: bool
    priors: str
    inference: bool
    start: bool = False


WORKSPACE_LOOK = Look(demos=True, priors=SHOWN, inference=False)
TEACH_LOOK = Look(demos=True, priors=SHOWN, inference=False, start=True)


def look(panel: str, inference_shown: bool, priors: str = SHOWN) -> Look:
    """What the scene draws while ``panel`` is in use.

    Parameters
    ----------
    panel : {"teach", "infer", "data"}
    inference_shown : bool
        The Infer panel has an inference to show in 3D (a result, "Show in 3D" on, a hand
        modality).
    priors : {"shown", "faded", "hidden"}
        The Infer panel's "Session priors" option.

    Raises
    ------
    ValueError
        An unknown panel or priors option.
    """
    if panel not in PANELS:
        raise ValueError(f"unknown panel {panel!r}; expected one of {', '.join(PANELS)}")
    if priors not in PRIOR_MODES:
        raise ValueError(f"unknown priors option {priors!r}; expected {', '.join(PRIOR_MODES)}")
    if panel == TEACH:
        return TEACH_LOOK
    if panel != INFER or not inference_shown:
        return WORKSPACE_LOOK
    return Look(demos=priors == SHOWN, priors=priors, inference=True)


class SceneView:
    """The studio's 3D objects and their look (see the module docstring)."""

    def __init__(
        self,
        server: viser.ViserServer,
        robot: RobotView | None = None,
        on_via_moved: Callable[[int, np.ndarray], object] | None = None,
    ):
        """``on_via_moved(id, position)``: a via-point's handle was dragged (viser's thread)."""
        self.robot = robot  # shown or hidden with the workspace's frame
        self.partner = PartnerView(server)
        self.workspace = WorkspaceLayer(server)
        self.inference = InferenceLayer(server)
        self.start = StartMarker(server)
        self.vias = ViaPointLayer(server, on_via_moved or (lambda _id, _position: None))
        self._vias_from: tuple = ((), NO_COLOR)  # the via-points and the colour drawn
        self.panel = TEACH  # the panel in use: the first tab until another is shown or used
        self.look = look(TEACH, False)
        self._hidden: frozenset = frozenset()
        self.drawn_from: tuple = ()  # what the demonstration lines were drawn from
        self._tubes_from: tuple = (None,) * 4  # model, primitives, via-points, tube style shown
        self.snapshot: Snapshot | None = None  # the latest drawn (the camera buttons read it)

    def use_panel(self, panel: str) -> None:
        """``panel`` is shown or used in a browser: its look is drawn (from any thread)."""
        if panel not in PANELS:
            raise ValueError(f"unknown panel {panel!r}; expected one of {', '.join(PANELS)}")
        self.panel = panel

    def draw(self, snapshot: Snapshot, head: np.ndarray | None, shown: Shown) -> Look:
        """Draw one frame: ``snapshot``'s workspace, the partner's ``head`` angles and what
        the panels asked for; returns the look applied. The Infer layer's shape is the Infer
        panel's to give (it draws its result there, :meth:`InferenceLayer.draw`): here it is
        only shown or hidden."""
        self.snapshot = snapshot
        lines, tubes = self._draw_workspace(snapshot)
        scene = scene_shown(snapshot.view, snapshot.store)
        if self.robot is not None:
            self.robot.show(snapshot.store.frame.robot_shown, scene)
        self.partner.show(scene and HEAD.name in snapshot.store.layout.names)
        self.partner.orient(head)
        inference, style = shown.inference or NOTHING_INFERRED, snapshot.view.tube_style
        start = shown.start
        self.start.place(None if start is None else start.position,
                         NO_COLOR if start is None else start.color)  # fmt: skip
        self.look = look(self.panel, inference.in_3d and self.inference.has_shape,
                         inference.priors)  # fmt: skip
        self.workspace.apply(self.look.demos, self.look.priors, self._hidden, style)
        self._draw_vias(snapshot, shown)
        self.inference.show(self.look.inference)
        self.start.show(self.look.start)
        # said once drawn and shown (tests wait on them): what apply() shows was drawn hidden,
        # and a busy machine's test polled between the two
        if lines is not None:
            self.drawn_from = lines
        if tubes is not None:
            self._tubes_from = tubes
        return self.look

    def _draw_vias(self, snapshot: Snapshot, shown: Shown) -> None:
        """The handles of the via-points the panel in use shows (none elsewhere, nor while the
        Infer panel's inference is not drawn)."""
        vias = shown.vias_of(self.panel)
        if vias is None or (self.panel == INFER and not self.look.inference):
            points, color = (), NO_COLOR
        else:
            points, color = of_primitive(snapshot.view.via_points, vias.primitive), vias.color
        if (points, tuple(color)) != self._vias_from:
            self.vias.draw(points, color)
            self._vias_from = (points, tuple(color))  # said once drawn (tests wait on it)

    def _draw_workspace(self, snapshot: Snapshot) -> tuple[tuple | None, tuple | None]:
        """The demonstration lines and the prior tubes, each when what it shows changed (the
        hidden set compared by value, the immutable rest by identity); what each was drawn
        from (None: not drawn again), for :meth:`draw` to say once they are shown."""
        store, model, hidden = snapshot.store, snapshot.model, snapshot.hidden
        lines = (hidden, store.demos, store.primitives, store.findings, store.checks)
        drawn = self.drawn_from
        colors = {p.name: p.color for p in store.primitives}
        if not drawn or hidden != drawn[0] or any(
            a is not b for a, b in zip(lines[1:], drawn[1:], strict=True)
        ):
            self._hidden = hidden
            self.workspace.draw_lines(store.demos, colors, store.layout, set(store.left_out))
        else:
            lines = None
        tubes = (model, store.primitives, snapshot.view.via_points, snapshot.view.tube_style)
        if any(a is not b for a, b in zip(tubes[:3], self._tubes_from[:3], strict=True)) or (
            tubes[3] != self._tubes_from[3]
        ):
            self.workspace.draw_tubes(model, colors, self.look.priors, tubes[3], tubes[2])
        else:
            tubes = None
        return lines, tubes

    # ------------------------------------------------------------------ what the camera frames

    def paths(self, inference: bool | None = None) -> np.ndarray:
        """The paths drawn, points (n, 3): the demonstration lines (but those the user hid,
        whether the look shows them now or not), and with them the Infer layer's paths and
        points (observation, prediction, truth and end, of every position) when ``inference``
        (default: when the current look shows it). Empty (0, 3) without any.

        The demonstrations are always among them: a single inference (a few centimetres of one
        movement, beside the dragged hand's gizmo) framed alone filled the picture with the
        gizmo, not with the paths. The tubes are not: a region a metre wide framed with them
        left the data a speck among the scene's clutter."""
        if inference is None:
            inference = self.look.inference
        nodes = [line for key, line in self.workspace.lines.items() if key not in self._hidden]
        if inference:
            shaped = self.inference.drawn.shaped
            nodes += [n for n in self.inference.path_nodes if n.visible and id(n) in shaped]
        arrays = []
        for node in nodes:
            points = getattr(node, "points", None)
            if points is None:
                points = getattr(node, "vertices", None)
            if points is None:
                points = np.atleast_2d(getattr(node, "position", np.zeros((0, 3))))
            arrays.append(np.asarray(points, dtype=float).reshape(-1, 3))
        return np.concatenate(arrays) if arrays else np.zeros((0, 3))
