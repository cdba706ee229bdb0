"""A recorded live session replayed in the studio: what ``python -m promp.live --replay FILE
--model M`` does, shown as a live session is.

:class:`SessionReplay` stands where a :class:`promp.live.session.LiveSession` stands in the
studio's :class:`app.live.lsl_source.Running` (the Infer tab, the robot's take-over and the
recognition chart read its :meth:`~SessionReplay.snapshot` the same way): on a thread of its
own it runs :func:`promp.live.session_file.replay_session` on the file, at the recorded timing
or as fast as it goes, and publishes a :class:`promp.live.snapshot.LiveSnapshot` after each
step, with the session's own bounded record. At the end :attr:`SessionReplay.result` says
whether every prediction equalled the recorded one, bit for bit (or the first difference).

The file is checked before anything starts (:func:`promp.live.session_file.read_session`: a
missing, cut or foreign file; :func:`promp.live.session_file.check_recorded_with`: another
model): a refusal is a ``ValueError`` and nothing runs. The file is only read.
"""

from __future__ import annotations

import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from promp.live.options import live_inputs
from promp.live.session_file import (
    Replayed,
    check_recorded_with,
    read_session,
    replay_session,
)
from promp.live.sinks import Output
from promp.live.snapshot import LiveSnapshot, SessionRecord
from promp.live.source import LiveInput
from promp.model import ProMPModel

__all__ = ["ReplayHeader", "ReplayResult", "SessionReplay", "read_header"]


class _Stopped(Exception):
    """Raised in the replay's callback to end it at Stop."""


@dataclass(frozen=True)
class ReplayHeader:
    """What a session file says of its session: its path, inputs' mappings (parsed against
    the model), start rule, commit threshold (None: no rule) and count of steps and
    predictions recorded."""

    path: Path
    inputs: tuple[LiveInput, ...]
    start: str
    commit: float | None
    steps: int
    predictions: int


@dataclass(frozen=True)
class ReplayResult:
    """How a replay ended: ``steps`` replayed, ``predictions`` made and ``recorded``, and the
    first difference ('' when every prediction equalled the recorded one bit for bit);
    ``stopped`` at Stop; ``error`` a failure's text."""

    steps: int = 0
    predictions: int = 0
    recorded: int = 0
    difference: str = ""
    stopped: bool = False
    error: str = ""

    @property
    def equal(self) -> bool:
        return not (self.difference or self.stopped or self.error)


def read_header(model: ProMPModel, path: Path | str) -> ReplayHeader:
    """The session file ``path``, checked for a replay with ``model``.

    Raises
    ------
    ValueError
        No such file, not a session file (or one cut short), recorded with another model, or
        inputs ``model`` does not observe.
    """
    path = Path(str(path).strip()).expanduser()
    if not str(path).strip() or path == Path("."):
        raise ValueError("give the path of a session file (.mcap, written by python -m "
                         "promp.live --session)")  # fmt: skip
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    session = read_session(path)
    header = session.header
    check_recorded_with(model, header, path)
    options = header.get("options", {})
    decide = options.get("decide")
    return ReplayHeader(path, live_inputs(model, header["inputs"]), str(options.get("start")),
                        None if decide is None else float(decide["threshold"]),
                        len(session.of("a")), len(session.of("p")))  # fmt: skip


class SessionReplay:
    """A session file replayed on a thread of its own (see the module docstring).

    Parameters
    ----------
    model : ProMPModel
        The model it was recorded with.
    header : ReplayHeader
        :func:`read_header`'s.
    fast : bool
        As fast as it goes, not at the recorded timing.
    sinks : sequence of callable
        Each step's :class:`promp.live.sinks.Output` handed to each (the recognition chart's
        :meth:`app.live.live_curve.CurveSink.take`), on the replay's thread.
    """

    def __init__(self, model: ProMPModel, header: ReplayHeader, fast: bool = False,
                 sinks: tuple[Callable[[Output], object], ...] = ()):  # fmt: skip
        self.model, self.header, self.fast = model, header, fast
        self.sinks = sinks
        self.steps = 0  # replayed so far
        self.result: ReplayResult | None = None  # once ended
        self._record = SessionRecord()
        self._stop = threading.Event()
        self._snapshot = self._record.snapshot(0.0, (), (), None, {}, ())
        self._thread = threading.Thread(target=self._run, name="session-replay", daemon=True)

    def snapshot(self) -> LiveSnapshot:
        """The latest snapshot (immutable; from any thread, without a lock)."""
        return self._snapshot

    @property
    def done(self) -> bool:
        return self.result is not None

    def start(self) -> None:
        self._thread.start()

    def _step(self, output: Output) -> None:
        if self._stop.is_set():
            raise _Stopped
        for sink in self.sinks:
            sink(output)
        self._record.add(output.events, output.boundaries, output.predictions, ())
        self.steps += 1
        self._snapshot = self._record.snapshot(output.time, (), (), output.movement, {}, ())

    def _run(self) -> None:
        try:
            replayed: Replayed = replay_session(self.model, self.header.path,
                                                paced=not self.fast, on_output=self._step,
                                                sleep=self._stop.wait)  # fmt: skip
            self.result = ReplayResult(replayed.steps, len(replayed.predictions),
                                       len(replayed.recorded), replayed.difference)  # fmt: skip
        except _Stopped:
            self.result = ReplayResult(self.steps, self._record.predictions,
                                       self.header.predictions, stopped=True)  # fmt: skip
        except Exception as exc:  # noqa: BLE001 (a file changed under us, a defect: said)
            traceback.print_exc()
            self.result = ReplayResult(self.steps, self._record.predictions,
                                       self.header.predictions,
                                       error=f"{type(exc).__name__}: {exc}")  # fmt: skip

    # the live session's calls that mean nothing here
    def begin(self, label: str = "", time: float | None = None) -> None:
        """A recorded session's movements start as recorded."""

    def end(self, time: float | None = None) -> None:
        """A recorded session's movements end as recorded."""

    def close(self) -> None:
        """Stop the replay (at its next step or wait) and wait for its thread."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=10.0)
