"""The streams on the network as the studio lists them (:class:`StreamWatch`), for
:class:`app.live.lsl_source.LslSource`: a look every :data:`SCAN_EVERY_S` while no session runs
(a running session looks for its own, and its list is shown), and the channels' labels and
units of each new stream, read from an inlet opened once for that.

The two are separate threads, and the list never waits for a description: an inlet of a stream
gone between the look and the open (another program's, coming and going) takes seconds to give
up, and a look that described each new stream before publishing left a new one (a marker
stream started meanwhile) out of the list for minutes.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from promp.live.transport import StreamDescription, Transport

__all__ = ["SCAN_EVERY_S", "StreamWatch"]

SCAN_EVERY_S = 0.5


class StreamWatch:
    """The streams found, described once each.

    Parameters
    ----------
    session_found : callable
        The running session's list of streams, or None while none runs (then this looks
        itself).
    """

    def __init__(self, session_found: Callable[[], tuple[StreamDescription, ...] | None]):
        self._session_found = session_found
        self._found: tuple[StreamDescription, ...] = ()
        self._described: dict[str, StreamDescription] = {}  # by uid: with labels and units
        self._stop = threading.Event()
        self._threads: tuple[threading.Thread, ...] = ()

    def start(self, transport: Transport) -> None:
        """Look and describe from now on (idempotent)."""
        if self._threads:
            return
        self._threads = tuple(
            threading.Thread(target=work, args=(transport,), name=name, daemon=True)
            for work, name in ((self._look, "lsl-scan"), (self._describe, "lsl-describe"))
        )
        for thread in self._threads:
            thread.start()

    def found(self) -> tuple[StreamDescription, ...]:
        """The streams at the latest look (the session's, while it runs), with their channels'
        labels and units once read."""
        return tuple(self._described.get(s.uid, s) for s in self._listed())

    def hand_over(self, found: tuple[StreamDescription, ...]) -> None:
        """A session stopped: its last list stands until the next look."""
        self._found = found

    def close(self) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=5.0)

    def _listed(self) -> tuple[StreamDescription, ...]:
        found = self._session_found()
        return self._found if found is None else found

    def _look(self, transport: Transport) -> None:
        while not self._stop.is_set():
            if self._session_found() is None:
                try:
                    self._found = tuple(transport.find(SCAN_EVERY_S))
                except Exception:  # noqa: BLE001 (the network, not us: look again)
                    self._found = ()
            self._stop.wait(SCAN_EVERY_S)

    def _describe(self, transport: Transport) -> None:
        """Every stream listed and not described yet, one inlet each, in the latest list (a
        stream gone meanwhile is not waited for)."""
        while not self._stop.is_set():
            for stream in self._listed():
                if self._stop.is_set():
                    return
                if stream.uid not in self._described:
                    self._described[stream.uid] = described(transport, stream)
            self._stop.wait(SCAN_EVERY_S)


def described(transport: Transport, stream: StreamDescription) -> StreamDescription:
    """``stream`` with its channels' labels and units, read from an inlet opened for that
    (as found when the stream vanished or does not answer)."""
    if stream.is_markers or any(stream.labels):
        return stream
    try:
        inlet = transport.open(stream)
    except Exception:  # noqa: BLE001 (gone, or not answering: listed as found)
        return stream
    try:
        return inlet.description
    except Exception:  # noqa: BLE001 (as above)
        return stream
    finally:
        inlet.close()
