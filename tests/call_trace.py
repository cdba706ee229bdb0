"""The calls a running studio makes, recorded: which functions of ours each thread enters, in
order, while a trace is on.

A profile function (``sys.setprofile``; ``threading.setprofile`` for threads started later)
sees every Python call; :class:`CallTrace` keeps those into the repository's own code (app/,
promp/, robots/) made between :meth:`CallTrace.on` and :meth:`CallTrace.off`, with the thread
that made them. Python 3.11 cannot give a profile function to a thread already running, so a
trace is installed before the studio it watches starts (:meth:`CallTrace.install`), and is
idle (one flag test per call) until it is switched on. A call to a function of
:meth:`CallTrace.watch` also keeps its stack: the functions of ours it was called through, from
its thread's first.
"""

from __future__ import annotations

import sys
import threading
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
OURS = tuple(f"{REPO / package}/" for package in ("app", "promp", "robots"))


@dataclass(frozen=True)
class Call:
    """One call: the thread that made it, the file (relative to the repository) and the
    function's qualified name (``Class.method``); for a watched function, ``stack``: the
    functions of ours it was called through, (file, name) from its thread's first."""

    thread: str
    path: str
    name: str
    stack: tuple[tuple[str, str], ...] = ()


class CallTrace:
    """Calls into our code while on (see the module docstring)."""

    def __init__(self) -> None:
        self.calls: list[Call] = []
        self._on = False
        self._watched: set[tuple[str, str]] = set()
        self._lock = threading.Lock()

    def _profile(self, frame, event, arg) -> None:
        if not self._on or event != "call":
            return
        filename = frame.f_code.co_filename
        if not filename.startswith(OURS):
            return
        path, name = filename[len(str(REPO)) + 1 :], frame.f_code.co_qualname
        stack = _stack(frame.f_back) if (path, name) in self._watched else ()
        call = Call(threading.current_thread().name, path, name, stack)
        with self._lock:
            self.calls.append(call)

    def install(self) -> None:
        """Watch this thread and every thread started from now on (idle until :meth:`on`)."""
        threading.setprofile(self._profile)
        sys.setprofile(self._profile)

    def uninstall(self) -> None:
        threading.setprofile(None)
        sys.setprofile(None)

    def watch(self, functions: set[tuple[str, str]]) -> None:
        """Keep the stack of every call to ``functions`` ((file, qualified name))."""
        self._watched = set(functions)

    def on(self) -> None:
        with self._lock:
            self.calls = []
        self._on = True

    def off(self) -> list[Call]:
        """Stop recording; the calls recorded since :meth:`on`."""
        self._on = False
        with self._lock:
            return list(self.calls)


def first_calls(calls: list[Call]) -> list[Call]:
    """``calls`` without repeats: each function once, where it was first entered."""
    seen: set[tuple[str, str]] = set()
    out = []
    for call in calls:
        if (call.path, call.name) not in seen:
            seen.add((call.path, call.name))
            out.append(call)
    return out


def _stack(frame) -> tuple[tuple[str, str], ...]:
    """The functions of ours on the stack from ``frame`` out, (file, name) outermost first."""
    out = []
    while frame is not None:
        filename = frame.f_code.co_filename
        if filename.startswith(OURS):
            out.append((filename[len(str(REPO)) + 1 :], frame.f_code.co_qualname))
        frame = frame.f_back
    return tuple(reversed(out))
