"""A transport without LSL for the live stages' tests: streams the test pushes samples into,
inlets that hand them out, outlets that keep what was pushed, and a clock the test moves."""

from __future__ import annotations

import itertools

import numpy as np

from promp.data import Demonstration
from promp.live.transport import OutletSpec, StreamDescription, StreamLost

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


# ---------------------------------------------------------------------------- shared data

_CACHE: dict = {}


def flt_dataset():
    """The shared set lab-records-flt (the test is skipped when it is absent)."""
    import pytest

    from promp.datasets import load_records_dataset
    from tests.conftest import SHARED_DATA

    root = SHARED_DATA / "lab-records-flt"
    if not root.is_dir():
        pytest.skip(f"shared lab recordings not found at {root}")
    if "flt" not in _CACHE:
        _CACHE["flt"] = load_records_dataset(root)
    return _CACHE["flt"]


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


def flt_workspace(root, per_class: int = 6, modalities: str = "hand=x,y,z", settings=None):
    """A studio workspace at ``root`` of lab-records-flt's ``modalities``: each class's
    demonstrations but its first (the one the tests replay), at most ``per_class``; learning
    ``settings`` given (default: hand_model's, fast and deterministic)."""
    from app.io.dataset_import import read_folder
    from app.io.workspace import Workspace
    from promp.datasets import parse_modalities
    from tests.conftest import SHARED_DATA

    flt_dataset()  # skips when absent
    data, _ = read_folder(SHARED_DATA / "lab-records-flt", "records", parse_modalities(modalities))
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
