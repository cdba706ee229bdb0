"""A transport without LSL for the live stages' tests: streams the test pushes samples into,
inlets that hand them out, outlets that keep what was pushed, and a clock the test moves."""

from __future__ import annotations

import itertools
from collections import deque
from typing import NamedTuple

import numpy as np

from promp.data import Demonstration
from promp.learn import fit
from promp.live.sinks import CallbackSink, Output
from promp.live.transport import OutletSpec, StreamDescription, StreamLost
from promp.model import ProMPModel, Settings
from tests.conftest import PATIENCE_S, shared_set, uses_shared_data
from tests.synthetic import LAYOUT, make_dataset

_UIDS = itertools.count(1)


class FakeStream:
    """An outlet of the fake network: the test pushes samples (times on the session's clock)."""

    def __init__(self, name: str, labels, units=None, rate: float = 100.0, type: str = "Mocap",
                 source_id: str = "", markers: bool = False):  # fmt: skip
        labels = tuple(labels)
        self.description = StreamDescription(
            name=name, type=type, source_id=source_id, uid=f"uid-{next(_UIDS)}", host="fake",
            rate=rate, labels=labels, units=tuple(units or ("",) * len(labels)),
            format="string" if markers else "double64",
        )  # fmt: skip
        self.pending: list[tuple[np.ndarray, object]] = []
        self.gone = False

    def push(self, times, values) -> None:
        """Send samples (lost while the outlet is gone, as an outlet that is not there sends
        nothing)."""
        if not self.gone:
            self.pending.append((np.asarray(times, dtype=float), values))


class FakeInlet:
    def __init__(self, stream: FakeStream):
        self.stream = stream
        self.description = stream.description
        self.closed = False

    def pull(self):
        if self.stream.gone:
            raise StreamLost(f"stream {self.description.name!r} is gone")
        pending, self.stream.pending = self.stream.pending, []
        if self.description.is_markers:
            times = np.concatenate([t for t, _ in pending]) if pending else np.zeros(0)
            return times, [label for _, labels in pending for label in labels]
        if not pending:
            return np.zeros(0), np.zeros((0, self.description.n_channels))
        return (np.concatenate([t for t, _ in pending]),
                np.concatenate([np.asarray(v, dtype=float) for _, v in pending]))  # fmt: skip

    def offset(self) -> float:
        return 0.0

    def close(self) -> None:
        self.closed = True


class FakeOutlet:
    def __init__(self, spec: OutletSpec):
        self.spec = spec
        self.pushed: list[tuple[object, float]] = []

    def push(self, rows, stamp: float) -> None:
        self.pushed.append((rows, stamp))

    def close(self) -> None:
        pass


class FakeTransport:
    """The fake network: ``streams`` visible, a manual clock (``now``)."""

    def __init__(self, now: float = 1000.0):
        self.now = now
        self.streams: list[FakeStream] = []
        self.outlets: dict[str, FakeOutlet] = {}

    def clock(self) -> float:
        return self.now

    def add(self, stream: FakeStream) -> FakeStream:
        self.streams.append(stream)
        return stream

    def find(self, wait: float) -> list[StreamDescription]:
        return [s.description for s in self.streams if not s.gone]

    def open(self, description: StreamDescription) -> FakeInlet:
        for s in self.streams:
            if s.description.uid == description.uid and not s.gone:
                return FakeInlet(s)
        raise StreamLost(f"stream {description.name!r} vanished before it was opened")

    def outlet(self, spec: OutletSpec) -> FakeOutlet:
        self.outlets[spec.name] = FakeOutlet(spec)
        return self.outlets[spec.name]


_MODEL: list[ProMPModel] = []


def synthetic_model() -> ProMPModel:
    """The synthetic hand and head model (primitives left and right; learned once, fixed
    settings)."""
    if not _MODEL:
        settings = Settings(n_basis=7, width=1.0, noise_scale=1.5, duration_temperature=1.0)
        _MODEL.append(fit(make_dataset(seed=5, n_demos=5), LAYOUT, settings))
    return _MODEL[0]


