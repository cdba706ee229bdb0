"""A live hand placed in the iCub's frame, as an imported one is.

A workspace imported from another rig keeps its hand placed in the iCub's root frame
(:mod:`app.io.hand_frame`: a turn about the vertical and a translation): its demonstrations and
its model are in that frame. A motion capture streams the hand in its own frame, the frame the
imported files were recorded in; so the live hand is placed the same way before the session
sees it. :class:`PlacedTransport` wraps the session's transport: the inlets of the stream the
hand comes from give its channels placed (in the stream's own unit: converted to metres,
placed, converted back; the source converts them again), every other channel as it came.
"""

from __future__ import annotations

import numpy as np

from promp.live.source import Channels, LiveInput, channels_of
from promp.live.transport import Inlet, OutletSpec, StreamDescription, Transport
from robots.icub.placement import Placement

__all__ = ["PlacedInlet", "PlacedTransport"]


class PlacedInlet:
    """An inlet whose hand channels (``channels``) are placed by ``placement``."""

    def __init__(self, inlet: Inlet, channels: Channels, placement: Placement):
        self._inlet = inlet
        self.description = inlet.description
        self._channels = channels
        self._placement = placement

    def pull(self):
        times, values = self._inlet.pull()
        if not isinstance(values, np.ndarray) or values.size == 0:
            return times, values
        index, scale = self._channels.index, self._channels.scale
        if values.ndim != 2 or index.max() >= values.shape[1]:
            return times, values  # not the stream's channels: the source says so
        placed = np.array(values, dtype=float)
        placed[:, index] = self._placement.apply(placed[:, index] * scale) / scale
        return times, placed

    def offset(self) -> float:
        return self._inlet.offset()

    def close(self) -> None:
        self._inlet.close()


class PlacedTransport:
    """``transport`` with the ``hand`` input's channels placed by ``placement`` (see the module
    docstring)."""

    def __init__(self, transport: Transport, hand: LiveInput, placement: Placement):
        if len(hand.modality.fields) != 3:
            raise ValueError(f"a placed hand has 3 channels, {hand.name!r} maps "
                             f"{len(hand.modality.fields)}")  # fmt: skip
        self._transport = transport
        self._hand = hand
        self._placement = placement

    def clock(self) -> float:
        return self._transport.clock()

    def find(self, wait: float) -> list[StreamDescription]:
        return self._transport.find(wait)

    def open(self, stream: StreamDescription) -> Inlet:
        inlet = self._transport.open(stream)
        if not self._hand.selector.matches(stream) or stream.is_markers:
            return inlet
        try:
            channels = channels_of(self._hand, inlet.description)
        except ValueError:  # the source finds it too, and says so (wrong channels)
            return inlet
        return PlacedInlet(inlet, channels, self._placement)

    def outlet(self, spec: OutletSpec):
        return self._transport.outlet(spec)
