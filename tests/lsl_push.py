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

    Rows due at the same time (a late sender's backlog) are pushed at once, in one chunk with
    their stamps, as a sender pushing its backlog does. One at a time, a sender in the
    session's own process waits for its threads (Python's lock) between rows, on a busy
    machine for longer than :data:`promp.live.restamp.QUIET_S`: the backlog then arrives in
    parts, which no sender pushing it at once does (a test failed that way, once in a busy
    run: its movement ended by an "input paused" instead of stillness).

    Returns
    -------
    pushed : array, shape (n,)
        When each row was pushed, s on LSL's clock.
    """
    due = np.asarray(due, dtype=float)
    pushed = np.empty(len(due))
    i = 0
    while i < len(due):
        j = i + 1
        if stamps is not None:  # the rows due with row i
            while j < len(due) and due[j] == due[i]:
                j += 1
        time.sleep(max(0.0, due[i] - pylsl.local_clock()))
        if stamps is None:
            outlet.push_sample(np.asarray(rows[i]).tolist())
        elif j == i + 1:
            outlet.push_sample(np.asarray(rows[i]).tolist(), stamps[i])
        else:
            outlet.push_chunk(np.asarray(rows[i:j]), [float(t) for t in stamps[i:j]])
        pushed[i:j] = pylsl.local_clock()
        i = j
    return pushed
