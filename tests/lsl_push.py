"""A sender on real LSL (the loopback, tests/lsl_loopback.cfg) for the live tests: an outlet
of the hand in millimetres, and the loop that pushes recorded rows through it as they come due.
Import it after ``pytest.importorskip("pylsl")``."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
import pylsl


def hand_outlet(name: str, labels: Sequence[str] = ("hx", "hy", "hz"),
                rate: float = 100.0) -> pylsl.StreamOutlet:  # fmt: skip
    """An outlet ``name`` (type Mocap, source ``src-NAME``) of the hand: one channel per label,
    in mm, ``rate`` Hz declared."""
    info = pylsl.StreamInfo(name, "Mocap", len(labels), rate, pylsl.cf_double64, f"src-{name}")
    channels = info.desc().append_child("channels")
    for label in labels:
        channel = channels.append_child("channel")
        channel.append_child_value("label", label)
        channel.append_child_value("unit", "mm")
    return pylsl.StreamOutlet(info)


def push_when_due(outlet: pylsl.StreamOutlet, rows: np.ndarray, due: np.ndarray,
                  stamps: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """Push ``rows`` (n, k) through ``outlet``, row ``i`` once LSL's clock reaches ``due[i]``
    (s, :func:`pylsl.local_clock`; a sender woken late pushes what it owes at once), stamped
    ``stamps[i]`` (s), or at its push (LSL's default) when ``stamps`` is None.

    Returns
    -------
    pushed : array, shape (n,)
        When each row was pushed, s on LSL's clock.
    """
    pushed = np.empty(len(due))
    for i in range(len(due)):
        time.sleep(max(0.0, due[i] - pylsl.local_clock()))
        if stamps is None:
            outlet.push_sample(np.asarray(rows[i]).tolist())
        else:
            outlet.push_sample(np.asarray(rows[i]).tolist(), stamps[i])
        pushed[i] = pylsl.local_clock()
    return pushed
