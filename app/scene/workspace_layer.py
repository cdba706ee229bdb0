"""The workspace in 3D: each demonstration as a thin line, each primitive's prior as a tube.

Both are the ``hand`` modality's (a workspace without one has none). Lines keep their node while
their demonstration is the same object; tubes keep their mesh topology (``TUBE_POINTS`` rings of
:data:`app.scene.tubes.RING` vertices), so a refit only replaces vertices. A tube is drawn as
the view's tube style says (:func:`app.scene.tubes.tube_look`): a translucent band at +-2 or
+-1 sigma, an outline (thin rings and lines, its own node), or nothing; lines stay above it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import viser

from app.live.inference import typical_prior
from app.scene.look import FADED, HIDDEN
from app.scene.tubes import (
    TUBE_SIDE,
    outline_segments,
    resample,
    tube_faces,
    tube_look,
    tube_vertices,
)
from promp.data import Demonstration, Layout
from promp.model import ProMPModel
from robots.icub.layout import hand_dims

TUBE_POINTS = 100
LINE_POINTS = 60
PRIOR_OPACITY = 0.25
DIMMED_OPACITY = 0.07
NO_COLOR = (200, 200, 200)
OUTLINE_WHITE = 0.35  # an outline's colour: its primitive's, this much towards white
DIMMED_WHITE = 0.8  # and this much while the tubes are dimmed

Key = tuple[str, str]  # (primitive, demonstration)


def toward_white(color, share: float) -> tuple[int, int, int]:
    """``color`` mixed with white (``share`` of white): a line that reads lighter."""
    return tuple(int(round(c + share * (255 - c))) for c in color)  # type: ignore[return-value]


def _set(node, name: str, value) -> None:
    """Set a node property only when it changes (every assignment is a message)."""
    current = getattr(node, name)
    same = (
        tuple(current) == tuple(value)
        if isinstance(value, tuple)
        else current == value
    )
    if not same:
        setattr(node, name, value)


class WorkspaceLayer:
    """Demonstration lines and prior tubes (see the module docstring)."""

    def __init__(self, server: viser.ViserServer):
        self.server = server
        self.lines: dict[Key, viser.SceneNodeHandle] = {}
        self._line_demo: dict[Key, Demonstration] = {}  # what each line shows
        self.tubes: dict[str, viser.MeshHandle] = {}
        self.outlines: dict[str, viser.LineSegmentsHandle] = {}
        self._tones: dict[str, tuple] = {}  # each outline's colour and the tone it shows
        self.faces = tube_faces(TUBE_POINTS)

    def draw_lines(
        self,
        demos: Mapping[str, Sequence[Demonstration]],
        colors: Mapping[str, tuple[int, int, int]],
        layout: Layout,
        left_out: set[Key] | frozenset = frozenset(),
    ) -> None:
        """A line per demonstration of ``demos`` in its primitive's colour (``left_out``:
        flagged demonstrations not learned from, grey); none in a layout without a hand. A new
        line is drawn hidden (:meth:`apply` shows it)."""
        if hand_dims(layout) is None:
            demos = {}
        colors_of = {
            (name, d.name): NO_COLOR if (name, d.name) in left_out else colors.get(name, NO_COLOR)
            for name, items in demos.items()
            for d in items
        }
        self._draw_lines(demos, colors_of, layout)

    def draw_tubes(
        self,
        model: ProMPModel | None,
        colors: Mapping[str, tuple[int, int, int]],
        priors: str,
        style: str,
    ) -> None:
        """A prior tube per primitive both ``model`` and ``colors`` know (``priors`` as the look
        shows them, at the radius of tube ``style``); none for a model without a hand."""
        self._draw_tubes(model if model is not None and hand_dims(model.layout) is not None
                         else None, colors, priors, style)  # fmt: skip

    def _draw_lines(self, demos, colors, layout: Layout) -> None:
        """``colors``: per (primitive, demo)."""
        wanted = set()
        cols = hand_dims(layout)
        for name, items in demos.items():
            for demo in items:
                key = (name, demo.name)
                wanted.add(key)
                if key in self.lines and self._line_demo.get(key) is demo:
                    continue
                if key in self.lines:  # same name, other data (a restored or new workspace)
                    self.lines.pop(key).remove()
                self._line_demo[key] = demo
                points = layout.extract(demo)[:, cols]
                self.lines[key] = self.server.scene.add_spline_catmull_rom(
                    f"/demos/{name}/{demo.name}",
                    points=resample(points, min(len(points), LINE_POINTS)),
                    color=colors[key],
                    thickness=1.5,
                    thickness_units="screen",
                    visible=False,
                )
        for key in list(self.lines):
            if key not in wanted:
                self.lines.pop(key).remove()
                self._line_demo.pop(key, None)
            else:
                _set(self.lines[key], "color", tuple(colors[key]))

    def prior_tube(self, model: ProMPModel, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Mean and std (TUBE_POINTS, 3) of the prior hand path of primitive ``name``."""
        prediction = typical_prior(model, name, TUBE_POINTS)
        cols = hand_dims(model.layout)
        return prediction.mean[:, cols], prediction.std[:, cols]

    def _draw_tubes(self, model: ProMPModel | None, colors, priors: str, style: str) -> None:
        # A model still being replaced may know a primitive just deleted or renamed.
        names = [n for n in model.names if n in colors] if model is not None else []
        for name in list(self.tubes):
            if name not in names:
                self.tubes.pop(name).remove()
                self.outlines.pop(name).remove()
                self._tones.pop(name, None)
        look = tube_look(style)
        for name in names:
            vertices = tube_vertices(*self.prior_tube(model, name), n_sigma=look.n_sigma)
            color = tuple(colors.get(name, NO_COLOR))
            tube = self.tubes.get(name)
            if tube is None:
                self.tubes[name] = self.server.scene.add_mesh_simple(
                    f"/priors/{name}",
                    vertices=vertices,
                    faces=self.faces,
                    color=color,
                    opacity=DIMMED_OPACITY if priors == FADED else PRIOR_OPACITY,
                    flat_shading=False,
                    side=TUBE_SIDE,
                    visible=False,  # apply() shows it
                )
                self.outlines[name] = self.server.scene.add_line_segments(
                    f"/prior_outlines/{name}",
                    points=outline_segments(vertices),
                    colors=toward_white(color, OUTLINE_WHITE),
                    thickness=1.0,
                    thickness_units="screen",
                    visible=False,
                )
            else:
                tube.vertices = vertices
                _set(tube, "color", color)
                self.outlines[name].points = outline_segments(vertices)
            if self._tones.get(name, (None,))[0] != color:
                self._tones[name] = (color, OUTLINE_WHITE)
                self._tone(name, OUTLINE_WHITE)

    def apply(self, demos: bool, priors: str, hidden: set[Key], style: str) -> None:
        """Show the lines (``demos``, but those the user hid: ``hidden``) and the tubes as
        ``priors`` says (shown, faded or hidden) in tube ``style``."""
        for key, line in list(self.lines.items()):
            _set(line, "visible", demos and key not in hidden)
        look = tube_look(style)
        opacity = DIMMED_OPACITY if priors == FADED else PRIOR_OPACITY
        for tube in list(self.tubes.values()):
            _set(tube, "visible", priors != HIDDEN and look.surface)
            _set(tube, "opacity", opacity)
        white = DIMMED_WHITE if priors == FADED else OUTLINE_WHITE
        for name, outline in list(self.outlines.items()):
            _set(outline, "visible", priors != HIDDEN and look.outline)
            if self._tones[name][1] != white:
                self._tone(name, white)

    def _tone(self, name: str, white: float) -> None:
        """Colour outline ``name`` its primitive's colour mixed with ``white``."""
        color = self._tones[name][0]
        self._tones[name] = (color, white)
        outline = self.outlines[name]
        rgb = np.array(toward_white(color, white), dtype=np.uint8)
        outline.colors = np.broadcast_to(rgb, (outline.points.shape[0], 2, 3)).copy()