class Tap(CallbackSink):
    """A lossless sink keeping every output the session gave its sinks, in order."""

    lossless = True

    def __init__(self) -> None:
        super().__init__(lambda p: None, "tap")
        self.outputs: deque[Output] = deque()

    def view(self, output: Output) -> Output:
        return output

    def take(self, output: Output) -> tuple:
        self.outputs.append(output)
        return ()


def held(demo: Demonstration, before_s: float, after_s: float) -> Demonstration:
    """``demo`` with its first sample held for ``before_s`` and its last for ``after_s``
    (still rests around the movement, at its own step)."""
    dt = demo.sample_period
    n0, n1 = int(round(before_s / dt)), int(round(after_s / dt))
    t = demo.times - demo.times[0]
    after = n0 * dt + t[-1] + dt * np.arange(1, n1 + 1)
    times = np.concatenate([np.arange(n0) * dt, n0 * dt + t, after])
    values = np.vstack([np.repeat(demo.values[:1], n0, axis=0), demo.values,
                        np.repeat(demo.values[-1:], n1, axis=0)])  # fmt: skip
    return Demonstration(times, values, demo.columns, demo.name)


def replay(session, transport: FakeTransport, stream: FakeStream, times, values,
           step_s: float = 1 / 60, scale: float = 1.0, start: float | None = None):  # fmt: skip
    """Push the samples ``(times (n,) from 0, values (n, k))`` into ``stream`` as the clock
    reaches them (``scale`` the values, e.g. 1000 for mm), stepping ``session`` every
    ``step_s`` of the clock, and waits for its sinks; returns the session clock's times of
    the samples."""
    t0 = transport.now if start is None else start
    stamps = t0 + np.asarray(times, dtype=float)
    i = 0
    while i < stamps.size:
        transport.now += step_s
        j = int(np.searchsorted(stamps, transport.now, side="right"))
        if j > i:
            stream.push(stamps[i:j], np.asarray(values[i:j]) * scale)
            i = j
        session.step()
    session.flush()  # the sinks (the predictions' callback, a recorder) have all of it
    return stamps



class BeganAndEnded(NamedTuple):
    """What :func:`begun_and_ended` ran: the session (still open), its fake network, the
    ``Hand`` stream and the movements replayed (in order)."""

    session: object
    transport: FakeTransport
    stream: FakeStream
    demos: list[Demonstration]


def begun_and_ended(
    model: ProMPModel,
    options,
    classes=("right", "left"),
    inputs=None,
    transport: FakeTransport | None = None,
    **session_args,
) -> BeganAndEnded:
    """A stepped session (``options``, ``start="call"``) on a fake network (``transport``, or a
    new one) streaming ``Hand`` (x, y, z at 50 Hz) into ``inputs`` (default the hand on its
    channels 0, 1, 2), that observed an unseen movement (``make_dataset(seed=11, n_demos=1)``)
    of each of ``classes`` in turn, each between a Begin and an End call, the clock moved 0.1 s
    and the session stepped and flushed after each End. ``session_args`` go to
    :class:`LiveSession` (outlets, sinks, on_prediction)."""
    from promp.live.session import LiveSession

    transport = FakeTransport() if transport is None else transport
    stream = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    session = LiveSession(model, ["hand=Hand:0,1,2"] if inputs is None else inputs, transport,
                          options, **session_args)  # fmt: skip
    session.connect()
    session.step()
    unseen = make_dataset(seed=11, n_demos=1)
    demos = [unseen[name][0] for name in classes]
    for demo in demos:
        session.begin()
        replay(session, transport, stream, demo.times - demo.times[0],
               demo.select(["x", "y", "z"]))  # fmt: skip
        session.end()
        transport.now += 0.1
        session.step()
        session.flush()
    return BeganAndEnded(session, transport, stream, demos)


# ---------------------------------------------------------------------------- shared data

