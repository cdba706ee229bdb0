"""What a live session shows: an immutable :class:`LiveSnapshot`, made from a bounded record.

The session's runner adds each step's outputs to its :class:`SessionRecord` (the latest
:data:`EVENTS_KEPT` events, ended movements and recorded ones, the predictions counted, the
inference times) and publishes a new :class:`LiveSnapshot` after each step that changed
something; the studio's loop and the headless command read the latest one without a lock.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

from promp.live.predictor import LivePrediction
from promp.live.recorder import Recorded
from promp.live.segmenter import Boundary, Movement
from promp.live.sinks import SinkState
from promp.live.status import LiveEvent, StreamStatus
from promp.live.transport import StreamDescription

__all__ = ["EVENTS_KEPT", "LiveSnapshot", "SessionRecord", "TIMES_KEPT"]

EVENTS_KEPT = 50
TIMES_KEPT = 100_000  # inference times kept (the headless command's percentiles)


@dataclass(frozen=True, eq=False)
class LiveSnapshot:
    """The session at one moment (immutable; a new one after each step that changed it).

    Attributes
    ----------
    version : int
    time : float
        The session's clock when it was taken.
    found : tuple of StreamDescription
        The streams on the network at the last look (names, rates, channel counts).
    statuses : tuple of StreamStatus
        Each input's (and the marker stream's).
    movement : Movement or None
        The movement going on.
    prediction : LivePrediction or None
        The latest (of the movement going on, or of the last one).
    events : tuple of LiveEvent
        The latest :data:`EVENTS_KEPT`.
    n_events : int
        The events so far (the last of them are ``events``).
    ended : tuple of Movement
        The movements that ended, latest last (at most :data:`EVENTS_KEPT`).
    recorded : tuple of Recorded
        With a recorder, the movements it recorded (latest last, at most
        :data:`EVENTS_KEPT`): each one's demonstration, for a take.
    predictions : int
        Made so far (each offered to the sinks).
    counts : dict of str to (int, int)
        Per input: samples received, samples left out.
    sinks : tuple of SinkState
        Each sink's deliveries, failures and drops (:mod:`promp.live.sinks`).
    """

    version: int
    time: float
    found: tuple[StreamDescription, ...]
    statuses: tuple[StreamStatus, ...]
    movement: Movement | None
    prediction: LivePrediction | None
    events: tuple[LiveEvent, ...]
    n_events: int
    ended: tuple[Movement, ...]
    recorded: tuple[Recorded, ...]
    predictions: int
    counts: dict[str, tuple[int, int]]
    sinks: tuple[SinkState, ...] = ()


class SessionRecord:
    """What a session keeps of its outputs, bounded (see the module docstring)."""

    def __init__(self) -> None:
        self.events: deque[LiveEvent] = deque(maxlen=EVENTS_KEPT)
        self.ended: deque[Movement] = deque(maxlen=EVENTS_KEPT)
        self.recorded: deque[Recorded] = deque(maxlen=EVENTS_KEPT)
        self.compute_s: deque[float] = deque(maxlen=TIMES_KEPT)
        self.n_events = 0
        self.predictions = 0
        self.prediction: LivePrediction | None = None
        self.version = 0

    def add(self, events: Sequence[LiveEvent], boundaries: Sequence[Boundary],
            predictions: Sequence[LivePrediction], recorded: Sequence[Recorded]) -> None:
        """One step's outputs (and what the recorder returned since the last step)."""
        self.events.extend(events)
        self.n_events += len(events)
        self.ended.extend(b.movement for b in boundaries if b.movement is not None)
        self.recorded.extend(recorded)
        self.predictions += len(predictions)
        self.compute_s.extend(p.compute_s for p in predictions)
        if predictions:
            self.prediction = predictions[-1]

    def snapshot(self, time: float, found: tuple[StreamDescription, ...],
                 statuses: tuple[StreamStatus, ...], movement: Movement | None,
                 counts: dict[str, tuple[int, int]], sinks: tuple[SinkState, ...]
                 ) -> LiveSnapshot:  # fmt: skip
        self.version += 1
        return LiveSnapshot(self.version, time, found, statuses, movement, self.prediction,
                            tuple(self.events), self.n_events, tuple(self.ended),
                            tuple(self.recorded), self.predictions, counts, sinks)  # fmt: skip
