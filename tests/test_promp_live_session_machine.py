"""A live session under faults nobody listed: hypothesis's rule-based state machine drives a
session (tests/live_fakes.py: a fake transport and a manual clock) with random sequences of
samples, pauses, stalls, backlogs, restarts, time jumps both ways, NaN and infinite values (a
stream's first samples too), changes of rate and of channel count, garbage and over-long
markers, Record calls, and streams vanishing and appearing. After every step it checks that
nothing raised; that the work is bounded (events and predictions per step by what arrived, the
sinks' queues); that the memory is bounded (the arrays the stages hold, by the rates, the
channels and the movement's longest); that every acknowledged sample is in the journal
(acknowledged = flushed: after the sinks are flushed, every row of the movement under way); and
that every prediction the sinks were given equals promp.infer on the samples it names (its
movement's first ``n_observed`` rows, read back from the journal) within 1e-9.

Bounded to :data:`EXAMPLES` sequences of at most :data:`STEPS` rules (well under a minute;
``LIVE_MACHINE_EXAMPLES=200`` in the environment runs more, by hand); the sequences it found
that failed are kept below it as plain tests."""

from __future__ import annotations

import math
import os
import tempfile
from collections import deque
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule
from numpy.testing import assert_allclose

from promp.data import Layout
from promp.evidence.pipeline import infer
from promp.evidence.speed import N_NODES, N_REFINE
from promp.live.journal import read_journal
from promp.live.predictor import LivePrediction
from promp.live.recorder import Recorder
from promp.live.segmenter import HISTORY_S
from promp.live.session import LiveOptions, LiveSession
from promp.live.sinks import QUEUE_OUTPUTS, Output
from promp.live.source import RATE_WINDOW_S
from promp.live.timebase import KEEP_S
from promp.model import ProMPModel
from promp.noise import noise_groups
from promp.observation import Observation
from tests.live_fakes import FakeStream, FakeTransport, Tap, synthetic_model

EXAMPLES = int(os.environ.get("LIVE_MACHINE_EXAMPLES", "12"))
STEPS = 30
MAX_MOVEMENT_S = 4.0
RATES = (25.0, 50.0, 100.0, 250.0)  # what the senders run at (Hz); the fastest bounds memory
MAX_CHUNK = 400  # the most samples one rule delivers at once (a backlog)
TOLERANCE = 1e-9  # absolute, the predictor's documented agreement with the offline engine
RTOL = 1e-8  # and relative: a refined speed may land ~1e-10 apart (see the kept example)
# A log-likelihood summed in another order agrees to ~1e-11 of its size (bench/outputs.py's
# rtol-log). The duration's median and bounds are quantiles of the speed posterior, whose
# masses are exp(log-likelihood): they move by up to that many nats as a share of a node's
# mass, so a movement the model explains badly (log-likelihoods of -2e6 nats after a stream
# changed its channels) moves them by ~1e-8 relative, and the posterior drawn at the median
# speed with them (see the kept example).
LOG_RTOL = 1e-11
model = synthetic_model


class Sender:
    """One outlet's sender: its stamps (its own clock), its rate, its motion."""

    def __init__(self, name: str, labels, transport: FakeTransport, rate: float, scale: float):
        self.name, self.labels, self.transport = name, tuple(labels), transport
        self.rate, self.scale = rate, scale
        self.stream = transport.add(FakeStream(name, labels, rate=rate))
        self.stamp = transport.now
        self.phase = 0.0

    def samples(self, n: int, moving: bool) -> tuple[np.ndarray, np.ndarray]:
        times = self.stamp + np.arange(1, n + 1) / self.rate
        self.stamp = float(times[-1])
        if moving:
            phases = self.phase + np.arange(1, n + 1) * 2.0 / self.rate
        else:
            phases = np.full(n, self.phase)
        self.phase = float(phases[-1])
        k = len(self.labels)
        values = np.column_stack([np.sin(phases + j) for j in range(k)]) * self.scale
        return times, values

    def restart(self, labels=None) -> None:
        self.stream.gone = True
        self.labels = tuple(labels or self.labels)
        self.stream = self.transport.add(FakeStream(self.name, self.labels, rate=self.rate))


