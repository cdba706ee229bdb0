"""What a live input is doing, as the studio and the headless command show it.

Every input stream has one :class:`StreamStatus` at a time: its :class:`Condition`, since when
(seconds on the session's LSL clock), and a detail naming what happened. Faults never raise:
a stream that stalls, vanishes, comes back, restarts, changes rate, sends NaNs or the wrong
number of channels, or whose clock jumps, changes its status and adds a :class:`LiveEvent` to
the session's history; the samples that cannot be used are counted and left out.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = ["Condition", "LiveEvent", "StreamStatus", "UNHEALTHY"]


class Condition(enum.Enum):
    """A live input's condition; ``healthy`` ones deliver usable samples."""

    WAITING = "waiting"  # not found yet
    OK = "ok"
    STALLED = "stalled"  # connected, but no sample for a while
    VANISHED = "vanished"  # its outlet is gone; looked for again
    BACK = "back"  # the same outlet again after it vanished
    RESTARTED = "restarted"  # a new outlet of the same stream after it vanished
    RATE_CHANGED = "rate changed"
    BAD_VALUES = "bad values"  # NaN or infinite samples, left out
    WRONG_CHANNELS = "wrong channels"  # not the channels the mapping names; not used
    CLOCK_JUMP = "clock jumped"  # its time stamps leapt; re-anchored

    @property
    def healthy(self) -> bool:
        return self not in UNHEALTHY


UNHEALTHY = frozenset(
    {Condition.WAITING, Condition.STALLED, Condition.VANISHED, Condition.WRONG_CHANNELS}
)


@dataclass(frozen=True)
class StreamStatus:
    """The condition of one input.

    Attributes
    ----------
    stream : str
        The input as the command line names it (``hand=MocapHand:0,1,2@mm``'s ``MocapHand``).
    condition : Condition
    since : float
        Seconds on the session's clock when the condition began.
    detail : str
        What happened, in words (the rate, the channels, the size of the jump...).
    """

    stream: str
    condition: Condition
    since: float
    detail: str = ""

    @property
    def healthy(self) -> bool:
        return self.condition.healthy

    def message(self, now: float) -> str:
        """One line: ``stream 'MocapHand': stalled for 1.2 s (no sample since ...)``."""
        ago = max(0.0, now - self.since)
        detail = f" ({self.detail})" if self.detail else ""
        return f"stream {self.stream!r}: {self.condition.value} for {ago:.1f} s{detail}"


@dataclass(frozen=True)
class LiveEvent:
    """Something that happened: a movement started or ended, a stream's condition changed.

    ``time`` in seconds on the session's clock; ``text`` one line (the events outlet's
    sample, the status line's news); ``kind`` ``"decision"`` for a commitment to a primitive
    (:mod:`promp.live.commitment`), empty for the rest."""

    time: float
    text: str
    kind: str = ""
