"""The Infer layer's nodes of one position in space other than the robot's hand (a partner's
hand, a marker): its region as a tube, its predicted path and end, what was observed of it, the
rest of the test demonstration, and labels that name it (:mod:`app.scene.inference_layer` draws
the hand with its own nodes, and these for every other position).

Its tube is drawn in a lighter tone of the recognised primitive's colour than the hand's, so
that two tubes of one primitive read as two things; the labels say which is which.
"""

from __future__ import annotations

import numpy as np
import viser

from app.live.regions import TUBE_POINTS, PositionView
from app.scene import tubes

LIGHTER = 0.45  # the tube's colour: the primitive's, this much towards white
OBSERVED_COLOR = (25, 25, 25)
TRUTH_COLOR = (70, 70, 70)
PATH_POINTS_DRAWN = 60


def lighter(color, share: float = LIGHTER) -> tuple[int, int, int]:
    return tuple(int(round(c + share * (255 - c))) for c in color)  # type: ignore[return-value]


def shape_tube(tube, outline, region, color, look: tubes.TubeLook) -> set[int]:
    """Write ``region``'s tube at ``look``'s probability into the ``tube`` mesh (a band) or its
    ``outline``, in ``color``, as ``look`` draws it; the ids of the nodes given a shape."""
    vertices = tubes.region_vertices(region, look.probability)
    drawn = set()
    if look.surface:
        tube.vertices = vertices
        tube.color = color
        drawn.add(id(tube))
    if look.outline:
        segments = tubes.outline_segments(vertices)
        outline.points = segments
        outline.colors = np.broadcast_to(np.array(color, dtype=np.uint8), segments.shape).copy()
        drawn.add(id(outline))
    return drawn


class PositionNodes:
    """The nodes of position modality ``name`` (created hidden, shaped by :meth:`shape`)."""

    def __init__(self, server: viser.ViserServer, name: str, opacity: float):
        scene, root = server.scene, f"/infer/positions/{name}"
        self.name = name
        straight = np.linspace([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], TUBE_POINTS)
        cov = np.broadcast_to(1e-4 * np.eye(3), (TUBE_POINTS, 3, 3))
        vertices = tubes.tube_vertices(straight, cov, 1.0)
        line = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]])
        self.tube = scene.add_mesh_simple(
            f"{root}/tube", vertices=vertices, faces=tubes.tube_faces(TUBE_POINTS),
            opacity=opacity, flat_shading=False, side=tubes.TUBE_SIDE, visible=False,
        )  # fmt: skip
        self.outline = scene.add_line_segments(
            f"{root}/outline", points=tubes.outline_segments(vertices), colors=(0, 0, 0),
            thickness=1.5, thickness_units="screen", visible=False,
        )  # fmt: skip
        self.future = scene.add_spline_catmull_rom(
            f"{root}/future", points=line, thickness=4.0, thickness_units="screen", visible=False
        )
        self.observed = scene.add_spline_catmull_rom(
            f"{root}/observed", points=line, thickness=4.0, thickness_units="screen",
            color=OBSERVED_COLOR, visible=False,
        )  # fmt: skip
        self.truth = scene.add_spline_catmull_rom(
            f"{root}/truth", points=line, thickness=2.0, thickness_units="screen",
            color=TRUTH_COLOR, visible=False,
        )  # fmt: skip
        self.end = scene.add_icosphere(f"{root}/end", radius=0.012, visible=False)
        self.label = scene.add_label(f"{root}/label", text=name, visible=False)
        self.nodes = (self.tube, self.outline, self.future, self.observed, self.truth, self.end,
                      self.label)  # fmt: skip
        self.paths = (self.future, self.observed, self.truth, self.end)  # not regions, labels

    def shape(self, view: PositionView, color, look: tubes.TubeLook, labelled: bool) -> set[int]:
        """Write ``view`` into the nodes (the tube in ``look``, in a lighter tone of
        ``color``; the label when ``labelled``); the ids of the nodes given a shape."""
        tone = lighter(color)
        drawn = {id(self.future), id(self.end)}
        drawn |= shape_tube(self.tube, self.outline, view.region, tone, look)
        self.future.points = view.future.astype(np.float32)
        self.future.color = tuple(int(round(0.6 * c)) for c in color)
        self.end.position = view.future[-1]
        self.end.color = tone
        if labelled:
            observed = view.observed is not None and view.observed.shape[0] >= 1
            self.label.text = f"{self.name}: {'observed, ' if observed else ''}predicted"
            self.label.position = view.future[-1] + np.array([0.0, 0.0, 0.03])
            drawn.add(id(self.label))
        for node, points in ((self.observed, view.observed), (self.truth, view.truth)):
            if points is not None and points.shape[0] >= 2:
                n = min(points.shape[0], PATH_POINTS_DRAWN)
                node.points = tubes.resample(points, n).astype(np.float32)
                drawn.add(id(node))
        return drawn
