"""The live stream the Infer tab observes: the hand and the partner's head, sampled at every loop
iteration between "Start observing" and "Stop observing".

:class:`LiveStream` is a two-state controller (idle, observing) over a bounded buffer; what it
holds is read as one immutable :class:`StreamSamples` (the same object until a sample is added
or the stream is cleared), from which an inference takes its early observation: a computation
and the test that checks it see the same samples.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from promp.data import Layout
from promp.inference import Observation
from robots.icub.layout import HAND, HEAD

MAX_SECONDS = 30.0
SHOWN_HZ = 20.0  # the samples an inference observes are taken at most this often


@dataclass(frozen=True, eq=False)
class StreamSamples:
    """The samples of the live stream at one moment.

    Attributes
    ----------
    times : array, shape (n,)
        Seconds from the first sample.
    hand : array, shape (n, 3)
    head : array, shape (n, 3)
        NaN rows where there was no face.
    epoch : int
        Counts the stream's starts and clears: samples of one epoch are one movement.
    """

    times: np.ndarray
    hand: np.ndarray
    head: np.ndarray
    epoch: int = 0

    def __len__(self) -> int:
        return int(self.times.shape[0])

    def observation(
        self, percent: float, modalities: Sequence[str], layout: Layout
    ) -> Observation:
        """The first ``ceil(percent / 100 * n)`` samples in ``modalities`` (of ``layout``);
        samples without a face are dropped when the head is observed
        (:meth:`promp.inference.Observation.first_live`).

        Raises
        ------
        ValueError
            If there is nothing (usable) to observe yet.
        """
        if len(self) == 0:
            raise ValueError("nothing observed yet: press Start observing and move the hand")
        columns = {HAND.name: self.hand, HEAD.name: self.head}
        names = tuple(m for m in layout.names if m in modalities)
        unknown = [m for m in names if m not in columns]
        if unknown:
            raise ValueError(f"the live stream has no modality {unknown[0]!r}")
        if not names:
            raise ValueError("choose at least one observed modality")
        if HEAD.name in names and not np.all(np.isfinite(self.head), axis=1).any():
            raise ValueError("no face seen yet: the head cannot be observed")
        values = np.hstack([columns[m] for m in names])
        return Observation.first_live(self.times, values, percent, names)


EMPTY = StreamSamples(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)))


class LiveStream:
    """Idle or observing; the samples since the last start or clear (see the module docstring).

    Bounded (``max_seconds``): :meth:`append` stops observing once the buffer is full.
    ``clock``: the samples' time stamps, monotonic seconds (tests drive a manual one).
    """

    def __init__(
        self, max_seconds: float = MAX_SECONDS, clock: Callable[[], float] = time.monotonic
    ):
        self.max_seconds = max_seconds
        self.clock = clock
        self.observing = False
        self._rows: list[tuple[float, np.ndarray, np.ndarray]] = []
        self._epoch = 0
        self._samples: StreamSamples | None = EMPTY
        self._shown: tuple[float, StreamSamples] | None = None  # the latest shown, and when

    def start(self) -> None:
        """Observe from an empty buffer."""
        self.clear()
        self.observing = True

    def stop(self) -> None:
        """Stop observing (the samples taken stay, and are shown at once)."""
        self.observing = False
        self._shown = None

    def clear(self) -> None:
        """Forget the samples (a new movement)."""
        self._rows = []
        self._epoch += 1
        self._samples = StreamSamples(EMPTY.times, EMPTY.hand, EMPTY.head, self._epoch)
        self._shown = None

    def append(self, t: float, hand: np.ndarray, head: np.ndarray | None) -> bool:
        """Add a sample taken at monotonic time ``t`` (one not after the last is ignored).
        False when the buffer is full: nothing added, and observing stops."""
        rows = self._rows
        if rows and t - rows[0][0] > self.max_seconds:
            self.observing = False
            return False
        if rows and t <= rows[-1][0]:
            return True
        head = np.full(3, np.nan) if head is None else np.array(head, dtype=float).reshape(3)
        rows.append((float(t), np.array(hand, dtype=float).reshape(3), head))
        self._samples = None  # made again when asked for
        return True

    def samples(self) -> StreamSamples:
        """What the stream holds now (the same object until it changes)."""
        if self._samples is None:
            t = np.array([row[0] for row in self._rows])
            self._samples = StreamSamples(
                t - t[0], np.array([row[1] for row in self._rows]),
                np.array([row[2] for row in self._rows]), self._epoch,
            )  # fmt: skip
        return self._samples

    def observe(self, hand: np.ndarray, head: np.ndarray | None) -> bool:
        """While observing, add a sample stamped by the clock now; False when the buffer
        has just become full (observing stopped)."""
        return not self.observing or self.append(self.clock(), hand, head)

    def shown(self, now: float) -> StreamSamples:
        """The samples an inference observes at ``now`` (monotonic seconds): renewed at most
        ``SHOWN_HZ`` times a second, so that a stream sampled at every frame is not inferred
        from at every frame."""
        if self._shown is None or now - self._shown[0] >= 1.0 / SHOWN_HZ:
            self._shown = (now, self.samples())
        return self._shown[1]
