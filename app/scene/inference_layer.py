"""The Infer tab's objects in 3D: the observed hand path, the posterior tube of the recognised
primitive (the region where 90 % of the movements that began like the observed one are, at
each moment: :mod:`app.live.regions`), the predicted path to its end point, the point the
prediction starts from, and the true remainder of a test demonstration; the same, labelled,
for every other position in space of the layout (:mod:`app.scene.position_nodes`).

:meth:`InferenceLayer.draw` shapes them from an inference (:class:`app.live.inference.InferResult`);
whether they are shown is the scene's decision (:func:`app.scene.look.look`). The tube's mesh
has a fixed topology, so a new inference only replaces its vertices; it is drawn as the view's
tube style says (:func:`app.scene.tubes.tube_look`: a band, its outline, or nothing), as an
outline when wider than its position's workspace (:mod:`app.scene.tube_scale`).

"This result is drawn" is said in one place, :attr:`InferenceLayer.drawn`: a
:class:`DrawnInference` replaced only once the tube, its outline, the paths and the points of a
result have all been written (a reader that sees a result there sees its geometry in the nodes,
never the previous one's).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import viser

from app.core.view_state import REGION_90
from app.live.inference import PATH_POINTS, TUBE_POINTS, InferResult
from app.scene import tubes
from app.scene.position_nodes import PositionNodes, shape_tube
from app.scene.tube_scale import TubeWidth, drawn_look, position_widths
from robots.icub.layout import HAND, hand_dims

POSTERIOR_OPACITY = 0.45
OBSERVED_COLOR = (25, 25, 25)
TRUTH_COLOR = (70, 70, 70)
DEFAULT_COLOR = (120, 120, 120)


def darker(color, factor: float = 0.6) -> tuple[int, int, int]:
    return tuple(int(round(c * factor)) for c in color)  # type: ignore[return-value]


@dataclass(frozen=True, eq=False)
class DrawnInference:
    """What the Infer layer's nodes show: ``result`` (None: nothing) in ``color`` and tube
    ``style``; ``shaped``: the nodes it gave a shape to (the others keep an older shape and
    stay hidden); ``widths``: each position's tube width (those too wide are outlines)."""

    result: InferResult | None
    color: tuple[int, int, int]
    style: str
    shaped: frozenset[int] = frozenset()
    widths: tuple[TubeWidth, ...] = ()

    def shows(self, result: InferResult | None, color, style: str) -> bool:
        """Whether this is what drawing ``result`` in ``color`` and ``style`` would give."""
        return result is self.result and tuple(color) == self.color and style == self.style


