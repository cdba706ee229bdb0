"""Progress a person can plan around: done / total, the time elapsed and an estimate of the
time left, for every long task (a leave-one-out sweep, a dataset import, a fit), in the studio
and on the command line (:func:`stderr_progress`).

The estimate assumes the remaining steps take as long as those done did on average: a
leave-one-out fold or a file read costs about the same as the next one.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import TextIO

__all__ = ["Progress", "clock", "progress_text", "stderr_progress", "time_left"]

Progress = Callable[[int, int], None]


def time_left(done: int, total: int, elapsed_s: float) -> float | None:
    """Seconds left at the average pace so far; None before the first step is done (nothing
    to go by), 0 once every step is.

    Raises
    ------
    ValueError
        ``done`` outside [0, ``total``], or a negative or non-finite ``elapsed_s``.
    """
    if total < 0 or not 0 <= done <= total:
        raise ValueError(f"done must be in [0, total], got {done} of {total}")
    if not math.isfinite(elapsed_s) or elapsed_s < 0:
        raise ValueError(f"elapsed time must be a finite number of seconds >= 0, got {elapsed_s}")
    if done == total:
        return 0.0
    if done == 0:
        return None
    return elapsed_s / done * (total - done)


def clock(seconds: float) -> str:
    """``"0:35"``, ``"12:05"``, ``"1:02:03"`` (whole seconds, rounded up: "about 0:01 left"
    rather than "0:00" while a step still runs)."""
    whole = max(0, math.ceil(seconds - 1e-9))
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


def progress_text(done: int, total: int, elapsed_s: float, unit: str = "",
                  pace_s: float | None = None) -> str:  # fmt: skip
    """``"12 / 40 trials · 0:35 elapsed · about 1:10 left"`` (see :func:`time_left`); the
    time left from the ``done`` steps' own time ``pace_s`` when the elapsed time includes an
    earlier stage's (default: ``elapsed_s``)."""
    counted = f"{done} / {total}" + (f" {unit}" if unit else "")
    left = time_left(done, total, elapsed_s if pace_s is None else pace_s)
    if done == total:
        return f"{counted} · {clock(elapsed_s)} elapsed"
    estimate = "estimating the time left" if left is None else f"about {clock(left)} left"
    return f"{counted} · {clock(elapsed_s)} elapsed · {estimate}"


def stderr_progress(label: str, unit: str = "", stream: TextIO | None = None,
                    every_s: float = 2.0) -> Progress:  # fmt: skip
    """A ``progress(done, total)`` printing ``label: <progress_text>`` on stderr: on one line
    rewritten in place on a terminal, else a line at most every ``every_s`` seconds (a log
    stays short), and always the last."""
    start = time.monotonic()
    printed = -math.inf

    def report(done: int, total: int) -> None:
        nonlocal printed
        out = sys.stderr if stream is None else stream
        now = time.monotonic()
        last = done >= total
        tty = getattr(out, "isatty", lambda: False)()
        if not (tty or last or now - printed >= every_s):
            return
        printed = now
        text = f"{label}: {progress_text(done, total, now - start, unit)}"
        out.write(f"\r{text}\033[K" + ("\n" if last else "") if tty else text + "\n")
        out.flush()

    return report
