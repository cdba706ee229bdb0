"""The partner's head as the studio sees it: the head source in use and its latest reading.

The Teach tab's *Head source* chooses the source (:meth:`HeadInput.use`, from any thread); the
studio's loop reads it once per iteration (:meth:`HeadInput.read`); the recorder, the live
stream and the partner's avatar take :attr:`HeadInput.angles`, that latest reading.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from app.head_sources import HeadReading, HeadSource


class HeadInput:
    """The current head source and its latest reading (see the module docstring)."""

    def __init__(self, source: HeadSource):
        self._lock = threading.Lock()
        self._source = source
        self.reading = HeadReading(time.monotonic(), None)

    @property
    def source(self) -> HeadSource:
        return self._source

    @property
    def angles(self) -> np.ndarray | None:
        """Roll, pitch, yaw (rad) of the latest reading, None when it saw no face."""
        return self.reading.angles

    def use(self, source: HeadSource) -> None:
        """Read the head from ``source`` from now on; the previous one is closed."""
        with self._lock:
            old, self._source = self._source, source
        if old is not source:
            old.close()

    def read(self, hand_position: np.ndarray) -> HeadReading:
        """Read the source (the simulated partner looks where the hand goes)."""
        with self._lock:
            source = self._source
        self.reading = source.read(hand_position)
        return self.reading

    def close(self) -> None:
        self._source.close()
