"""The Record button as a pure state machine: idle, counting down, recording.

One button (Record, then Cancel during the countdown, then Stop) and the passing of time are
its only inputs: :meth:`RecordingMachine.press` and :meth:`RecordingMachine.tick` (the clock is
the caller's), plus :meth:`RecordingMachine.fail` when the recorder breaks. Each returns what
happened (an :class:`Event`) and the take it concerns; the Teach tab's Record section
(:mod:`app.panels.teach.record`) starts and stops the recorder and the display accordingly.
No viser, no threads: tested without a browser.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from app.live.recorder import unrecordable
from promp.data import Layout
from robots.icub.layout import HEAD

COUNTDOWN_S = 3.0
MAX_COUNTDOWN_S = 10.0
RATE_RANGE_HZ = (10.0, 100.0)
HEAD_FAILED = "The head source failed"


class Phase(Enum):
    IDLE = "idle"
    COUNTDOWN = "countdown"
    RECORDING = "recording"


class Event(Enum):
    NONE = "none"  # nothing happened
    REFUSED = "refused"  # a press that cannot start a recording (see refusal())
    COUNTDOWN = "countdown"  # the countdown started
    CANCELLED = "cancelled"  # pressed during the countdown
    STARTED = "started"  # the countdown ended: sample from now on
    STOPPED = "stopped"  # pressed while recording, or the recorder failed: save what it has


@dataclass(frozen=True)
class Take:
    """One recording: into ``primitive``, sampled at ``rate_hz``, starting at ``starts_at``
    (the caller's clock, seconds) once the countdown is over."""

    primitive: str
    starts_at: float
    rate_hz: float


def refusal(
    primitive: str | None, layout: Layout, head_error: str | None, rate_hz: float
) -> str | None:
    """Why a recording cannot start (None when it can): no primitive, a workspace of
    modalities the studio cannot record, a failed head source when the head is recorded, or a
    rate outside :data:`RATE_RANGE_HZ`."""
    missing = unrecordable(layout)
    if primitive is None:
        return "Create a primitive first: a demonstration belongs to one."
    if missing:
        return (
            f"This workspace's demonstrations also hold {', '.join(missing)}, which the "
            "studio cannot record: a new demonstration would lack them. Record in a "
            "workspace of hand and head demonstrations."
        )
    if HEAD.name in layout.names and head_error is not None:
        return (
            f"{HEAD_FAILED} ({head_error}). Choose another head source (e.g. the simulated "
            "partner) to record."
        )
    low, high = RATE_RANGE_HZ
    if not low <= rate_hz <= high:
        return f"The rate must be within {low:g}-{high:g} Hz, got {rate_hz:g}."
    return None


def checked_countdown(seconds: float) -> float:
    """``seconds`` as a countdown, or a ValueError when it is not a finite time >= 0."""
    seconds = float(seconds)
    if not math.isfinite(seconds) or seconds < 0:
        raise ValueError(f"the countdown must be >= 0 s, got {seconds}")
    return seconds


class RecordingMachine:
    """The states of the Record button (see the module docstring).

    Parameters
    ----------
    countdown_s : float
        Seconds between Record and the first sample, >= 0.
    """

    def __init__(self, countdown_s: float = COUNTDOWN_S):
        self.countdown_s = checked_countdown(countdown_s)
        self.phase = Phase.IDLE
        self.take: Take | None = None

    def press(
        self,
        now: float,
        primitive: str | None = None,
        rate_hz: float = 0.0,
        refused: str | None = None,
        countdown_s: float | None = None,
    ) -> tuple[Event, Take | None]:
        """The button was pressed at ``now``. When idle, a recording into ``primitive`` at
        ``rate_hz`` counts down for ``countdown_s`` seconds (default: the machine's), unless
        ``refused`` says why not (see :func:`refusal`)."""
        if self.phase is Phase.IDLE:
            if refused is not None:
                return Event.REFUSED, None
            if primitive is None:
                raise ValueError("a recording needs a primitive")
            countdown = self.countdown_s if countdown_s is None else checked_countdown(countdown_s)
            self.take = Take(primitive, now + countdown, float(rate_hz))
            self.phase = Phase.COUNTDOWN
            return Event.COUNTDOWN, self.take
        event = Event.CANCELLED if self.phase is Phase.COUNTDOWN else Event.STOPPED
        take, self.phase, self.take = self.take, Phase.IDLE, None
        return event, take

    def tick(self, now: float) -> tuple[Event, Take | None]:
        """Time passed: the countdown ends at the take's ``starts_at``."""
        if self.phase is Phase.COUNTDOWN and now >= self.take.starts_at:
            self.phase = Phase.RECORDING
            return Event.STARTED, self.take
        return Event.NONE, self.take

    def fail(self) -> tuple[Event, Take | None]:
        """The recorder stopped by itself (its sampler failed): the take ends."""
        if self.phase is not Phase.RECORDING:
            return Event.NONE, None
        take, self.phase, self.take = self.take, Phase.IDLE, None
        return Event.STOPPED, take

    def remaining(self, now: float) -> int:
        """The countdown's digit: whole seconds left, rounded up (0 when not counting)."""
        if self.phase is not Phase.COUNTDOWN:
            return 0
        return max(0, math.ceil(self.take.starts_at - now))