class LiveSessionMachine(RuleBasedStateMachine):
    """A session of the hand (a position, m) and head (angles, deg) streams, faulted."""

    @initialize(start=st.sampled_from(["still", "marker", "call"]),
                hand_rate=st.sampled_from(RATES), head_rate=st.sampled_from(RATES),
                bad_start=st.sampled_from([None, None, "Hand", "Head"]))  # fmt: skip
    def open_session(self, start: str, hand_rate: float, head_rate: float,
                     bad_start: str | None = None) -> None:  # fmt: skip
        """The session opened; its first 0.3 s of samples, after ``bad_start``'s first 0.2 s
        of NaN values (a marker occluded from the start: its stamps are all it gives)."""
        self.folder = Path(tempfile.mkdtemp(prefix="live-machine-"))
        self.transport = FakeTransport()
        self.senders = {"Hand": Sender("Hand", ("x", "y", "z"), self.transport, hand_rate, 0.2),
                        "Head": Sender("Head", ("r", "p", "y"), self.transport, head_rate, 30.0)}
        self.cues = self.transport.add(FakeStream("Cues", ("label",), rate=0.0,
                                                  type="Markers", markers=True))
        self.recorder = Recorder(self.folder, ("x", "y", "z", "roll", "pitch", "yaw"))
        self.tap = Tap()
        options = LiveOptions(start=start, markers="Cues" if start == "marker" else "",
                              max_movement_s=MAX_MOVEMENT_S)
        self.session = LiveSession(model(), ["hand=Hand:0,1,2", "head=Head:0,1,2@deg"],
                                   self.transport, options, recorder=self.recorder,
                                   sinks=[self.tap])  # fmt: skip
        self.checked = 0  # predictions checked against the offline engine
        self.session.connect()
        self.step()
        if start == "call":
            self.session.begin()
        if bad_start is not None:
            sender = self.senders[bad_start]
            times, values = sender.samples(int(0.2 * sender.rate), True)
            sender.stream.push(times, np.full_like(values, math.nan))
            self.transport.now += 0.2
            self.step()
        self.stream(0.3)

    def teardown(self) -> None:
        if hasattr(self, "session"):
            self.session.close()

    # ------------------------------------------------------------------ one step, checked

    def step(self, markers: int = 0, calls: int = 0) -> None:
        """One step of the session (it must not raise), its sinks flushed, its work checked."""
        before = self.session.snapshot()
        self.session.step()
        assert self.session.flush(60.0), "a sink did not deliver within a minute"
        outputs = list(self.tap.outputs)
        self.tap.outputs.clear()
        events = sum(len(o.events) for o in outputs)
        feeds = 3
        assert events <= 10 * feeds + 2 * (markers + calls) + 8, [
            e.text for o in outputs for e in o.events]
        ends = sum(b.kind == "end" for o in outputs for b in o.boundaries)
        predictions = [p for o in outputs for p in o.predictions]
        assert len(predictions) <= ends + 1
        assert self.session.snapshot().predictions - before.predictions == len(predictions)
        for state in self.session.snapshot().sinks:
            assert state.queued <= QUEUE_OUTPUTS and not state.failing, state
        self.check_journal(outputs)
        for p in predictions:
            self.check_prediction(p)

    def check_journal(self, outputs: list[Output]) -> None:
        """Every row of the movement under way is acknowledged, and in its journal; an ended
        movement's journal holds its rows."""
        movements = [b.movement for o in outputs for b in o.boundaries if b.movement is not None]
        going = self.session.snapshot().movement
        if going is not None and len(going):
            assert self.recorder.acknowledged == len(going)
            movements.append(going)
        for movement in movements:
            if len(movement) < 2:
                continue
            demo, header = read_journal(self.recorder.journal_path(movement.number))
            n = len(movement)
            assert demo.n_samples >= n
            assert header["start"] == movement.start
            assert np.array_equal(demo.times[:n], movement.times - movement.start)
            assert np.array_equal(demo.values[:n], movement.values)

    def check_prediction(self, p) -> None:
        """``p`` is promp.infer on its movement's first ``n_observed`` rows, read back
        from the journal (within 1e-9: the online sums add the same terms in another order)."""
        demo, header = read_journal(self.recorder.journal_path(p.movement))
        n = p.n_observed
        assert header["start"] == p.start and demo.n_samples >= n
        values = np.array(demo.values[:n])
        values[:, 3:] = np.unwrap(values[:, 3:], axis=0)
        observation = Observation(demo.times[:n], values, ("hand", "head"))
        offline = infer(model(), observation)
        close = {"rtol": RTOL, "atol": TOLERANCE}
        assert p.inference.index == offline.index
        assert_allclose(p.probabilities, offline.probabilities, **close)
        # what depends on the speed posterior's quantiles (the duration, and the posterior
        # drawn at its median) carries the log-likelihoods' round-off (LOG_RTOL)
        carried = LOG_RTOL * largest_log_likelihood(offline)
        online, seen = p.duration, offline.timing.duration
        assert_allclose([online.value, online.low, online.high],
                        [seen.value, seen.low, seen.high], rtol=RTOL + carried,
                        atol=TOLERANCE)  # fmt: skip
        mean = offline.posterior.mean
        assert_allclose(p.inference.posterior.mean, mean, rtol=RTOL + carried,
                        atol=TOLERANCE + carried * float(np.abs(mean).max()))  # fmt: skip
        self.checked += 1

    @invariant()
    def memory_is_bounded(self) -> None:
        """The arrays each stage holds, by what it may hold at the fastest rate ``R`` with a
        backlog of ``C`` samples on top: the time base, each input's samples (channels and
        time) for :data:`KEEP_S` and the longest wait for a lagging input (a movement's
        longest, ``W``); the segmenter, the rows (6 columns and time) of a movement and the
        :data:`HISTORY_S` before it; the predictor, a movement's observation twice (its own,
        and the sums' copy) and the sums it keeps (:func:`kept_sums_bytes`); the rate
        windows' stamps; and 16 kB of small arrays. Each stage within its own bound: a sum
        of bounds hid a time base holding 2.3 times its own (the hand's 31 s)."""
        if not hasattr(self, "session"):
            return
        state = self.session.state
        r, c, w = max(RATES), MAX_CHUNK, MAX_MOVEMENT_S
        bounds = {
            "timebase": 2 * (3 + 1) * 8 * ((KEEP_S + w) * r + c),
            "segmenter": (6 + 1) * 8 * ((w + HISTORY_S) * r + c),
            "predictor": 2 * (6 + 1) * 8 * (w * r + c) + kept_sums_bytes(model()),
        }
        for stage, bound in bounds.items():
            held = held_bytes(getattr(state, stage))
            assert held <= bound + 16e3, f"the {stage} holds {held} bytes"
        rates = 2 * 8 * RATE_WINDOW_S * r
        held = held_bytes(state)
        assert held <= sum(bounds.values()) + rates + 16e3, f"{held} bytes held"

    # ------------------------------------------------------------------ what happens

    def stream(self, seconds: float, moving: bool = True, steps: int = 3,
               only: str | None = None) -> None:  # fmt: skip
        """``seconds`` of samples of both streams (or ``only`` one), delivered as the clock
        reaches them, the session stepping ``steps`` times meanwhile."""
        names = [only] if only else ["Hand", "Head"]
        for _ in range(steps):
            for name in names:
                sender = self.senders[name]
                k = int(round(seconds / steps * sender.rate))
                if k:
                    sender.stream.push(*sender.samples(k, moving))
            self.transport.now += seconds / steps
            self.step()

    @rule(seconds=st.floats(0.01, 1.5), moving=st.booleans(), steps=st.integers(1, 6),
          only=st.sampled_from([None, None, "Hand", "Head"]))
    def samples(self, seconds: float, moving: bool, steps: int, only: str | None) -> None:
        self.stream(seconds, moving, steps, only)

    # Each fault is followed by ``then`` seconds of both streams, moving: a fault interrupts
    # a stream that goes on (a movement is observed again, and predicted, after it).
    THEN = st.floats(0.0, 1.0)

    @rule(seconds=st.floats(0.05, 3.0), then=THEN)
    def pause(self, seconds: float, then: float) -> None:
        """Every sender silent for ``seconds`` (their stamps go on: they resume later)."""
        for sender in self.senders.values():
            sender.stamp += seconds
        self.transport.now += seconds
        self.step()
        self.stream(then)

    @rule(stream=st.sampled_from(["Hand", "Head"]), seconds=st.floats(0.1, 2.0),
          steps=st.integers(1, 5), then=THEN)
    def stall(self, stream: str, seconds: float, steps: int, then: float) -> None:
        """One stream silent for ``seconds`` (while the session steps), then its backlog."""
        sender = self.senders[stream]
        for _ in range(steps):
            self.transport.now += seconds / steps
            self.step()
        n = min(MAX_CHUNK, max(1, int(seconds * sender.rate)))
        sender.stream.push(*sender.samples(n, True))
        self.step()
        self.stream(then)

    @rule(stream=st.sampled_from(["Hand", "Head"]), seconds=st.floats(2.0, 60.0),
          moving=st.booleans(), then=THEN)
    def long_stall(self, stream: str, seconds: float, moving: bool, then: float) -> None:
        """One stream silent for ``seconds`` while the other goes on (a head tracker that lost
        the face, the mocap streaming): it resumes after a gap."""
        other = "Head" if stream == "Hand" else "Hand"
        self.stream(seconds, moving, steps=max(2, int(seconds)), only=other)
        self.senders[stream].stamp += seconds
        self.stream(then)

    @rule(stream=st.sampled_from(["Hand", "Head"]), n=st.integers(50, MAX_CHUNK), then=THEN)
    def backlog(self, stream: str, n: int, then: float) -> None:
        """``n`` samples at once, stamped in the past (a sender catching up)."""
        sender = self.senders[stream]
        sender.stamp -= n / sender.rate
        sender.stream.push(*sender.samples(n, True))
        self.step()
        self.stream(then)

    @rule(stream=st.sampled_from(["Hand", "Head"]),
          jump=st.one_of(st.floats(-20.0, -0.3), st.floats(0.3, 20.0)), then=THEN)
    def time_jump(self, stream: str, jump: float, then: float) -> None:
        """One sender's clock jumps (back or ahead)."""
        self.senders[stream].stamp += jump
        self.stream(then + 0.05)

    @rule(stream=st.sampled_from(["Hand", "Head"]), n=st.integers(1, 20),
          bad=st.sampled_from([math.nan, math.inf, -math.inf, 1e300]),
          where=st.integers(0, 2), then=THEN)
    def bad_values(self, stream: str, n: int, bad: float, where: int, then: float) -> None:
        sender = self.senders[stream]
        times, values = sender.samples(n, True)
        values[::2, where % values.shape[1]] = bad
        sender.stream.push(times, values)
        self.transport.now += n / sender.rate
        self.step()
        self.stream(then)

    @rule(stream=st.sampled_from(["Hand", "Head"]), rate=st.sampled_from(RATES), then=THEN)
    def rate_change(self, stream: str, rate: float, then: float) -> None:
        """The sender runs at another rate from now on (its declared rate stays)."""
        self.senders[stream].rate = rate
        self.stream(then)

    @rule(stream=st.sampled_from(["Hand", "Head"]), width=st.sampled_from([2, 4]), then=THEN)
    def channel_change(self, stream: str, width: int, then: float) -> None:
        """Samples of another channel count on the same inlet (left out, said)."""
        sender = self.senders[stream]
        times, _ = sender.samples(3, True)
        sender.stream.push(times, np.zeros((3, width)))
        self.transport.now += 3 / sender.rate
        self.step()
        self.stream(then)

    @rule(stream=st.sampled_from(["Hand", "Head"]), width=st.sampled_from([2, 3, 4]),
          then=THEN)
    def restart(self, stream: str, width: int, then: float) -> None:
        """The outlet restarts (a new uid), with ``width`` channels; looked for again."""
        self.senders[stream].restart(tuple("abcd"[:width]))
        self.step()
        self.session.connect()
        self.stream(then)

    @rule(stream=st.sampled_from(["Hand", "Head"]), then=THEN)
    def vanish(self, stream: str, then: float) -> None:
        """An outlet vanishes (the other streams go on)."""
        self.senders[stream].stream.gone = True
        self.stream(then)

    @rule(stream=st.sampled_from(["Hand", "Head"]), then=THEN)
    def appear(self, stream: str, then: float) -> None:
        """A vanished outlet is back (the same uid), found at the next look."""
        self.senders[stream].stream.gone = False
        self.session.connect()
        self.stream(then)

    @rule(labels=st.lists(st.one_of(
        st.sampled_from(["start", "end", "start left", "end left", "start right", "start ",
                         "END", "start left right"]),
        st.text(max_size=30), st.text(min_size=200, max_size=2000)), min_size=1, max_size=4),
        then=THEN)  # fmt: skip
    def markers(self, labels: list[str], then: float) -> None:
        """Markers, valid, garbage or over-long, stamped now."""
        self.cues.push([self.transport.now] * len(labels), labels)
        self.step(markers=len(labels))
        self.stream(then)

    @rule(kind=st.sampled_from(["begin", "begin", "end"]), ago=st.floats(0.0, 1.0), then=THEN)
    def call(self, kind: str, ago: float, then: float) -> None:
        """A Record button: a movement begins or ends ``ago`` seconds back."""
        at = self.transport.now - ago
        if kind == "begin":
            self.session.begin(time=at)
        else:
            self.session.end(time=at)
        self.step(calls=1)
        self.stream(then)

    @rule()
    def look(self) -> None:
        """The resolver looks for the streams that are missing."""
        self.session.connect()
        self.step()