class InferenceLayer:
    """The Infer tab's scene nodes (see the module docstring)."""

    def __init__(self, server: viser.ViserServer):
        scene = server.scene
        line = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]])
        straight = np.linspace([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], TUBE_POINTS)
        vertices = tubes.tube_vertices(straight, np.broadcast_to(1e-4 * np.eye(3),
                                                                  (TUBE_POINTS, 3, 3)), 1.0)
        self.tube = scene.add_mesh_simple(
            "/infer/posterior",
            vertices=vertices,
            faces=tubes.tube_faces(TUBE_POINTS),
            color=DEFAULT_COLOR,
            opacity=POSTERIOR_OPACITY,
            flat_shading=False,
            side=tubes.TUBE_SIDE,
            visible=False,
        )
        self.outline = scene.add_line_segments(
            "/infer/posterior_outline", points=tubes.outline_segments(vertices),
            colors=DEFAULT_COLOR, thickness=1.5, thickness_units="screen", visible=False,
        )  # fmt: skip
        self.future = scene.add_spline_catmull_rom(
            "/infer/future", points=line, thickness=5.0, thickness_units="screen",
            color=DEFAULT_COLOR, visible=False,
        )  # fmt: skip
        self.observed_line = scene.add_spline_catmull_rom(
            "/infer/observed", points=line, thickness=4.0, thickness_units="screen",
            color=OBSERVED_COLOR, visible=False,
        )  # fmt: skip
        self.truth_line = scene.add_spline_catmull_rom(
            "/infer/truth", points=line, thickness=2.0, thickness_units="screen",
            color=TRUTH_COLOR, visible=False,
        )  # fmt: skip
        self.end_point = scene.add_icosphere(
            "/infer/end", radius=0.02, color=DEFAULT_COLOR, visible=False
        )
        self.now_point = scene.add_icosphere(
            "/infer/now", radius=0.012, color=(250, 250, 250), visible=False
        )
        self.hand_label = scene.add_label("/infer/hand_label", text=HAND.name, visible=False)
        self.hand_nodes = (
            self.tube, self.outline, self.future, self.observed_line, self.truth_line,
            self.end_point, self.now_point, self.hand_label,
        )  # fmt: skip
        self.server = server
        self.others: dict[str, PositionNodes] = {}  # every other position, by modality
        self.drawn = DrawnInference(None, DEFAULT_COLOR, REGION_90)

    @property
    def nodes(self) -> tuple:
        """Every node of the layer: the hand's, then the other positions'."""
        return self.hand_nodes + tuple(n for o in self.others.values() for n in o.nodes)

    @property
    def path_nodes(self) -> tuple:
        """The nodes that draw paths and points (observed, predicted, true, the end), not
        regions or labels: what *Frame paths* frames."""
        hand = (self.future, self.observed_line, self.truth_line, self.end_point, self.now_point)
        return hand + tuple(n for o in self.others.values() for n in o.paths)

    @property
    def has_shape(self) -> bool:
        """True when the result drawn last had something to show in 3D."""
        return bool(self.drawn.shaped)

    def draw(
        self, result: InferResult | None, color: tuple[int, int, int], style: str = REGION_90
    ) -> None:
        """Shape the nodes from ``result`` (drawn in ``color``, its primitive's; the tube in
        tube ``style``); none without a result or a hand modality. :attr:`drawn` says so once
        every node is written."""
        color = tuple(int(c) for c in color)
        shaped, widths = self._shape(result, color, style)
        self.drawn = DrawnInference(result, color, style, frozenset(shaped), widths)

    def _shape(
        self, result: InferResult | None, color: tuple[int, int, int], style: str
    ) -> tuple[set, tuple[TubeWidth, ...]]:
        """Write the nodes ``result`` shapes; their ids, and the tubes' widths."""
        layout = result.model.layout if result is not None else None
        hand = hand_dims(layout) if layout is not None else None
        if result is None or hand is None or result.future is None:
            return set(), ()
        look = tubes.tube_look(style)
        views = {view.modality: view for view in result.positions}
        widths = position_widths(result.model, result.positions, look.probability)
        labelled = len(views) > 1  # two positions or more: say which is which
        drawn = self._shape_hand(result, views[HAND.name], color,
                                 drawn_look(look, widths[HAND.name]), labelled)  # fmt: skip
        for name, view in views.items():
            if name != HAND.name:
                if name not in self.others:
                    self.others[name] = PositionNodes(self.server, name, POSTERIOR_OPACITY)
                drawn |= self.others[name].shape(view, color, drawn_look(look, widths[name]),
                                                 labelled)  # fmt: skip
        return drawn, tuple(widths.values())

    def _shape_hand(self, result: InferResult, view, color, look, labelled: bool) -> set:
        future = result.future.hand
        drawn = {id(n) for n in (self.future, self.end_point, self.now_point)}
        drawn |= shape_tube(self.tube, self.outline, view.region, color, look)
        self.future.points = future.astype(np.float32)
        self.future.color = darker(color)
        self.end_point.position = future[-1]
        self.end_point.color = color
        self.now_point.position = future[0]
        if labelled:
            observed = view.observed is not None
            self.hand_label.text = f"{HAND.name}: {'observed, ' if observed else ''}predicted"
            self.hand_label.position = future[-1] + np.array([0.0, 0.0, 0.04])
            drawn.add(id(self.hand_label))
        for node, points in ((self.observed_line, view.observed), (self.truth_line, view.truth)):
            if points is not None and points.shape[0] >= 2:
                resampled = tubes.resample(points, min(points.shape[0], PATH_POINTS))
                node.points = resampled.astype(np.float32)
                drawn.add(id(node))
        return drawn

    def show(self, visible: bool) -> None:
        """Show the nodes the latest result shaped (``visible``), or none."""
        shaped = self.drawn.shaped
        for node in self.nodes:
            wanted = visible and id(node) in shaped
            if node.visible != wanted:
                node.visible = wanted
