"""The intake: what reaches a live session from outside, gathered into one step's arrivals.

The imperative half of the source stage (:mod:`promp.live.source` is the other, pure, half):
the inlets of the streams in use, opened by a look (:meth:`Intake.look`, on the session's
resolver thread: a find blocks for a moment) and pulled each step, and the calls and notes
other threads hand in (a Record button's begin and end, a failure to say). :meth:`Intake.arrivals`
gives them to the pipeline as one :class:`promp.live.pipeline.Arrivals` (an inlet that fails
otherwise than by its stream being lost is closed all the same, and the failure said);
:meth:`Intake.settle` then closes the inlets of the streams the pipeline let go (lost, or
without the mapping's channels) and publishes what the next look is for.

A look reads only its arguments and immutable values: the feeds wanted (a tuple the pipeline's
thread publishes after each step, with the stream each one refused) and the source ids of the
session's own outputs (never read back: their events would come back as markers).
"""

from __future__ import annotations

import queue
from collections.abc import Callable, Iterable
from types import MappingProxyType

from promp.live.pipeline import Arrivals, Call
from promp.live.source import Opened, Pulled, Wanted
from promp.live.status import LiveEvent
from promp.live.transport import Inlet, StreamDescription, StreamLost, Transport

__all__ = ["Intake"]


class Intake:
    """The session's inlets, calls and notes (see the module docstring).

    Parameters
    ----------
    transport : Transport
    wanted : tuple of Wanted
        The feeds to look for at first (:meth:`promp.live.source.Source.wanted`).
    own : callable
        The source ids of the streams the session publishes, now.
    """

    def __init__(self, transport: Transport, wanted: tuple[Wanted, ...],
                 own: Callable[[], Iterable[str]] = tuple):  # fmt: skip
        self.transport = transport
        self.found: tuple[StreamDescription, ...] = ()  # at the latest look
        self._own = own
        self._wanted = wanted
        self._inlets: dict[int, Inlet] = {}  # by feed; the pipeline's thread only
        self._opened: queue.SimpleQueue = queue.SimpleQueue()
        self._calls: queue.SimpleQueue = queue.SimpleQueue()

    # ------------------------------------------------------------------ from any thread

    def call(self, kind: str, time: float, label: str = "") -> None:
        """A movement starts (``"start"``) or ends (``"end"``) at ``time``."""
        self._calls.put(Call(kind, float(time), label))

    def note(self, text: str) -> None:
        """Something the session itself says (in the next step's events)."""
        self._calls.put(LiveEvent(self.transport.clock(), text))

    def look(self, wait: float) -> None:
        """Find the streams on the network (waiting up to ``wait`` seconds) and open those of
        the feeds wanted; the next step adopts them."""
        found = tuple(self.transport.find(wait))
        self.found = found
        own = frozenset(self._own())
        opened = [entry for w in self._wanted
                  if (entry := self._open(w, found, own)) is not None]  # fmt: skip
        if opened:
            self._opened.put(opened)

    def _open(self, wanted: Wanted, streams: tuple[StreamDescription, ...],
              own: frozenset[str]) -> tuple[Opened, Inlet | None] | None:  # fmt: skip
        """The stream of ``wanted`` among ``streams``, opened, or None and why."""
        selected = [s for s in streams
                    if wanted.selector.matches(s) and s.is_markers == wanted.markers]  # fmt: skip
        matching = [s for s in selected if s.source_id not in own]
        if not matching:
            if selected:
                return Opened(wanted.feed, None, f"{selected[0].name} is this session's own "
                                                 "output, not read back"), None  # fmt: skip
            return None
        if len({s.uid for s in matching}) > 1:
            names = ", ".join(s.summary() for s in matching)
            return Opened(wanted.feed, None, f"several streams match: {names}; name one by "
                                             "source_id=ID"), None  # fmt: skip
        stream = matching[0]
        if stream.uid == wanted.refused:
            return None
        try:
            inlet = self.transport.open(stream)
        except StreamLost as exc:
            return Opened(wanted.feed, stream, str(exc)), None
        return Opened(wanted.feed, inlet.description), inlet

    # ------------------------------------------------------------------ the pipeline's thread

    def arrivals(self, now: float) -> Arrivals:
        """What arrived since the last call: the streams opened (an inlet for a feed that has
        one is closed: found twice, the first is kept), the samples of every inlet, the calls
        and the notes."""
        opened = []
        while not self._opened.empty():
            for entry, inlet in self._opened.get():
                if inlet is not None and entry.feed in self._inlets:
                    inlet.close()
                    continue
                if inlet is not None:
                    self._inlets[entry.feed] = inlet
                opened.append(entry)
        pulled, notes = {}, []
        for feed, inlet in self._inlets.items():
            try:
                times, values = inlet.pull()
            except StreamLost:
                pulled[feed] = Pulled.LOST
                continue
            except Exception as exc:  # a transport's defect: the stream is lost, not the session
                pulled[feed] = Pulled.LOST
                notes.append(LiveEvent(now, f"stream {inlet.description.name!r}: its inlet failed "
                                            f"({type(exc).__name__}: {exc}); closed"))  # fmt: skip
                continue
            pulled[feed] = Pulled(times, values, offset=float(inlet.offset()))
        calls = []
        while not self._calls.empty():
            item = self._calls.get()
            (calls if isinstance(item, Call) else notes).append(item)
        return Arrivals(now, tuple(opened), MappingProxyType(pulled), tuple(calls), tuple(notes))

    def settle(self, connected: frozenset[int], wanted: tuple[Wanted, ...]) -> None:
        """Close the inlets of the feeds the pipeline no longer reads; look for ``wanted``."""
        for feed in [f for f in self._inlets if f not in connected]:
            self._inlets.pop(feed).close()
        self._wanted = wanted

    def close(self) -> None:
        for inlet in self._inlets.values():
            inlet.close()
        self._inlets.clear()
        while not self._opened.empty():
            for _, inlet in self._opened.get():
                if inlet is not None:
                    inlet.close()