_CACHE: dict = {}


@uses_shared_data
def flt_dataset():
    """The shared set lab-records-flt (the test is skipped when it is absent)."""
    from promp.datasets import load_records_dataset

    root = shared_set("lab-records-flt")
    if "flt" not in _CACHE:
        _CACHE["flt"] = load_records_dataset(root)
    return _CACHE["flt"]


@uses_shared_data
def hand_model():
    """A hand model of lab-records-flt learned without each class's first demonstration (the
    replayed ones), fixed settings (fast and deterministic)."""
    from promp.data import Layout, Modality
    from promp.learn import fit
    from promp.model import Settings

    dataset = flt_dataset()
    if "hand" not in _CACHE:
        layout = Layout((Modality("hand", ("x", "y", "z"), unit="m"),))
        train = {k: v[1:] for k, v in dataset.items()}
        settings = Settings(n_basis=7, width=1.0, noise_scale=1.5, duration_temperature=1.0)
        _CACHE["hand"] = fit(train, layout, settings)
    return _CACHE["hand"]


def session_with(model, inputs, transport, **options):
    """A stepped session (no threads) over ``transport``, its streams found."""
    from promp.live.session import LiveOptions, LiveSession

    predictions: list = []
    session = LiveSession(model, inputs, transport, LiveOptions(**options),
                          on_prediction=predictions.append)  # fmt: skip
    session.connect()
    session.step()
    session.predictions = predictions
    return session


@uses_shared_data
def flt_workspace(root, per_class: int = 6, modalities: str = "hand=x,y,z", settings=None):
    """A studio workspace at ``root`` of lab-records-flt's ``modalities``: each class's
    demonstrations but its first (the one the tests replay), at most ``per_class``; learning
    ``settings`` given (default: hand_model's, fast and deterministic)."""
    from app.io.dataset_import import read_folder
    from app.io.workspace import Workspace
    from promp.datasets import parse_modalities

    flt_dataset()  # skips when absent
    data, _ = read_folder(shared_set("lab-records-flt"), "records", parse_modalities(modalities))
    data.demos = {name: demos[1:per_class + 1] for name, demos in data.demos.items()}
    data.settings = dict(settings if settings is not None else
                         {"n_basis": 7, "width": 1.0, "noise_scale": 1.5})  # fmt: skip
    Workspace.create(root, data)
    return root


def offset_in(values: np.ndarray, run: np.ndarray) -> int:
    """Where ``run`` (n, k) lies in ``values`` (m, k): the offset of the best match (a take's
    rows among those pushed; still stretches match anywhere within themselves)."""
    n = run.shape[0]
    if n > values.shape[0]:
        raise ValueError(f"a run of {n} rows cannot lie in {values.shape[0]}")
    errors = [np.abs(values[i:i + n] - run).max() for i in range(values.shape[0] - n + 1)]
    return int(np.argmin(errors))


# ------------------------------------------------------------ a guided arm, a busy machine

SLOW_M_S = 0.01  # a slow phase: 1 cm/s, below the idle speed (promp.stillness.HAND_IDLE_M_S)


def slowed_middle(demo: Demonstration, seconds: float, hand=("x", "y", "z")) -> Demonstration:
    """``demo`` with a slow phase in its middle, as a guided arm slows near a waypoint: the
    hand covers the ``SLOW_M_S * seconds`` of its path around the path's midpoint at
    ``SLOW_M_S`` (below the idle speed for ``seconds``), the rest as it was; resampled at its
    own step (every column interpolated on the new times)."""
    t = demo.times - demo.times[0]
    xyz = demo.select(list(hand))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))])
    slow = SLOW_M_S * seconds
    lo, hi = 0.5 * (arc[-1] - slow), 0.5 * (arc[-1] + slow)
    if lo <= 0:
        raise ValueError(f"{demo.name}: a path of {arc[-1]:.3f} m is too short to slow "
                         f"{slow:.3f} m of it")  # fmt: skip
    # the times at which the path reaches lo and hi, and the new clock between them
    t_lo, t_hi = np.interp([lo, hi], arc, t)
    new = np.where(t <= t_lo, t, np.where(t >= t_hi, t + seconds - (t_hi - t_lo),
                                          t_lo + (arc - lo) / SLOW_M_S))  # fmt: skip
    new = np.maximum.accumulate(new + 1e-12 * np.arange(t.size))
    step = demo.sample_period
    grid = np.arange(0.0, new[-1] + 1e-9, step)
    values = np.column_stack([np.interp(grid, new, c) for c in demo.values.T])
    return Demonstration(grid, values, demo.columns, demo.name)


