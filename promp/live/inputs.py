"""A live input: one modality of a session, the stream it comes from, and where its values
are in that stream's samples.

Each :class:`LiveInput` is one modality in the rig formats' mapping syntax
(:mod:`promp.rigs.mapping`): ``hand=MocapHand:0,1,2@mm`` takes channels 0, 1, 2 of the stream
named ``MocapHand`` (or ``type=Mocap``, ``source_id=vicon-1``: :class:`Selector`), in
millimetres, converted to metres; channels are named by their labels or their indices, and a
channel's own unit (its ``unit`` in the stream's description) is converted the same way when
the mapping states none (:func:`channels_of`). The channels are looked up with the XDF
reader's own code (:class:`promp.rigs.streams.Recording`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from promp.live.transport import Selector, StreamDescription
from promp.rigs.mapping import SourcedModality, parse_sourced, si_unit
from promp.rigs.streams import Recording

__all__ = ["Channels", "channels_of", "LiveInput"]


@dataclass(frozen=True)
class LiveInput:
    """One modality of a live session: its mapping and the stream it comes from."""

    modality: SourcedModality
    selector: Selector

    @classmethod
    def parse(cls, spec: str) -> LiveInput:
        """``"hand=MocapHand:0,1,2@mm"`` as an input.

        Raises
        ------
        ValueError
            The mapping syntax's errors, or no stream named (``hand=0,1,2``).
        """
        modality = parse_sourced(spec)
        if not modality.stream:
            raise ValueError(
                f"a live input names its stream: NAME=STREAM:CHANNEL,...[@UNIT], e.g. "
                f"{modality.name}=MocapHand:0,1,2@mm; got {spec!r}"
            )
        return cls(modality, Selector.parse(modality.stream))

    @property
    def name(self) -> str:
        return self.modality.name

    @property
    def stream(self) -> str:
        return str(self.selector)


@dataclass(frozen=True)
class Channels:
    """Where an input's values are in its stream's samples, and how they are converted.

    ``index`` (k,) the channels, ``scale`` (k,) the factor to SI, ``units`` the SI units."""

    index: np.ndarray
    scale: np.ndarray
    units: tuple[str, ...]


def channels_of(live_input: LiveInput, stream: StreamDescription) -> Channels:
    """The channels of ``live_input`` in ``stream``.

    Raises
    ------
    ValueError
        ``stream`` is a marker stream, or lacks a channel the mapping names.
    """
    if stream.is_markers:
        raise ValueError(f"stream {stream.name!r} is a marker stream, not {live_input.name!r}'s")
    labels = stream.labels
    if not all(labels) or len(set(labels)) != len(labels):
        labels = tuple(str(i) for i in range(stream.n_channels))
    recording = Recording(f"LSL stream {stream.name!r}", {stream.name: labels},
                          {stream.name: stream.units})  # fmt: skip
    fields = live_input.modality.fields
    recording.require_fields(stream.name, fields)
    index = np.array([recording.field_index(stream.name, f) for f in fields], dtype=int)
    stated = live_input.modality.stated_unit
    raw = (stated,) * len(fields) if stated else recording.field_units(stream.name, fields)
    units, scales = zip(*(si_unit(u) for u in raw), strict=True)
    return Channels(index, np.array(scales, dtype=float), tuple(units))
