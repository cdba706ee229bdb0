"""The studio's live source over LSL: one :class:`promp.live.session.LiveSession` at a time,
shared by the Infer tab (which starts it, and shows its predictions) and the Teach tab (which
records its movements as takes: :mod:`app.live.live_takes`).

:class:`LslSource` lists the streams on the network before a session runs
(:mod:`app.live.stream_watch`, started the first time the Live source is chosen),
starts a session with a mapping checked against the model and the streams found
(:mod:`app.live.lsl_mapping`), the workspace's hand placement applied to a live hand
(:mod:`app.live.lsl_placement`), publishes its predictions as the headless command does
(:mod:`promp.live.outlets`, switched on and off while it runs: :class:`SwitchedOutlets`), and
stops it. LSL's resolver tells a stream's name, type, rate and channel count, not its channels'
labels and units (its description comes with an inlet): the watch opens an inlet of each
new stream once to read them, so that the list and the guessed mapping can name channels as
the stream labels them. Where liblsl cannot load, :attr:`LslSource.unavailable` says so and
what to do, and nothing starts. The session has its own threads; the studio's loop reads its
immutable :class:`promp.live.session.LiveSnapshot` (its ``running.session.snapshot()``)
without a lock. A session file replayed (:mod:`app.live.session_replay`,
:meth:`LslSource.replay`) stands in a live session's place.
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from app.live.inference import TUBE_POINTS
from app.live.live_curve import CurveSink, LiveCurves
from app.live.live_takes import JOURNALS_DIR, TakeRecorder
from app.live.lsl_mapping import MappingCheck, parse_mapping, safe_out_name
from app.live.lsl_placement import PlacedTransport
from app.live.session_outputs import CommitmentWake, SwitchedOutlets
from app.live.session_replay import SessionReplay, read_header
from app.live.stream_watch import StreamWatch
from promp.decision import CommitRule
from promp.live.session import LiveOptions, LiveSession, live_columns
from promp.live.transport import Selector, StreamDescription, Transport
from promp.model import ProMPModel
from robots.icub.layout import HAND
from robots.icub.placement import Placement

__all__ = ["CommitmentWake", "LiveConfig", "LslSource", "Running", "STARTS",
           "SwitchedOutlets"]  # (the first and the last: app.live.session_outputs)

STARTS = {"stillness": "still", "marker stream": "marker", "Begin / End buttons": "call"}


@dataclass(frozen=True)
class LiveConfig:
    """What a session is started with, as the Live source's controls say it.

    Attributes
    ----------
    mapping : str
        One modality a line (``hand=MocapHand:0,1,2@mm``).
    start : {"still", "marker", "call"}
        How movements start and end (:mod:`promp.live.segmenter`).
    markers : str
        The marker stream for ``"marker"``.
    alpha_method : {"ml", "model"}
    publish : bool
        Publish the predictions (LSL outlets ``out``-probabilities, ...).
    out : str
    remainder : str or None
        The modality whose predicted remainder is published.
    rate : float
        Its rate, Hz.
    commit : float or None
        Commit to a primitive in each movement once its probability has stayed at or above
        this threshold, in (0, 1), for the rule's window (:class:`promp.decision.CommitRule`,
        :mod:`promp.live.commitment`); None: no commitment.
    """

    mapping: str
    start: str = "still"
    markers: str = ""
    alpha_method: str = "ml"
    publish: bool = False
    out: str = "studio"
    remainder: str | None = None
    rate: float = 50.0
    commit: float | None = None


@dataclass(frozen=True, eq=False)
class Running:
    """A session started: with which model and configuration, its checked mapping, its
    number (counts the studio's sessions) and start time (monotonic), and the recognition
    chart's curves of its movements; ``session`` is a :class:`SessionReplay` when a session
    file is replayed."""

    session: LiveSession | SessionReplay
    model: ProMPModel
    config: LiveConfig
    check: MappingCheck
    number: int
    started: float
    recorder: TakeRecorder | None
    curves: LiveCurves | None = None

    @property
    def replay(self) -> SessionReplay | None:
        return self.session if isinstance(self.session, SessionReplay) else None


class LslSource:
    """The studio's live source (see the module docstring).

    Parameters
    ----------
    transport : callable, optional
        Makes the transport (default: :class:`promp.live.lsl.LslTransport`, when liblsl
        loads); tests give a fake one.
    """

    def __init__(self, transport: Callable[[], Transport] | None = None):
        if transport is None:
            from promp.live import lsl_available

            available, self.unavailable = lsl_available()
            transport = _lsl_transport if available else None
        else:
            self.unavailable = ""
        self._make = transport
        self._transport: Transport | None = None
        self._watch = StreamWatch(self._session_found)
        self._lock = threading.Lock()  # start, stop and publish, from the loop or a test
        self._numbers = itertools.count(1)
        self.outlets = SwitchedOutlets()
        self.running: Running | None = None
        # the studio's loop woken at a commitment (its call set by the studio)
        self.on_commitment = CommitmentWake(lambda: self.running)

    @property
    def available(self) -> bool:
        return not self.unavailable

    def transport(self) -> Transport:
        if not self.available:
            raise ValueError(self.unavailable)
        if self._transport is None:
            self._transport = self._make()
        return self._transport

    def watch(self) -> None:
        """Look for streams from now on (idempotent; nothing where LSL is unavailable)."""
        if self.available:
            self._watch.start(self.transport())

    def _session_found(self) -> tuple[StreamDescription, ...] | None:
        running = self.running
        return None if running is None else running.session.snapshot().found

    def found(self) -> tuple[StreamDescription, ...]:
        """The streams on the network at the latest look (the session's, while it runs),
        with their channels' labels and units once read."""
        return self._watch.found()

    # ------------------------------------------------------------------ start, stop

    def start(
        self,
        model: ProMPModel,
        config: LiveConfig,
        placement: Placement | None = None,
        workspace: Path | None = None,
        names: Callable[[], Sequence[str]] = tuple,
    ) -> Running:
        """Start a session of ``model`` as ``config`` says; ``placement``: the workspace's, for
        a live hand; ``workspace``: where takes are journalled (``live-journals/``; None: no
        recording), ``names``: its primitives now.

        Raises
        ------
        ValueError
            LSL is unavailable, a session runs already (live or replayed), or the
            configuration is refused (the mapping, the marker stream, the outputs' name):
            nothing starts.
        """
        with self._lock:
            transport = self.transport()
            if self.running is not None:
                what = "a session file is being replayed" if self.running.replay else \
                    "the live source is running already"  # fmt: skip
                raise ValueError(f"{what}: Stop it first")
            check = parse_mapping(config.mapping, model, self.found())
            if config.start not in STARTS.values():
                raise ValueError(f"unknown movement start {config.start!r}")
            if config.start == "marker":
                if not config.markers.strip():
                    raise ValueError("choose the marker stream the movements start and end by")
                Selector.parse(config.markers)
            specs = _specs(model, config) if config.publish else None
            rule = _commit_rule(config.commit)
            hand = next((i for i in check.inputs if i.name == HAND.name), None)
            if placement is not None and not placement.is_identity and hand is not None:
                transport = PlacedTransport(transport, hand, placement)
            options = LiveOptions(start=config.start, markers=config.markers.strip(),
                                  alpha_method=config.alpha_method, remainder=config.remainder,
                                  remainder_rate=config.rate, n_points=TUBE_POINTS,
                                  decide=rule)  # fmt: skip
            number = next(self._numbers)
            recorder = None
            if workspace is not None:
                prefix = time.strftime(f"live-%Y%m%d-%H%M%S-{number}")
                recorder = TakeRecorder(Path(workspace) / JOURNALS_DIR,
                                        live_columns(model, check.inputs), names, prefix)
            woken = self.on_commitment if rule is not None else None
            curves = LiveCurves(model.names)
            session = LiveSession(model, check.inputs, transport, options, outlets=self.outlets,
                                  recorder=recorder, on_prediction=woken,
                                  sinks=[CurveSink(curves)])  # fmt: skip
            if specs is not None:
                self.outlets.set(_outlets(specs, self.transport()))
            session.start()
            self.running = Running(session, model, config, check, number, time.monotonic(),
                                   recorder, curves)  # fmt: skip
            return self.running

    def replay(self, model: ProMPModel, path: Path | str, fast: bool = False) -> Running:
        """Replay the session file ``path`` (recorded with ``model``) in place of a live
        session (:mod:`app.live.session_replay`), at its timing or ``fast``.

        Raises
        ------
        ValueError
            A session runs (live or replayed), or the file is refused: nothing starts.
        """
        with self._lock:
            if self.running is not None:
                raise ValueError("the live source is running: Stop it first (a replay and "
                                 "live streams do not run together)")  # fmt: skip
            header = read_header(model, path)
            curves = LiveCurves(model.names)
            replay = SessionReplay(model, header, fast, (CurveSink(curves).take,))
            config = LiveConfig("\n".join(i.modality.spec() for i in header.inputs), header.start,
                                commit=header.commit)  # fmt: skip
            self.running = Running(replay, model, config, MappingCheck(header.inputs, ()),
                                   next(self._numbers), time.monotonic(), None, curves)
            replay.start()
            return self.running

    def stop(self) -> None:
        """Stop the session (its outlets vanish; a take under way stays in its journal)."""
        with self._lock:
            running, self.running = self.running, None
            if running is not None:
                running.session.close()
                self._watch.hand_over(running.session.snapshot().found)

    def publish(self, on: bool, out: str) -> tuple[str, ...]:
        """Publish the running session's predictions as ``out``-probabilities, ... (or stop
        publishing); the streams' names.

        Raises
        ------
        ValueError
            Nothing runs, or the name is refused.
        """
        with self._lock:
            running = self.running
            if running is None:
                raise ValueError("start the live source first")
            if not on:
                self.outlets.set(None)
                return ()
            config = running.config
            specs = _specs(running.model, LiveConfig(config.mapping, out=out,
                                                     remainder=config.remainder))  # fmt: skip
            self.outlets.set(_outlets(specs, self.transport()))
            return self.outlets.names

    def begin(self) -> None:
        """A movement starts now (a button)."""
        if self.running is not None:
            self.running.session.begin()

    def end(self) -> None:
        """The movement going on ends now."""
        if self.running is not None:
            self.running.session.end()

    def close(self) -> None:
        """Stop the session and the look for streams (the studio is stopping)."""
        self.stop()
        self._watch.close()


def _commit_rule(threshold: float | None) -> CommitRule | None:
    if threshold is None:
        return None
    if not 0.0 < threshold < 1.0:  # the rule takes 1, which a posterior may never reach
        raise ValueError(f"the commit threshold is a probability in (0, 1), got {threshold:g}")
    return CommitRule(threshold)


def _specs(model: ProMPModel, config: LiveConfig):
    from promp.live.outlets import outlet_specs

    return outlet_specs(model, safe_out_name(config.out), config.remainder)


def _outlets(specs, transport: Transport):
    from promp.live.outlets import PredictionOutlets

    return PredictionOutlets(specs, transport.outlet)


def _lsl_transport() -> Transport:
    from promp.live.lsl import LslTransport

    return LslTransport()
