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
