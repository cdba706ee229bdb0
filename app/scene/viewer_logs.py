"""What the 3D view shows, as a viewer log (:mod:`promp.viewers`) for Rerun and Foxglove: the
Data tab's workspace (:func:`workspace_log`) and the Infer tab's current view
(:func:`infer_log`).

The workspace, in the iCub's root frame (metres; z up):

* ``robot``: the iCub at the pose the studio shows (:func:`robots.icub.model_file.robot_glb`),
  unless the hand was kept in its own frame (drawn without the robot, as the studio does);
* ``demos/<primitive>/<demo>``: each demonstration's hand path, in its primitive's colour
  (grey: flagged, not learned from), those the user hid left out; ``.../hand``: the hand at
  :data:`HAND_POINTS` times of the demonstration's own timeline ``demo_time`` (seconds from its
  start); ``.../<modality>/<column>``: every recorded column against ``demo_time``, in its
  unit (m, rad);
* ``priors/<primitive>``: each primitive's prior region, the studio's tube mesh
  (:mod:`app.scene.tubes`) at the tube style's probability (none while tubes are off), shaped by
  its via-points (``prior_means/<primitive>``: the shaped mean path).

The Infer view (one inference, at its observed percent on ``observed_percent``), under
``infer/<primitive>/<demo>`` (``infer/live`` for a live stream), for each position of the
layout (the hand first): what was observed, the posterior's region of a new sample (its
ellipsoids), the predicted path from the last observed sample and its end, the rest of the
true movement; ``p/<primitive>``: each primitive's probability against the percent observed,
the Recognition chart's curve (or the current percent alone, before the curve is computed).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from app.core.store_state import StoreState
from app.core.via_state import of_primitive
from app.core.view_state import ViewState
from app.live.inference import InferView
from app.live.recognition_curve import RecognitionCurve
from app.live.regions import TUBE_POINTS, prior_shape
from app.scene.tubes import region_vertices, resample, tube_faces, tube_look
from app.scene.workspace_layer import LINE_POINTS, NO_COLOR, PRIOR_OPACITY
from promp.model import ProMPModel
from promp.viewers.scene_log import (
    Color,
    Item,
    Mesh,
    Model,
    Note,
    Points,
    SceneLog,
    Series,
    Stamp,
    Strips,
    Timeline,
)
from promp.viewers.trial import OBSERVED, TRUTH_COLOR, path_name, probability_series, trial_items
from robots.icub.layout import HAND, hand_dims

__all__ = ["DEMO_TIME", "HAND_POINTS", "infer_log", "workspace_log"]

DEMO_TIME = Timeline("demo_time", "seconds", "seconds from the start of each demonstration")
HAND_POINTS = LINE_POINTS  # times a demonstration's hand is shown at (the line's resolution)
# Where the 3-D view starts: from the partner's side of the table, a little to the robot's
# left and above, looking at the hand paths (metres from what it looks at).
EYE_OFFSET = (-0.85, -0.45, 0.4)
UNITS_NOTE = ("Positions and sizes in metres in the iCub's root frame (z up, the robot faces "
              "-x, its left is -y); angles in radians; times in seconds.")  # fmt: skip


def _demo_items(prefix: str, demo, layout, color: Color) -> list[Item]:
    """One demonstration: its hand path, the hand at :data:`HAND_POINTS` times, and every
    column against its own time."""
    values = layout.extract(demo)
    times = np.asarray(demo.times, dtype=float) - float(demo.times[0])
    items: list[Item] = []
    cols = hand_dims(layout)
    if cols is not None and len(times) >= 2:
        hand = values[:, cols]
        items.append(Strips(prefix, (hand,), color, 0.003))
        for i in np.unique(np.round(np.linspace(0, len(times) - 1, HAND_POINTS)).astype(int)):
            items.append(Points(f"{prefix}/hand", hand[i : i + 1], color, 0.008,
                                Stamp(DEMO_TIME.name, float(times[i]))))  # fmt: skip
    for modality in layout.modalities:
        dims = layout.dims([modality.name])
        for column, d in zip(modality.columns, dims, strict=True):
            items.append(Series(f"{prefix}/{path_name(modality.name)}/{path_name(column)}",
                                f"{modality.name} {column}", modality.unit, DEMO_TIME.name,
                                times, values[:, d]))  # fmt: skip
    return items


def _prior_items(model: ProMPModel, colors: Mapping[str, Color], view: ViewState) -> list[Item]:
    """Each primitive's prior region, as the Teach tab draws it."""
    look = tube_look(view.tube_style)
    if not look.shown or hand_dims(model.layout) is None:
        return []
    faces = tube_faces(TUBE_POINTS)
    items: list[Item] = []
    for name in model.names:
        if name not in colors:
            continue
        region = prior_shape(model, name, view.via_points).region(model, HAND.name, TUBE_POINTS)
        items.append(Mesh(f"priors/{path_name(name)}", region_vertices(region, look.probability),
                          faces, colors[name], PRIOR_OPACITY))  # fmt: skip
        if of_primitive(view.via_points, name):
            mean = resample(region.mean, LINE_POINTS)
            items.append(Strips(f"prior_means/{path_name(name)}", (mean,), colors[name], 0.006))
    return items