def late_pushes(times: np.ndarray, rng, every_s=(0.4, 1.2), pause_s=(0.1, 0.35)) -> np.ndarray:
    """When a sender on a busy machine pushes samples due at ``times`` (s, increasing): now and
    then (every ``every_s`` s) it sleeps for ``pause_s`` s, then pushes what it owes at once.
    Returns the push times (a sample is never pushed before it is due)."""
    due = np.asarray(times, dtype=float).copy()
    t = float(due[0]) + rng.uniform(*every_s)
    while t < due[-1]:
        length = rng.uniform(*pause_s)
        late = (due >= t) & (due < t + length)
        due[late] = t + length
        t += length + rng.uniform(*every_s)
    return due


def guided_split(dataset: dict, n_replayed: int, seed: int, slow=(0.5, 1.0), replayed_slow=None):
    """``dataset`` split by content-independent position: each class's first ``n_replayed``
    takes replayed, the rest learned from. With ``slow`` (s, a range), every take gets a slow
    phase in its middle (:func:`slowed_middle`) of a length drawn in it (the replayed ones in
    ``replayed_slow``, default ``slow``); None: the takes as they are."""
    rng = np.random.default_rng(seed)
    train, replayed = {}, []
    for klass in sorted(dataset):
        demos = sorted(dataset[klass], key=lambda d: d.name)
        out = []
        for k, demo in enumerate(demos):
            span = (replayed_slow or slow) if k < n_replayed else slow
            if slow is not None:
                demo = slowed_middle(demo, float(rng.uniform(*span)))
            out.append(demo)
        train[klass] = out[n_replayed:]
        replayed += [(klass, d) for d in out[:n_replayed]]
    return train, replayed


