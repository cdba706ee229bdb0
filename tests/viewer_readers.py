"""Viewer files read back with the tools' own readers, for the tests: Rerun's chunk reader
(``rerun.chunk.RrdReader``) on an ``.rrd``, and the ``mcap`` package's reader (with
``mcap-protobuf-support`` decoding Foxglove's protobuf schemas) on an MCAP file. Nothing of
ours is used to read them."""

from __future__ import annotations

import json
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class RrdEntity:
    """What an ``.rrd`` holds at one entity path.

    Attributes
    ----------
    static : dict
        Component (``Archetype:field``) -> value, of the static rows.
    rows : list of (dict, dict)
        The temporal rows: ({timeline: value (int: a sequence, or nanoseconds)},
        {component: value}), ordered by their times.
    """

    static: dict = field(default_factory=dict)
    rows: list = field(default_factory=list)

    def at(self, timeline: str, value: int) -> dict:
        """The components logged at ``value`` of ``timeline`` (merged)."""
        out: dict = {}
        for times, components in self.rows:
            if times.get(timeline) == value:
                out.update(components)
        return out

    def series(self, timeline: str) -> tuple[np.ndarray, np.ndarray]:
        """The ``Scalars:scalars`` rows as (times, values)."""
        pairs = sorted((t[timeline], c["Scalars:scalars"][0]) for t, c in self.rows
                       if "Scalars:scalars" in c)  # fmt: skip
        return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs], dtype=float)


def read_rrd(path: Path) -> dict[str, RrdEntity]:
    """Every entity of the first recording of ``path``, by path (without the leading ``/``)."""
    import pyarrow as pa
    import rerun as rr

    out: dict[str, RrdEntity] = defaultdict(RrdEntity)
    for chunk in rr.chunk.RrdReader(path).store().stream():
        batch = chunk.to_record_batch()
        timelines = set(chunk.timeline_names)
        times = {}
        for name in timelines:
            column = batch.column(name)
            if pa.types.is_duration(column.type) or pa.types.is_timestamp(column.type):
                column = column.cast(pa.int64())
            times[name] = column.to_pylist()
        components = {name: batch.column(name).to_pylist() for name in batch.schema.names
                      if name not in timelines and not name.startswith("rerun.controls")}
        entity = out[chunk.entity_path.lstrip("/")]
        for i in range(chunk.num_rows):
            row = {name: values[i] for name, values in components.items() if values[i] is not None}
            if chunk.is_static:
                entity.static.update(row)
            else:
                entity.rows.append(({t: times[t][i] for t in timelines}, row))
    for entity in out.values():
        entity.rows.sort(key=lambda r: sorted(r[0].items()))
    return dict(out)


@dataclass
class McapMessage:
    topic: str
    log_time: int  # nanoseconds
    schema: str
    encoding: str
    message: object  # a decoded protobuf message, or the JSON object


def read_mcap(path: Path) -> tuple[list[McapMessage], dict[str, list[dict]]]:
    """Every message of ``path`` in log-time order, decoded, and its metadata records by name."""
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    factory = DecoderFactory()
    messages = []
    metadata: dict[str, list[dict]] = defaultdict(list)
    with open(path, "rb") as handle:
        reader = make_reader(handle)
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            if channel.message_encoding == "json":
                decoded = json.loads(message.data)
            else:
                decoded = factory.decoder_for(channel.message_encoding, schema)(message.data)
            messages.append(McapMessage(channel.topic, message.log_time,
                                        schema.name if schema else "", channel.message_encoding,
                                        decoded))  # fmt: skip
        for record in reader.iter_metadata():
            metadata[record.name].append(dict(record.metadata))
    return messages, dict(metadata)


def scene_entities(messages: list[McapMessage]) -> dict[str, list[tuple[int, object]]]:
    """Every ``foxglove.SceneUpdate`` entity by id: [(log time, entity), ...] in time order."""
    out: dict[str, list] = defaultdict(list)
    for m in messages:
        if m.schema == "foxglove.SceneUpdate":
            for entity in m.message.entities:
                out[entity.id].append((m.log_time, entity))
    return dict(out)


def json_series(messages: list[McapMessage], topic: str, timeline: str):
    """The (times, values) of a series topic (``null`` read as NaN)."""
    rows = [(m.message[timeline], m.message["value"]) for m in messages if m.topic == topic]
    values = [np.nan if v is None else v for _, v in rows]
    return np.array([t for t, _ in rows], dtype=float), np.array(values, dtype=float)


def points(primitive_points) -> np.ndarray:
    """Foxglove ``Point3`` messages as an array (n, 3)."""
    return np.array([[p.x, p.y, p.z] for p in primitive_points], dtype=float)