def largest_log_likelihood(inference) -> float:
    """The largest |log-likelihood| (nats) of any primitive at any speed node it scored."""
    tables = [np.abs(t[np.isfinite(t)]) for t in inference.recognition.log_likelihoods]
    return max((float(t.max()) for t in tables if t.size), default=0.0)


def kept_sums_bytes(model: ProMPModel) -> float:
    """What the predictor's kept sums may hold (:class:`promp.evidence.sums.KeptSums`): per
    primitive, the candidates scored at the latest two lengths of the observation (the coarse
    nodes, the refined ones, and the refined ones of the update before), each with
    ``Psi^T K^-1 Psi`` of every noise group (G, M, M), its projections (Do, M) and ``r^T K^-1
    r`` (Do), for every dimension observed."""
    dims = np.arange(model.n_dims)
    total = 0.0
    for primitive in model.primitives:
        m = primitive.mean.shape[0] // model.n_dims
        g = len(noise_groups(primitive, dims))
        per_candidate = g * m * m + dims.size * m + dims.size
        total += 2 * (N_NODES + 1 + 2 * N_REFINE) * 8 * per_candidate
    return total


def held_bytes(root) -> int:
    """Bytes of the arrays reachable from ``root`` (through attributes, containers), but the
    model's (constant) and the latest prediction's (an output, not a buffer: one, its size
    the model's, ``s_bar / alpha`` points); 8 per element of a container of numbers."""
    seen: set[int] = set()
    total = 0
    stack = [root]
    while stack:
        obj = stack.pop()
        if id(obj) in seen or isinstance(obj, ProMPModel | Layout | LivePrediction | str | bytes
                                         | type):
            continue
        seen.add(id(obj))
        if isinstance(obj, np.ndarray):
            total += obj.nbytes if obj.base is None or id(obj.base) not in seen else 0
            continue
        if isinstance(obj, dict):
            stack += list(obj.values())
        elif isinstance(obj, list | tuple | deque | set | frozenset):
            total += 8 * len(obj)
            stack += [o for o in obj if not isinstance(o, int | float)]
        elif hasattr(obj, "__dict__"):
            stack += list(vars(obj).values())
        elif hasattr(obj, "__slots__"):
            stack += [getattr(obj, s) for s in obj.__slots__ if hasattr(obj, s)]
    return total