def replay_over_lsl(model, takes, name: str, rng, late: bool, rest_s=(1.5, 1.5), rate=100.0,
                    on_prediction=None):  # fmt: skip
    """Push ``takes`` [(class, demo)] one after the other through an LSL outlet named ``name``
    (the hand in mm, ``rate`` Hz declared), each held still ``rest_s`` before and after (the
    hand jumps, in one step, from one take's end to the next one's start), into a
    :class:`LiveSession` on ``start="still"`` running on its threads. Each sample is pushed
    when due by a sender that with ``late`` sleeps 0.1-0.35 s now and then and pushes its
    backlog at once (:func:`late_pushes`), stamped when that sender pushes it (what LSL's
    default stamps: a pause, then the backlog microseconds apart). The stamps are those planned
    pushes, not this process's actual ones: the sender here shares the session's process, and
    on a loaded machine its own pushes wait for the session's threads (Python's lock) several
    milliseconds each, a backlog then arriving at half its rate or slower, which no sender
    pushing "at once" does (and which cannot be told from a stream that resumes faster than it
    declares: ``promp.live.restamp``); a backlog is pushed in one chunk (:func:`tests.lsl_push.
    push_when_due`). A busy machine still delays when the samples arrive.
    Returns the
    session's ended movements, the predictions and, per take, the stamps and due times of its
    samples (session clock; the stamps are the planned pushes, which this process's own
    pushes can trail by most of a second on a busy machine)."""
    import pylsl

    from promp.live.lsl import LslTransport
    from promp.live.session import LiveOptions, LiveSession
    from promp.live.status import Condition
    from tests.conftest import wait_until
    from tests.lsl_push import hand_outlet, push_when_due

    rows, spans = [], []
    n = 0
    for _, demo in takes:  # each take held still before and after (the hand jumps between)
        step = demo.sample_period
        held_demo = held(demo, rest_s[0], rest_s[1])
        xyz = held_demo.select(["x", "y", "z"])
        rows.append(xyz)
        first = n + int(round(rest_s[0] / step))
        spans.append((first, first + demo.n_samples))
        n += xyz.shape[0]
    table = np.vstack(rows) * 1000.0
    outlet = hand_outlet(name, rate=rate)
    predictions = []

    def predicted(p):
        predictions.append(p)
        if on_prediction is not None:
            on_prediction(p)

    session = LiveSession(model, [f"hand={name}:hx,hy,hz"], LslTransport(),
                          LiveOptions(start="still"), on_prediction=predicted)  # fmt: skip
    session.start()
    try:
        wait_until(lambda: session.snapshot().statuses[0].condition is Condition.OK,
                   timeout=60.0, what="the session to find the replayed stream")  # fmt: skip
        assert outlet.wait_for_consumers(PATIENCE_S)
        due = np.arange(table.shape[0]) / rate
        pushes = late_pushes(due, rng) if late else due
        start = pylsl.local_clock() + 0.1
        planned = start + pushes
        index = np.arange(planned.size)  # a backlog's samples pushed 20 us apart
        first = np.maximum.accumulate(np.where(np.r_[True, np.diff(planned) > 0], index, 0))
        stamps = planned + 2e-5 * (index - first)
        push_when_due(outlet, table, planned, stamps)
        wait_until(lambda: session.snapshot().movement is None, timeout=60.0,
                   what="the last movement's end")  # fmt: skip
        ended = list(session.snapshot().ended)
    finally:
        session.close()
    return ended, predictions, [(stamps[a:b], start + due[a:b]) for a, b in spans]


def robot_side_code(document: str, test: str, what: str, name: str) -> str:
    """The python block of ``docs/DOCUMENT`` marked ``<!-- run by tests/TEST: WHAT ...-->``
    (a robot-side reader of the predictor's streams), for the outputs ``name``."""
    import re

    from tests.conftest import REPO

    text = (REPO / "docs" / document).read_text()
    mark = rf"<!-- run by tests/{re.escape(test)}: {re.escape(what)}[^\n]*-->"
    code = re.search(mark + r"\n```python\n(.*?)```", text, re.S).group(1)
    assert code.count('NAME = "icub"') == 1
    return code.replace('NAME = "icub"', f"NAME = {name!r}")


def one_ulp_changed(source, target) -> None:
    """A copy at ``target`` of the session file ``source`` (MCAP) with its first recorded
    prediction's phase moved by one ulp, everything else as recorded."""
    import json

    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(source, "rb") as read, open(target, "wb") as written:
        reader = make_reader(read)
        writer = Writer(written)
        writer.start(profile="", library="test")
        schema = writer.register_schema(name="x", encoding="jsonschema", data=b"{}")
        channels: dict[str, int] = {}
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, dict(record.metadata))
        done = False
        for _, channel, message in reader.iter_messages():
            if channel.topic not in channels:
                channels[channel.topic] = writer.register_channel(channel.topic, "json", schema)
            data = json.loads(message.data)
            if channel.topic == "/predictions" and not done:
                data["phase"][0] = float(np.nextafter(data["phase"][0], 2.0))  # one ulp
                done = True
            writer.add_message(channels[channel.topic], message.log_time,
                               json.dumps(data).encode(), message.publish_time)  # fmt: skip
        writer.finish()


def instances_made(monkeypatch, module, name: str) -> list:
    """Replace the class ``module.name`` (for this test) with a subclass that records each
    instance it makes, in the list returned."""
    made: list = []
    base = getattr(module, name)

    class Recorded(base):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(module, name, Recorded)
    return made