def workspace_log(
    store: StoreState,
    view: ViewState,
    model: ProMPModel | None,
    robot: Callable[[], bytes] | None,
) -> tuple[SceneLog, int]:
    """The workspace as the studio shows it (see the module docstring), and how many
    demonstrations the user hid (left out).

    Parameters
    ----------
    robot : callable or None
        Gives the robot's ``.glb`` (None: no robot, whatever the frame).
    """
    colors = {p.name: tuple(p.color) for p in store.primitives}
    left_out = set(store.left_out)
    items: list[Item] = [Note("about", "# Workspace\n\n" + UNITS_NOTE)]
    if robot is not None and store.frame.robot_shown:
        items.append(Model("robot", robot()))
    hidden = 0
    for name, demos in store.demos.items():
        for demo in demos:
            if (name, demo.name) in view.hidden:
                hidden += 1
                continue
            color = NO_COLOR if (name, demo.name) in left_out else colors.get(name, NO_COLOR)
            prefix = f"demos/{path_name(name)}/{path_name(demo.name)}"
            items += _demo_items(prefix, demo, store.layout, color)
    if model is not None:
        items += _prior_items(model, colors, view)
    log = SceneLog("icub-studio-workspace", (DEMO_TIME,), tuple(items), _camera(items))
    return log, hidden


def _camera(items: list[Item]):
    """The start view: towards the middle of the paths drawn (the origin without any)."""
    paths = [s for item in items if isinstance(item, Strips) for s in item.strips]
    target = np.vstack(paths).mean(axis=0) if paths else np.zeros(3)
    return tuple(target + EYE_OFFSET), tuple(target)


def infer_log(
    view: InferView,
    color_of: Callable[[str], Color],
    tube_style: str,
    curve: RecognitionCurve | None = None,
) -> SceneLog:
    """The Infer tab's view ``view`` (see the module docstring).

    Raises
    ------
    ValueError
        The view has no inference (its message says why).
    """
    result = view.result
    if result is None:
        raise ValueError(view.message or "the Infer tab shows no inference")
    state = view.state
    prefix = ("infer/live" if state.live
              else f"infer/{path_name(state.primitive)}/{path_name(state.demo)}")  # fmt: skip
    percent = int(state.percent)
    names = tuple(result.model.names)
    color = color_of(result.inference.primitive)
    probability = tube_look(tube_style).probability
    items: list[Item] = [Note("about", f"# Infer: {prefix}, {percent} % observed\n\n"
                                       + UNITS_NOTE)]  # fmt: skip
    for position in result.positions:
        where = f"{prefix}/{path_name(position.modality)}"
        region = position.region
        items += trial_items(where, percent, position.observed, region.mean, region.cov,
                             position.future, color, probability)  # fmt: skip
        if position.truth is not None and len(position.truth) >= 2:
            items.append(Strips(f"{where}/truth", (position.truth,), TRUTH_COLOR, 0.003,
                                Stamp(OBSERVED.name, percent)))  # fmt: skip
    if curve is not None and curve.names == names:
        items += probability_series(prefix, names, np.round(curve.percents).astype(int),
                                    curve.probabilities)  # fmt: skip
    else:
        items += probability_series(prefix, names, [percent],
                                    np.asarray(result.inference.probabilities)[None, :])
    return SceneLog("icub-studio-infer", (OBSERVED,), tuple(items), _camera(items))
