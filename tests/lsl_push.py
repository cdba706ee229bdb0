"""A sender on real LSL (the loopback, tests/lsl_loopback.cfg) for the live tests: an outlet
of the hand in millimetres, and the loop that pushes recorded rows through it as they come due.
Import it after ``pytest.importorskip("pylsl")``.

The tests' outlets and inlets live in the process of the sessions and studios they test, so
they are made, opened and destroyed under :data:`promp.live.lsl.LIFECYCLE` (liblsl crashes
when an outlet dies while another thread opens an inlet: the module docstring of
:mod:`promp.live.lsl`): by :func:`outlet`, :func:`inlet` and :func:`release`, and whatever a
test left is released when it ends (``tests/conftest.py``), never by the garbage collector."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
import pylsl

from promp.live.lsl import new_outlet, open_inlet, release

__all__ = ["hand_outlet", "inlet", "open_inlet", "outlet", "push_when_due", "release",
           "release_all"]
MADE: list[pylsl.StreamOutlet | pylsl.StreamInlet] = []  # what the test under way made


def outlet(info: pylsl.StreamInfo) -> pylsl.StreamOutlet:
    """An outlet of ``info``, released at the latest when the test ends."""
    MADE.append(new_outlet(info))
    return MADE[-1]


def inlet(info: pylsl.StreamInfo, timeout: float, **options) -> pylsl.StreamInlet:
    """An inlet of ``info``, its stream opened (within ``timeout`` s), released at the latest
    when the test ends: for the test's own thread (a reader thread opens its inlet with
    :func:`open_inlet` and releases it when it stops: never while it pulls)."""
    MADE.append(open_inlet(info, timeout, **options))
    return MADE[-1]


def release_all() -> None:
    """Release every outlet and inlet the test made (the last made first)."""
    while MADE:
        release(MADE.pop())


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
    return outlet(info)


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
