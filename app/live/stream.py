"""The live stream the Infer tab observes: (t, hand, head) samples taken at every loop
iteration since "Start observing", and the early observation of them a scrub step needs."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from promp.data import Layout
from promp.inference import Observation
from promp.timing import n_observed_for
from robots.icub.layout import HAND, HEAD


class LiveBuffer:
    """Samples of the live stream since "Start observing": (t, hand (3,), head (3,) or NaN).

    Bounded (``max_seconds``): :meth:`append` returns False once full.
    """

    def __init__(self, max_seconds: float = 30.0):
        self.max_seconds = max_seconds
        self._t: list[float] = []
        self._hand: list[np.ndarray] = []
        self._head: list[np.ndarray] = []

    def __len__(self) -> int:
        return len(self._t)

    def clear(self) -> None:
        self._t.clear()
        self._hand.clear()
        self._head.clear()

    @property
    def duration(self) -> float:
        return self._t[-1] - self._t[0] if self._t else 0.0

    def append(self, t: float, hand: np.ndarray, head: np.ndarray | None) -> bool:
        """Add a sample taken at monotonic time ``t``; samples not after the last are ignored.
        False when the buffer is full (nothing added)."""
        if self._t and t - self._t[0] > self.max_seconds:
            return False
        if self._t and t <= self._t[-1]:
            return True
        self._t.append(float(t))
        self._hand.append(np.array(hand, dtype=float).reshape(3))
        self._head.append(
            np.full(3, np.nan) if head is None else np.array(head, dtype=float).reshape(3)
        )
        return True

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times (n,) from 0, hand (n, 3), head (n, 3) with NaN rows where there was no face."""
        if not self._t:
            return np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3))
        t = np.array(self._t)
        return t - t[0], np.array(self._hand), np.array(self._head)

    def observation(
        self, percent: float, modalities: Sequence[str], layout: Layout
    ) -> Observation:
        """The first ``ceil(percent / 100 * n)`` samples of the buffer in ``modalities`` (of
        ``layout``); samples without a face are dropped when the head is observed.

        Raises
        ------
        ValueError
            If there is nothing (usable) to observe yet.
        """
        times, hand, head = self.arrays()
        if times.shape[0] == 0:
            raise ValueError("nothing observed yet: press Start observing and move the hand")
        n_o = n_observed_for(percent, times.shape[0])
        times, hand, head = times[:n_o], hand[:n_o], head[:n_o]
        columns = []
        keep = np.ones(n_o, dtype=bool)
        for name in layout.names:
            if name not in modalities:
                continue
            if name == HAND.name:
                columns.append(hand)
            elif name == HEAD.name:
                columns.append(head)
                keep &= np.all(np.isfinite(head), axis=1)
            else:
                raise ValueError(f"the live stream has no modality {name!r}")
        if not columns:
            raise ValueError("choose at least one observed modality")
        if not keep.any():
            raise ValueError("no face seen yet: the head cannot be observed")
        values = np.hstack(columns)[keep]
        kept = times[keep]
        return Observation(
            kept - kept[0], values, tuple(m for m in layout.names if m in modalities)
        )