LiveSessionMachine.TestCase.settings = settings(
    max_examples=EXAMPLES, stateful_step_count=STEPS, deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)  # fmt: skip
test_a_live_session_survives_any_sequence_of_faults = LiveSessionMachine.TestCase


# ---------------------------------------------------------------------- sequences it found


def test_the_rows_wait_for_a_silent_input_no_longer_than_a_movement_lasts() -> None:
    """Found: the head silent for 41 s while the hand streams at 250 Hz. A row needs every
    input, so the hand's samples waited for the head, all of them: 8 kB a second, for ever.
    They now wait no longer than a movement may last (promp.live.pipeline)."""
    state = LiveSessionMachine()
    state.open_session(start="still", hand_rate=250.0, head_rate=25.0)
    state.samples(seconds=1.0, moving=True, steps=3, only=None)  # movement 1 starts
    state.memory_is_bounded()
    state.long_stall(moving=False, seconds=41.0, stream="Head", then=0.0)
    state.memory_is_bounded()
    texts = [e.text for e in state.session.snapshot().events]
    assert sum(t.startswith("input 'head' lags the others by over 4 s") for t in texts) == 1
    assert "movement 1 ended (input 'head' lags the others by over 4 s" in " ".join(texts)
    state.teardown()


def test_samples_that_can_never_be_in_a_row_are_not_kept() -> None:
    """Found (2026-11-29, by a helper's run): the hand's clock jumps back twice (28 s), it
    vanishes and comes back on its own clock, then the head is silent for 31 s. The head's
    samples were dropped (the hand lagged), so no row came, and the time base, which forgot
    samples only when rows came, kept the hand's 31 s (248 kB). A row needs every input from
    its first sample on, or from after the latest of one whose samples were dropped: the
    samples before are forgotten, rows or not (promp.live.timebase)."""
    state = LiveSessionMachine()
    state.open_session(start="call", hand_rate=250.0, head_rate=25.0)
    state.time_jump(jump=-13.0, stream="Hand", then=0.0)
    state.time_jump(jump=-15.0, stream="Hand", then=0.0)
    state.vanish(stream="Hand", then=0.0)
    state.appear(stream="Hand", then=0.0)
    state.long_stall(moving=False, seconds=31.0, stream="Head", then=0.0)
    state.memory_is_bounded()
    state.teardown()


