"""What the studio hangs on a live session's outputs, besides the recognition chart's curves
(:mod:`app.live.live_curve`): the outlets publishing its predictions, switched on and off while
it runs (:class:`SwitchedOutlets`), and the wake-up of the studio's loop at a commitment
(:class:`CommitmentWake`)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from promp.live.predictor import LivePrediction
from promp.live.status import LiveEvent

__all__ = ["COMMIT_WAKE_WAIT_S", "CommitmentWake", "SwitchedOutlets"]

COMMIT_WAKE_WAIT_S = 0.02  # the longest a commitment's wake-up waits for the snapshot


class CommitmentWake:
    """The session's prediction callback (a sink's thread): the prediction that committed,
    once the session's snapshot holds it (the sinks are offered a step's outputs just before
    its snapshot is published), calls ``call()``: the studio wakes its loop, so the arm's
    take-over waits for no frame period.

    Parameters
    ----------
    running : callable
        The source's :class:`app.live.lsl_source.Running` session now (None: stopped).
    """

    def __init__(self, running: Callable[[], object]) -> None:
        self.running = running
        self.call: Callable[[], object] | None = None

    def __call__(self, prediction: LivePrediction) -> None:
        made, call = prediction.committed, self.call
        if made is None or made.at != prediction.last or call is None:
            return
        deadline = time.monotonic() + COMMIT_WAKE_WAIT_S
        while (running := self.running()) is not None and time.monotonic() < deadline:
            shown = running.session.snapshot().prediction
            if shown is not None and shown.seq >= prediction.seq:
                break
            time.sleep(0.0002)
        call()


class SwitchedOutlets:
    """The session's outlets sink, switched on and off while it runs (another thread may be
    publishing meanwhile: a lock keeps each push whole)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._outlets = None
        self.names: tuple[str, ...] = ()
        self.source_ids: tuple[str, ...] = ()

    def set(self, outlets) -> None:
        """Publish through ``outlets`` (a :class:`promp.live.outlets.PredictionOutlets`), or
        nothing (None); the previous ones are closed (their streams vanish)."""
        with self._lock:
            old, self._outlets = self._outlets, outlets
            self.names = tuple(s.name for s in outlets.specs.values()) if outlets else ()
            self.source_ids = outlets.source_ids if outlets else ()
        if old is not None:
            old.close()

    def publish(self, prediction: LivePrediction) -> None:
        with self._lock:
            if self._outlets is not None:
                self._outlets.publish(prediction)

    def event(self, event: LiveEvent) -> None:
        with self._lock:
            if self._outlets is not None:
                self._outlets.event(event)

    def close(self) -> None:
        self.set(None)
