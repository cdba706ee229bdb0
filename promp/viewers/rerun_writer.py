"""A :class:`promp.viewers.scene_log.SceneLog` as a Rerun recording (``.rrd``).

Each item goes to its path as Rerun's own archetype: line strips ``LineStrips3D``, points
``Points3D``, a mesh ``Mesh3D``, ellipsoids ``Ellipsoids3D`` (solid, translucent), a model
``Asset3D`` (glTF binary), a series ``Scalars`` with its ``SeriesLines`` name (label and
unit), a note ``TextDocument`` (markdown), an event ``TextLog``. An item at a
:class:`Stamp` is logged at that time of its timeline (a duration in seconds, or a sequence),
others are static. The scene's frame
is z up (``ViewCoordinates.RIGHT_HAND_Z_UP`` at the root). Rerun's own ``log_time`` is not
recorded: a file's content is the log's, not the clock's.

Writing a file sends nothing anywhere (the SDK's file sink); the SDK is imported on first use
and its absence is a ValueError naming the extra that installs it (``rerun``).

For a live session, :class:`RerunWriter` takes items one at a time (``write``) while a
session runs: its inputs, predictions and events at their LSL times on a ``seconds`` timeline.
"""

from __future__ import annotations

import uuid
from pathlib import Path
from types import ModuleType

import numpy as np
from scipy.spatial.transform import Rotation

from promp.viewers.scene_log import (
    Ellipsoids,
    Event,
    Item,
    Mesh,
    Model,
    Note,
    Points,
    SceneLog,
    Series,
    Strips,
    Timeline,
)

__all__ = ["PLOT_NAMES", "SERIES_UNITS", "needs_rerun", "RerunWriter"]

SERIES_UNITS = {"1": ""}  # a probability is said without a unit
PLOT_NAMES = {"m": "positions (m)", "rad": "angles (rad)", "1": "probability", "s": "seconds"}


def needs_rerun() -> ModuleType:
    """The ``rerun`` module (``rerun-sdk``), or the error naming the extra that installs it."""
    try:
        import rerun
    except ImportError:
        raise ValueError(
            "writing Rerun recordings needs the optional extra: pip install "
            "'icub-intention-studio[rerun]' (rerun-sdk)"
        ) from None
    return rerun


def _rgba(color, opacity: float = 1.0) -> list[int]:
    return [*color, int(round(255 * opacity))]


class RerunWriter:
    """Items of a log written to a new ``.rrd`` file as they come (see the module docstring).

    Parameters
    ----------
    path : Path
        The file (created; its folder must exist).
    name : str
        The recording's application id.
    timelines : sequence of Timeline
        The timelines the items may be stamped on.
    """

    def __init__(self, path: Path, name: str, timelines: tuple[Timeline, ...]):
        rr = needs_rerun()
        self.rr = rr
        self.timelines = {t.name: t for t in timelines}
        # a recording id of its own, said rather than left to the SDK's defaults
        self.stream = rr.RecordingStream(name, recording_id=uuid.uuid4(), send_properties=False)
        self.stream.set_log_time_enabled(False)
        self.stream.set_log_tick_enabled(False)
        self.stream.save(str(path))
        self.stream.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    def __enter__(self) -> RerunWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _set_time(self, timeline: str, value: float) -> None:
        if self.timelines[timeline].kind == "sequence":
            self.stream.set_time(timeline, sequence=int(round(value)))
        else:
            self.stream.set_time(timeline, duration=float(value))

    def describe(self, log: SceneLog) -> None:
        """The viewer's layout for ``log``: the 3-D view (from the log's camera) beside one
        plot per unit of its series (metres, radians, probabilities...)."""
        rrb = self.rr.blueprint
        series: dict[str, list[str]] = {}
        for item in log.items:
            if isinstance(item, Series) and f"/{item.path}" not in series.get(item.unit, []):
                series.setdefault(item.unit, []).append(f"/{item.path}")
        eye = None
        if log.camera is not None:
            eye = rrb.EyeControls3D(position=log.camera[0], look_target=log.camera[1],
                                    eye_up=(0.0, 0.0, 1.0))  # fmt: skip
        hidden = [f"- {p}" for paths in series.values() for p in paths]
        view = rrb.Spatial3DView(origin="/", name="3D (m)", contents=["+ /**", *hidden],
                                 eye_controls=eye)  # fmt: skip
        plots = [rrb.TimeSeriesView(origin="/", name=PLOT_NAMES.get(unit, unit or "values"),
                                    contents=paths)  # fmt: skip
                 for unit, paths in series.items()]
        layout = rrb.Horizontal(view, rrb.Vertical(*plots), column_shares=[3, 2]) if plots else view
        self.stream.send_blueprint(rrb.Blueprint(layout, collapse_panels=True),
                                   make_active=True, make_default=True)  # fmt: skip

    def write(self, item: Item) -> None:
        """Log ``item`` (at its stamp, or static)."""
        if isinstance(item, Series):
            self._series(item)
            return
        at = getattr(item, "at", None)
        if at is not None:
            self._set_time(at.timeline, at.value)
        try:
            self.stream.log(item.path, self._archetype(item), static=at is None)
        finally:
            self.stream.reset_time()

    def _archetype(self, item: Item):
        rr = self.rr
        if isinstance(item, Strips):
            return rr.LineStrips3D(list(item.strips), colors=item.color, radii=item.width / 2)
        if isinstance(item, Points):
            return rr.Points3D(item.positions, colors=item.color, radii=item.radius)
        if isinstance(item, Mesh):
            return rr.Mesh3D(vertex_positions=item.vertices, triangle_indices=item.faces,
                             albedo_factor=_rgba(item.color, item.opacity))  # fmt: skip
        if isinstance(item, Ellipsoids):
            quaternions = Rotation.from_matrix(item.rotations).as_quat()  # x, y, z, w
            return rr.Ellipsoids3D(
                centers=item.centers, half_sizes=item.half_axes, quaternions=quaternions,
                colors=_rgba(item.color, item.opacity), fill_mode=rr.components.FillMode.Solid,
            )  # fmt: skip
        if isinstance(item, Model):
            return rr.Asset3D(contents=item.glb, media_type=rr.MediaType.GLB)
        if isinstance(item, Note):
            return rr.TextDocument(item.text, media_type=rr.MediaType.MARKDOWN)
        if isinstance(item, Event):
            return rr.TextLog(item.text, level=rr.TextLogLevel.INFO)
        raise ValueError(f"{getattr(item, 'path', item)!r}: not an item of a viewer log")

    def _series(self, item: Series) -> None:
        rr = self.rr
        unit = SERIES_UNITS.get(item.unit, item.unit)
        name = f"{item.label} ({unit})" if unit else item.label
        self.stream.log(item.path, rr.SeriesLines(names=name), static=True)
        if self.timelines[item.timeline].kind == "sequence":
            index = rr.TimeColumn(item.timeline, sequence=np.round(item.times).astype(np.int64))
        else:
            index = rr.TimeColumn(item.timeline, duration=item.times)
        self.stream.send_columns(item.path, indexes=[index],
                                 columns=rr.Scalars.columns(scalars=item.values))  # fmt: skip

    def close(self) -> None:
        """Write what is buffered and end the file."""
        self.stream.flush()
        self.stream.disconnect()