def test_an_outlet_back_after_its_clock_jumped_stays_on_the_others_clock() -> None:
    """Found (2026-11-30, LIVE_MACHINE_EXAMPLES=200): the head's backlog is re-anchored (its
    stamps then ahead of its sender's clock), the hand's clock goes back 15 s (re-anchored),
    the hand vanishes and comes back (the same outlet), the head restarts without the
    mapping's channels and is silent for 28 s. The hand came back unshifted, 15 s behind its
    own earlier stamps and the head's, so the head did not seem to lag while the hand's
    samples waited for it: the time base held the hand's 16 s (129 kB). The same outlet back
    keeps its re-anchoring (promp.live.source)."""
    state = LiveSessionMachine()
    state.open_session(start="still", hand_rate=250.0, head_rate=25.0)
    state.backlog(n=303, stream="Head", then=0.0)
    state.time_jump(jump=-15.0, stream="Hand", then=0.0)
    state.long_stall(moving=False, seconds=2.0, stream="Hand", then=0.0)
    state.vanish(stream="Hand", then=0.0)
    state.restart(stream="Head", then=0.0, width=2)
    state.appear(stream="Hand", then=0.0)
    state.long_stall(moving=False, seconds=28.0, stream="Head", then=0.0)
    state.memory_is_bounded()
    state.teardown()


