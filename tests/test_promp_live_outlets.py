"""The prediction outlets: each published prediction's remainder rows (seq, movement, row,
rows, seconds after, mean, std), and the wait for the outlets' readers."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_array_equal

from promp.live.outlets import PredictionOutlets, outlet_specs, remainder_rows
from promp.live.session import LiveOptions, LiveSession
from tests.live_fakes import FakeOutlet, FakeStream, FakeTransport, replay, synthetic_model
from tests.synthetic import make_dataset


def test_each_prediction_s_remainder_is_published_row_by_row() -> None:
    transport = FakeTransport()
    stream = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    outlets = PredictionOutlets(outlet_specs(synthetic_model(), "robot", "hand"),
                                transport.outlet)  # fmt: skip
    predictions: list = []
    session = LiveSession(synthetic_model(), ["hand=Hand:0,1,2"], transport,
                          LiveOptions(start="call", remainder="hand", remainder_rate=20.0),
                          outlets=outlets, on_prediction=predictions.append)  # fmt: skip
    session.connect()
    session.step()
    demo = make_dataset(seed=11, n_demos=1)["left"][0]
    session.begin()
    replay(session, transport, stream, demo.times - demo.times[0], demo.select(["x", "y", "z"]))
    session.close()
    pushed = transport.outlets["robot-remainder"].pushed
    assert len(predictions) >= 3 and len(pushed) == len(predictions)
    for p, (rows, stamp) in zip(predictions, pushed, strict=True):
        r = p.remainder
        k = r.after.shape[0]
        assert stamp == p.last and rows.shape == (k, 4 + 1 + 2 * len(r.columns))
        assert_array_equal(rows, remainder_rows(p))
        assert_array_equal(rows[:, 0], p.seq)
        assert_array_equal(rows[:, 1], p.movement)
        assert_array_equal(rows[:, 2], np.arange(k))
        assert_array_equal(rows[:, 3], k)
        assert_array_equal(rows[:, 4], r.after)
        assert_array_equal(rows[:, 5:5 + len(r.columns)], r.mean)
        assert_array_equal(rows[:, 5 + len(r.columns):], r.std)


class Waiting(FakeOutlet):
    """An outlet that has a reader or not, and records how long it was asked to wait."""

    def __init__(self, spec, read: bool):
        super().__init__(spec)
        self.read, self.waits = read, []

    def wait_for_consumers(self, timeout: float) -> bool:
        self.waits.append(timeout)
        return self.read


def test_the_wait_for_readers_asks_each_outlet_within_the_deadline() -> None:
    specs = outlet_specs(synthetic_model(), "robot", None)
    made: dict = {}

    def open_outlet(spec):
        made[spec.name] = Waiting(spec, read=not spec.name.endswith("events"))
        return made[spec.name]

    outlets = PredictionOutlets(specs, open_outlet)
    assert outlets.wait_for_readers(2.0, ["probabilities", "timing"])
    assert not outlets.wait_for_readers(2.0)  # the events outlet has no reader
    assert not outlets.wait_for_readers(2.0, ["events"])
    for outlet in made.values():
        assert outlet.waits and all(0.0 <= w <= 2.0 for w in outlet.waits)
    plain = PredictionOutlets(specs, FakeOutlet)  # cannot tell: counts as read
    assert plain.wait_for_readers(0.0)


def test_the_outlets_layouts_of_an_output_name() -> None:
    import pytest

    from promp.live.outlets import TIMING_LABELS, TIMING_UNITS

    model = synthetic_model()
    for bad in ("", "two words", "tab\there", "line\n"):
        with pytest.raises(ValueError):
            outlet_specs(model, bad, None)
    with pytest.raises(ValueError):
        outlet_specs(model, "robot", "tail")
    assert TIMING_LABELS == (
        "seq", "movement", "start", "elapsed", "phase", "phase_low", "phase_high", "duration",
        "duration_low", "duration_high", "remaining", "remaining_low", "remaining_high",
        "primitive", "n_observed", "committed")  # fmt: skip
    assert TIMING_UNITS == ("count", "count", "s", "s", "share", "share", "share", "s", "s",
                            "s", "s", "s", "s", "index", "count", "index")  # fmt: skip
    specs = outlet_specs(model, "robot", None)
    assert list(specs) == ["probabilities", "timing", "events"]
    names = tuple(p.name for p in model.primitives)
    p, t, e = specs["probabilities"], specs["timing"], specs["events"]
    assert (p.name, p.type, p.source_id, p.labels, p.units, p.rate, p.format) == (
        "robot-probabilities", "Probabilities", "promp-live-robot-probabilities",
        ("seq", "movement", *names), ("count", "count") + ("probability",) * len(names), 0.0,
        "double64")  # fmt: skip
    assert (t.name, t.type, t.source_id, t.labels, t.units, t.format) == (
        "robot-timing", "Timing", "promp-live-robot-timing", TIMING_LABELS, TIMING_UNITS,
        "double64")  # fmt: skip
    assert (e.name, e.type, e.source_id, e.labels, e.units, e.format) == (
        "robot-events", "Markers", "promp-live-robot-events", ("event",), ("",), "string")
    r = outlet_specs(model, "arm", "head")["remainder"]
    assert (r.name, r.type, r.source_id, r.format) == (
        "arm-remainder", "Trajectory", "promp-live-arm-remainder", "double64")
    assert r.labels == ("seq", "movement", "index", "count", "after", "roll", "pitch", "yaw",
                        "roll_std", "pitch_std", "yaw_std")  # fmt: skip
    assert r.units == ("count",) * 4 + ("s",) + ("rad",) * 6


class Prediction:
    """What the outlets read of a prediction, made by hand."""

    def __init__(self, committed=None, remainder=None):
        from types import SimpleNamespace as Of

        self.seq, self.movement, self.start, self.last, self.elapsed = 7, 3, 100.5, 101.25, 0.75
        self.probabilities = np.array([0.25, 0.75])
        self.phase, self.duration = Of(value=0.3, low=0.2, high=0.4), Of(value=2.5, low=2, high=3)
        self.remaining = Of(value=1.75, low=1.25, high=2.25)
        self.inference, self.n_observed = Of(index=1), 76
        self.committed = None if committed is None else Of(index=committed)
        self.remainder = remainder


def test_each_prediction_and_event_is_pushed_to_its_outlet_at_its_stamp() -> None:
    from types import SimpleNamespace as Of

    from promp.live.outlets import EventSink, PredictionSink, probabilities_row, timing_row
    from promp.live.sinks import Output
    from promp.live.status import LiveEvent

    assert_array_equal(probabilities_row(Prediction()), [7, 3, 0.25, 0.75])
    row = timing_row(Prediction())
    assert row.dtype == np.float64
    assert_array_equal(row, [7, 3, 100.5, 0.75, 0.3, 0.2, 0.4, 2.5, 2, 3, 1.75, 1.25, 2.25,
                             1, 76, -1])  # fmt: skip
    assert timing_row(Prediction(committed=0))[-1] == 0
    transport = FakeTransport()
    outlets = PredictionOutlets(outlet_specs(synthetic_model(), "robot", "hand"),
                                transport.outlet)  # fmt: skip
    assert outlets.source_ids == tuple(f"promp-live-robot-{k}" for k in (
        "probabilities", "timing", "events", "remainder"))  # fmt: skip
    remainder = Of(after=np.array([0.5, 1.0]), mean=np.ones((2, 3)), std=np.zeros((2, 3)))
    sink, events = PredictionSink(outlets), EventSink(outlets)
    assert (sink.name, sink.lossless, events.name, events.lossless) == (
        "prediction outlets", False, "events outlet", False)  # fmt: skip
    said = (LiveEvent(100.0, "movement 3 started"), LiveEvent(100.5, "x"))
    output = Output(102.0, said, ("b",), (Prediction(), Prediction(remainder=remainder)))
    part = sink.view(output)
    assert (part.time, part.events, part.boundaries, part.predictions) == (
        102.0, (), (), output.predictions)  # fmt: skip
    assert sink.view(Output(1.0, said)) is None and events.view(Output(1.0, (), ("b",))) is None
    assert sink.take(part) == ()
    pushed = {k: o.pushed for k, o in transport.outlets.items()}
    assert [s for _, s in pushed["robot-probabilities"]] == [101.25, 101.25]
    assert_array_equal(pushed["robot-probabilities"][0][0], [probabilities_row(Prediction())])
    assert_array_equal(pushed["robot-timing"][1][0], [timing_row(Prediction())])
    assert [s for _, s in pushed["robot-timing"]] == [101.25, 101.25]
    ((rows, stamp),) = pushed["robot-remainder"]  # only the prediction with a remainder
    assert stamp == 101.25 and rows.shape == (2, 11)
    part = events.view(output)
    assert (part.time, part.events, part.predictions) == (102.0, said, ())
    assert events.take(part) == ()
    assert pushed["robot-events"] == [(["movement 3 started"], 100.0), (["x"], 100.5)]
    closed = []
    for outlet in transport.outlets.values():
        outlet.close = lambda o=outlet: closed.append(o.spec.name)
    events.close()
    assert closed == []  # the events outlet is closed with the others
    sink.close()
    assert sorted(closed) == sorted(transport.outlets)
    without = PredictionOutlets(outlet_specs(synthetic_model(), "r", None), FakeTransport().outlet)
    without.publish(Prediction(remainder=remainder))  # no remainder outlet: nothing to push


def test_a_wait_for_readers_of_no_time_asks_each_outlet_for_none() -> None:
    made: list = []

    def open_outlet(spec):
        made.append(Waiting(spec, read=True))
        return made[-1]

    outlets = PredictionOutlets(outlet_specs(synthetic_model(), "robot", "hand"), open_outlet)
    assert outlets.wait_for_readers(0.0)
    assert [o.waits for o in made] == [[0.0]] * 4  # every outlet, none past the deadline
    assert outlets.wait_for_readers(-1.0, ["timing"])
    assert made[1].waits == [0.0, 0.0]
