"""What the live pipeline needs of a transport, without naming LSL.

The source stage (:mod:`promp.live.source`) resolves streams, opens inlets and pulls samples
through a :class:`Transport`; the outlets sink (:mod:`promp.live.outlets`) opens outlets
through it. :mod:`promp.live.lsl` is the transport over the Lab Streaming Layer (the only
module that imports ``pylsl``); tests drive the stages with a fake one (``tests/live_fakes.py``).

A stream is chosen by a :class:`Selector`: its name (``MocapHand``), ``type=Mocap`` or
``source_id=vicon-1``, the ``STREAM`` part of the rig formats' mapping syntax
(``hand=type=Mocap:0,1,2@mm``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

__all__ = [
    "Inlet",
    "LSLUnavailable",
    "Outlet",
    "OutletSpec",
    "Selector",
    "SELECTOR_KEYS",
    "StreamDescription",
    "StreamLost",
    "Transport",
]

SELECTOR_KEYS = ("name", "type", "source_id")


class LSLUnavailable(ImportError):
    """``pylsl`` or its liblsl cannot be loaded (the message says what to do)."""


class StreamLost(Exception):
    """The outlet an inlet reads from is gone."""


@dataclass(frozen=True)
class StreamDescription:
    """A stream found on the network.

    Attributes
    ----------
    name, type, source_id : str
        As its outlet declares them.
    uid : str
        Unique to one outlet: a restarted outlet has a new one.
    host : str
    rate : float
        Nominal rate in Hz; 0 for an irregular stream (markers).
    labels, units : tuple of str, length n_channels
        Its channels' labels and units ('' where the outlet does not say).
    format : str
        ``float32``, ``double64``, ``int16``..., or ``string`` (a marker stream).
    """

    name: str
    type: str
    source_id: str
    uid: str
    host: str
    rate: float
    labels: tuple[str, ...]
    units: tuple[str, ...]
    format: str

    @property
    def n_channels(self) -> int:
        return len(self.labels)

    @property
    def is_markers(self) -> bool:
        return self.format == "string"

    def summary(self) -> str:
        """``MocapHand (Mocap, 100 Hz, 3 channels, source vicon-1, on lab-pc)``."""
        rate = "irregular" if self.rate <= 0 else f"{self.rate:g} Hz"
        kind = "markers" if self.is_markers else f"{self.n_channels} channels"
        source = f", source {self.source_id}" if self.source_id else ""
        return f"{self.name} ({self.type or 'no type'}, {rate}, {kind}{source}, on {self.host})"


@dataclass(frozen=True)
class Selector:
    """Which stream: ``key`` one of :data:`SELECTOR_KEYS`, ``value`` what it must equal."""

    key: str
    value: str

    @classmethod
    def parse(cls, text: str) -> Selector:
        """``"MocapHand"`` (a name), ``"type=Mocap"`` or ``"source_id=vicon-1"``.

        Raises
        ------
        ValueError
            Empty, or an unknown key before ``=``.
        """
        text = str(text).strip()
        key, sep, value = text.partition("=")
        if not sep:
            key, value = "name", text
        key, value = key.strip(), value.strip()
        if key not in SELECTOR_KEYS:
            raise ValueError(
                f"unknown stream selector {key!r} in {text!r}: name a stream as NAME, "
                "type=TYPE or source_id=ID"
            )
        if not value:
            raise ValueError(f"no stream named in {text!r}: give NAME, type=TYPE or source_id=ID")
        return cls(key, value)

    def matches(self, stream: StreamDescription) -> bool:
        return getattr(stream, self.key) == self.value

    def __str__(self) -> str:
        return self.value if self.key == "name" else f"{self.key}={self.value}"


class Inlet(Protocol):
    """An open inlet: samples on the session's clock."""

    description: StreamDescription

    def pull(self) -> tuple[np.ndarray, np.ndarray | list[str]]:
        """The samples waiting: times (n,) on the session's clock (the sender's stamps plus
        the transport's clock correction, :meth:`offset`) and values (n, n_channels), or
        the labels of a marker stream. Never blocks.

        Raises
        ------
        StreamLost
            The outlet is gone.
        """

    def offset(self) -> float:
        """The clock correction added to the sender's stamps (seconds)."""

    def close(self) -> None: ...


class Outlet(Protocol):
    """An open outlet."""

    def push(self, rows: np.ndarray | Sequence[str], stamp: float) -> None:
        """Push ``rows`` (k, n_channels), or strings, all stamped ``stamp`` (the session's
        clock), sent at once."""

    def close(self) -> None: ...


@dataclass(frozen=True)
class OutletSpec:
    """An outlet to open: its name, type, source id, channels (labels and units), nominal
    rate (0: irregular) and format (``double64`` or ``string``)."""

    name: str
    type: str
    source_id: str
    labels: tuple[str, ...]
    units: tuple[str, ...]
    rate: float = 0.0
    format: str = "double64"


class Transport(Protocol):
    """Finds streams, opens inlets and outlets, tells the time."""

    def clock(self) -> float:
        """Seconds on the session's clock (LSL's ``local_clock``)."""

    def find(self, wait: float) -> list[StreamDescription]:
        """The streams visible now, looking for up to ``wait`` seconds."""

    def open(self, stream: StreamDescription) -> Inlet:
        """An inlet of ``stream`` (may block briefly for its first clock correction)."""

    def outlet(self, spec: OutletSpec) -> Outlet: ...