def test_an_input_silent_while_the_others_stamps_lag_it_is_said_to_lag() -> None:
    """Found (2026-11-30, LIVE_MACHINE_EXAMPLES=200): the hand is silent for 15 s, then its
    clock goes back 15 s (its stamps now lag the session's clock by 15 s, no jump seen: they
    go on from where they stopped), the head restarts without the mapping's channels and is
    silent. By the stamps the hand lagged the head's last sample, so the head did not lag and
    the hand's samples waited for it: the time base held 16 s (128 kB). An input from which
    nothing arrived for over the wait while another's did lags (promp.live.pipeline)."""
    state = LiveSessionMachine()
    state.open_session(start="still", hand_rate=250.0, head_rate=25.0)
    state.long_stall(moving=False, seconds=15.0, stream="Hand", then=0.0)
    state.time_jump(jump=-15.0, stream="Hand", then=0.0)
    state.restart(stream="Head", then=0.0, width=2)
    state.long_stall(moving=False, seconds=2.0, stream="Hand", then=1.0)
    state.long_stall(moving=False, seconds=14.0, stream="Head", then=1.0)
    state.memory_is_bounded()
    texts = [e.text for e in state.session.snapshot().events]
    assert any(t.startswith("input 'head' lags the others by over 4 s") for t in texts), texts
    state.teardown()


