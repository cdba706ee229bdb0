"""A :class:`promp.viewers.scene_log.SceneLog` as MCAP for Foxglove, PlotJuggler and ROS 2
tools, with Foxglove's own schemas (written by ``foxglove-sdk``, no ROS install).

* 3-D items are entities of ``foxglove.SceneUpdate`` messages (protobuf), in frame
  :data:`promp.viewers.scene_log.FRAME`: line strips are ``LinePrimitive`` (LINE_STRIP),
  points and ellipsoids ``SpherePrimitive`` (a size per axis and a pose), a mesh a
  ``TriangleListPrimitive`` (vertices and indices), a model a ``ModelPrimitive`` holding the
  glTF binary. An item's entity id is its path; its topic is its path's parent
  (``demos/reach/demo-3`` on ``/demos/reach``; a path of one name on ``/scene``). The items of
  one topic at one time are one message, so a viewer that seeks shows the topic's whole state
  from its last message.
* A series is a topic of its own (``/`` + its path), JSON messages
  ``{"<timeline>": t, "value": v}`` (``null`` for NaN) with a JSON schema whose title is the
  label and whose ``value`` says the unit: PlotJuggler and Foxglove's Plot panel plot
  ``/<path>/value``.
* An event is a ``foxglove.Log`` message on ``/`` + its path (Foxglove's Log panel).
* A note is an MCAP metadata record (``notes``); the timelines and units are another
  (``timelines``).

MCAP has one time per message (``log_time``, nanoseconds): an item at ``t`` seconds is logged
at ``t`` s, at ``k`` steps of a sequence timeline at ``k`` s (the observed percent ``p`` at
``p`` s: a plot's time axis reads as the observed percent), a static item at 0. Every message
also carries its time in its own timeline's unit (a scene entity's ``timestamp``, a series'
field).

:class:`McapWriter` keeps the items until :meth:`McapWriter.flush` (or ``close``), which writes
them in time order: a live session can flush at each step.
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from pathlib import Path
from types import ModuleType

import numpy as np
from scipy.spatial.transform import Rotation

from promp.viewers.scene_log import (
    FRAME,
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

__all__ = ["GLB", "McapWriter", "needs_foxglove", "scene_topic"]

GLB = "model/gltf-binary"


def needs_foxglove() -> ModuleType:
    """The ``foxglove`` module (``foxglove-sdk``), or the error naming the extra."""
    try:
        import foxglove
    except ImportError:
        raise ValueError(
            "writing MCAP files needs the optional extra: pip install "
            "'icub-intention-studio[mcap]' (foxglove-sdk, mcap)"
        ) from None
    return foxglove


def scene_topic(path: str) -> str:
    """The topic of a 3-D item at ``path``: its parent (``/scene`` for a path of one name)."""
    parent = path.rpartition("/")[0]
    return f"/{parent}" if parent else "/scene"


def _nanoseconds(seconds: float) -> int:
    return int(round(seconds * 1e9))


class McapWriter:
    """Items written to a new ``.mcap`` file (see the module docstring).

    Parameters
    ----------
    path : Path
        The file (created; its folder must exist).
    name : str
        The recording's name (metadata ``recording``).
    timelines : sequence of Timeline
    """

    def __init__(self, path: Path, name: str, timelines: tuple[Timeline, ...]):
        foxglove = needs_foxglove()
        from foxglove import messages

        self.m = messages
        self.foxglove = foxglove
        self.timelines = {t.name: t for t in timelines}
        self.context = foxglove.Context()
        self.file = foxglove.open_mcap(str(path), context=self.context)
        self.channels: dict[str, object] = {}
        self.scene: dict[tuple[int, str], list] = defaultdict(list)  # (ns, topic): entities
        self.values: list[tuple[int, str, dict]] = []  # (ns, topic, JSON message)
        self.events: list[tuple[int, str, str]] = []  # (ns, topic, text)
        notes = {t.name: f"{t.kind}: {t.label}" for t in timelines}
        notes["units"] = "positions and sizes in metres, angles in radians, times in seconds"
        notes["frame"] = FRAME
        self.file.write_metadata("recording", {"name": name})
        self.file.write_metadata("timelines", notes)

    def __enter__(self) -> McapWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def describe(self, log: SceneLog) -> None:
        """The log's camera, as metadata (``camera``: Foxglove's layouts are not in MCAP)."""
        if log.camera is not None:
            eye, target = log.camera
            self.file.write_metadata("camera", {"eye_m": json.dumps(eye),
                                                "target_m": json.dumps(target)})  # fmt: skip

    def write(self, item: Item) -> None:
        """Keep ``item`` for the next :meth:`flush`."""
        if isinstance(item, Note):
            self.file.write_metadata("notes", {item.path: item.text})
            return
        if isinstance(item, Event):
            ns = _nanoseconds(item.at.value)
            self.events.append((ns, f"/{item.path}", item.text))
            return
        if isinstance(item, Series):
            topic = f"/{item.path}"
            self._series_channel(item, topic)
            for t, v in zip(item.times.tolist(), item.values.tolist(), strict=True):
                value = v if math.isfinite(v) else None
                self.values.append((_nanoseconds(t), topic,
                                    {item.timeline: t, "value": value}))  # fmt: skip
            return
        at = item.at
        ns = 0 if at is None else _nanoseconds(at.value)  # a sequence's step is a second
        self.scene[(ns, scene_topic(item.path))].append(self._entity(item, ns))

    def _series_channel(self, item: Series, topic: str) -> None:
        if topic in self.channels:
            return
        timeline = self.timelines[item.timeline].label
        schema = {
            "type": "object",
            "title": item.label,
            "properties": {
                item.timeline: {"type": "number", "description": timeline},
                "value": {"type": ["number", "null"], "description": f"{item.label}, unit: "
                          f"{item.unit or 'none stated'}"},
            },
        }  # fmt: skip
        self.channels[topic] = self.foxglove.Channel(
            topic, schema=schema, context=self.context,
            metadata={"label": item.label, "unit": item.unit, "timeline": item.timeline},
        )  # fmt: skip

    def _color(self, rgb, opacity: float = 1.0):
        return self.m.Color(r=rgb[0] / 255, g=rgb[1] / 255, b=rgb[2] / 255, a=opacity)

    def _pose(self, position=(0.0, 0.0, 0.0), quaternion=(0.0, 0.0, 0.0, 1.0)):
        m = self.m
        x, y, z, w = (float(v) for v in quaternion)
        return m.Pose(position=m.Vector3(x=float(position[0]), y=float(position[1]),
                                         z=float(position[2])),
                      orientation=m.Quaternion(x=x, y=y, z=z, w=w))  # fmt: skip

    def _points(self, array: np.ndarray) -> list:
        return [self.m.Point3(x=x, y=y, z=z) for x, y, z in np.asarray(array, float).tolist()]

    def _entity(self, item: Item, ns: int):
        m = self.m
        parts: dict[str, list] = {}
        if isinstance(item, Strips):
            parts["lines"] = [
                m.LinePrimitive(type=m.LinePrimitiveLineType.LineStrip, pose=self._pose(),
                                thickness=item.width, points=self._points(s),
                                color=self._color(item.color))  # fmt: skip
                for s in item.strips
            ]
        elif isinstance(item, Points):
            d = 2.0 * item.radius
            parts["spheres"] = [
                m.SpherePrimitive(pose=self._pose(p), size=m.Vector3(x=d, y=d, z=d),
                                  color=self._color(item.color))  # fmt: skip
                for p in item.positions
            ]
        elif isinstance(item, Ellipsoids):
            quaternions = Rotation.from_matrix(item.rotations).as_quat()
            parts["spheres"] = [
                m.SpherePrimitive(pose=self._pose(c, q), size=m.Vector3(x=2 * a, y=2 * b, z=2 * h),
                                  color=self._color(item.color, item.opacity))  # fmt: skip
                for c, q, (a, b, h) in zip(item.centers, quaternions, item.half_axes, strict=True)
            ]
        elif isinstance(item, Mesh):
            parts["triangles"] = [
                m.TriangleListPrimitive(pose=self._pose(), points=self._points(item.vertices),
                                        color=self._color(item.color, item.opacity),
                                        indices=item.faces.reshape(-1).tolist())  # fmt: skip
            ]
        elif isinstance(item, Model):
            parts["models"] = [
                m.ModelPrimitive(pose=self._pose(), scale=m.Vector3(x=1.0, y=1.0, z=1.0),
                                 media_type=GLB, data=item.glb)  # fmt: skip
            ]
        else:
            raise ValueError(f"{getattr(item, 'path', item)!r}: not an item of a viewer log")
        return m.SceneEntity(timestamp=m.Timestamp(ns // 1_000_000_000, ns % 1_000_000_000),
                             frame_id=FRAME, id=item.path, **parts)  # fmt: skip

    def flush(self) -> None:
        """Write the items kept, in time order: one ``SceneUpdate`` per topic and time."""
        messages = [(ns, topic, "scene", entities)
                    for (ns, topic), entities in self.scene.items()]  # fmt: skip
        messages += [(ns, topic, "json", body) for ns, topic, body in self.values]
        messages += [(ns, topic, "log", text) for ns, topic, text in self.events]
        messages.sort(key=lambda m: (m[0], m[1]))
        for ns, topic, kind, body in messages:
            if kind == "scene":
                channel = self.channels.get(topic)
                if channel is None:
                    channel = self.foxglove.channels.SceneUpdateChannel(topic, context=self.context)
                    self.channels[topic] = channel
                channel.log(self.m.SceneUpdate(entities=body), log_time=ns)
            elif kind == "log":
                if topic not in self.channels:
                    self.channels[topic] = self.foxglove.channels.LogChannel(
                        topic, context=self.context)  # fmt: skip
                stamp = self.m.Timestamp(ns // 1_000_000_000, ns % 1_000_000_000)
                self.channels[topic].log(self.m.Log(timestamp=stamp, level=self.m.LogLevel.Info,
                                                    message=body, name=topic), log_time=ns)
            else:
                self.channels[topic].log(json.dumps(body, allow_nan=False).encode(), log_time=ns)
        self.scene.clear()
        self.values.clear()
        self.events.clear()

    def close(self) -> None:
        """Write what is kept and end the file."""
        try:
            self.flush()
        finally:
            self.file.close()
            for channel in self.channels.values():
                channel.close()
                _forget = getattr(self.foxglove.channel, "_channels_by_id", {})
                _forget.pop(channel.id(), None)  # the SDK's registry of JSON channels
            self.channels.clear()


