"""The workspace in 3D: each demonstration as a thin line, each primitive's prior as a tube.

Both are the ``hand`` modality's (a workspace without one has none). Lines keep their node while
their demonstration is the same object; tubes keep their mesh topology (``TUBE_POINTS`` rings of
:data:`app.scene.tubes.RING` vertices), so a refit only replaces vertices. A tube is the region
where 90 % (or 50 %) of the primitive's movements are at each moment
(:func:`app.live.regions.prior_shape`), drawn as the view's tube style says
(:func:`app.scene.tubes.tube_look`): a translucent band, an outline (thin rings and lines, its
own node), or nothing; lines stay above it. A tube wider than its workspace is drawn as its
outline whatever the style (:mod:`app.scene.tube_scale`; :attr:`WorkspaceLayer.widths`). A
primitive shaped by via-points has its tube conditioned on them and its mean path drawn as a
thicker line through them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import viser

from app.core.via_state import StudioViaPoint, of_primitive
from app.live.regions import TUBE_POINTS, prior_shape
from app.scene.look import FADED, HIDDEN
from app.scene.tube_scale import TubeWidth, drawn_look, tube_width, workspace_extent
from app.scene.tubes import (
    TUBE_SIDE,
    outline_segments,
    region_vertices,
    resample,
    tube_faces,
    tube_look,
)
from promp.data import Demonstration, Layout
from promp.model import ProMPModel
from promp.region import SampleDistribution
from robots.icub.layout import HAND, hand_dims

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
        self.means: dict[str, viser.SceneNodeHandle] = {}  # a shaped primitive's mean path
        self._tones: dict[str, tuple] = {}  # each outline's colour and the tone it shows
        self.widths: dict[str, TubeWidth] = {}  # each tube's, at the style drawn
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
        via_points: Sequence[StudioViaPoint] = (),
    ) -> None:
        """A prior tube per primitive both ``model`` and ``colors`` know (``priors`` as the look
        shows them, the region of tube ``style``'s probability), each conditioned on its
        ``via_points``; none for a model without a hand."""
        self._draw_tubes(model if model is not None and hand_dims(model.layout) is not None
                         else None, colors, priors, style, tuple(via_points))  # fmt: skip

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

    def prior_tube(
        self, model: ProMPModel, name: str, via_points: Sequence[StudioViaPoint] = ()
    ) -> SampleDistribution:
        """The region of primitive ``name``'s hand (TUBE_POINTS phases), shaped by its
        ``via_points``."""
        return prior_shape(model, name, via_points).region(model, HAND.name, TUBE_POINTS)

    def _draw_tubes(
        self, model: ProMPModel | None, colors, priors: str, style: str, via_points: tuple
    ) -> None:
        # A model still being replaced may know a primitive just deleted or renamed.
        names = [n for n in model.names if n in colors] if model is not None else []
        for name in list(self.tubes):
            if name not in names:
                self.tubes.pop(name).remove()
                self.outlines.pop(name).remove()
                self._tones.pop(name, None)
                self.widths.pop(name, None)
        for name in list(self.means):
            if name not in names or not of_primitive(via_points, name):
                self.means.pop(name).remove()
        look = tube_look(style)
        extent = workspace_extent(model, HAND.name) if names else 0.0
        for name in names:
            region = self.prior_tube(model, name, via_points)
            self.widths[name] = tube_width(name, region, look.probability, extent)
            vertices = region_vertices(region, look.probability)
            color = tuple(colors.get(name, NO_COLOR))
            if of_primitive(via_points, name):
                self._draw_mean(name, region.mean, color)
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

    def _draw_mean(self, name: str, mean: np.ndarray, color) -> None:
        """The mean path of a primitive shaped by via-points, darker than its tube."""
        points = resample(mean, LINE_POINTS).astype(np.float32)
        darker = tuple(int(round(0.6 * c)) for c in color)
        if name in self.means:
            self.means[name].points = points
            _set(self.means[name], "color", darker)
        else:
            self.means[name] = self.server.scene.add_spline_catmull_rom(
                f"/prior_means/{name}", points=points, color=darker, thickness=4.0,
                thickness_units="screen", visible=False,
            )  # fmt: skip

    def apply(self, demos: bool, priors: str, hidden: set[Key], style: str) -> None:
        """Show the lines (``demos``, but those the user hid: ``hidden``) and the tubes as
        ``priors`` says (shown, faded or hidden) in tube ``style``."""
        for key, line in list(self.lines.items()):
            _set(line, "visible", demos and key not in hidden)
        style_look = tube_look(style)
        opacity = DIMMED_OPACITY if priors == FADED else PRIOR_OPACITY
        white = DIMMED_WHITE if priors == FADED else OUTLINE_WHITE
        for mean in list(self.means.values()):
            _set(mean, "visible", priors != HIDDEN)
        for name, tube in list(self.tubes.items()):
            width = self.widths.get(name)
            look = style_look if width is None else drawn_look(style_look, width)
            _set(tube, "visible", priors != HIDDEN and look.surface)
            _set(tube, "opacity", opacity)
            outline = self.outlines[name]
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