def test_the_rows_input_restarted_on_another_phase_does_not_fail_the_step() -> None:
    """Found (2026-11-30, LIVE_MACHINE_EXAMPLES=1000, with the hand's first samples all NaN):
    both streams at 25 Hz, the hand's clock goes back 0.5 s (re-anchored), then its outlet
    restarts. The rows' input came back on another phase, and one row after the last given
    was one sample on the time base: the XDF reader's clock refused it and the step raised
    (promp.live.timebase now waits for its next sample)."""
    state = LiveSessionMachine()
    state.open_session(start="still", hand_rate=25.0, head_rate=25.0, bad_start="Hand")
    state.time_jump(jump=-0.5, stream="Hand", then=1.0)
    state.restart(stream="Hand", then=1.0, width=3)
    state.memory_is_bounded()
    state.teardown()


def test_a_prediction_after_a_stall_and_its_backlog_is_the_offline_one() -> None:
    """Found: after a stall of the head and its backlog, the refined speed of the online
    update lands 7.6e-11 from the offline engine's, and the duration's low bound 1.24e-9 from
    it (the predictor's documented agreement is 1e-9 absolute): equal to round-off, within
    1e-8 relative."""
    state = LiveSessionMachine()
    state.open_session(start="still", hand_rate=100.0, head_rate=50.0)
    state.memory_is_bounded()
    state.bad_values(bad=math.nan, n=9, stream="Hand", then=0.640625, where=0)
    state.memory_is_bounded()
    assert state.checked >= 3
    checked = state.checked
    state.stall(seconds=1.0, steps=1, stream="Head", then=0.0)
    state.memory_is_bounded()
    assert state.checked > checked  # the prediction after the backlog
    state.teardown()


def test_a_stall_after_a_rate_change_is_a_gap_the_time_base_sees() -> None:
    """Found (2026-11-28, while the mutation bench ran the machine): the head's rate changes
    from 50 to 250 Hz, then it stalls for 2 s; the time base does not take the pause for a gap
    and gives rows across it, which the XDF reader's on_one_clock refuses (a ValueError out of
    the session's step). The pauses are judged once, by the time base's push, with the
    sender's lateness: a pause it lets through is interpolated across."""
    state = LiveSessionMachine()
    state.open_session(start="still", hand_rate=25.0, head_rate=50.0)
    for _ in range(3):
        state.markers(labels=["start"], then=0.0)
    state.rate_change(rate=250.0, stream="Head", then=0.0)
    state.long_stall(moving=False, seconds=2.0, stream="Head", then=0.3878886815088102)
    state.rate_change(rate=25.0, stream="Hand", then=0.10027715958783515)
    state.teardown()


def test_a_movement_explained_badly_agrees_with_the_offline_one_to_its_likelihood_s_round_off():
    """Found (2026-11-29): both streams change their channels, the hand twice. The online
    log-likelihoods (about -2e6 nats) are the offline ones to 2.9e-11 of their size, and the
    duration's low bound 6e-8 s from the offline one's (2.7e-8 relative): within the
    round-off its quantile carries from log-likelihoods that large (LOG_RTOL)."""
    state = LiveSessionMachine()
    state.open_session(start="still", hand_rate=250.0, head_rate=250.0)
    state.memory_is_bounded()
    state.channel_change(stream="Head", then=0.05, width=2)
    state.memory_is_bounded()
    state.channel_change(stream="Hand", then=0.140625, width=2)
    state.memory_is_bounded()
    state.channel_change(stream="Hand", then=0.140625, width=2)
    state.memory_is_bounded()
    checked = state.checked
    state.channel_change(stream="Head", then=0.828125, width=2)
    assert state.checked > checked
    state.teardown()
