"""The online predictor: each update is promp.evidence.infer on the movement's samples so far
(the same numbers, exactly), whether one stream or several at different rates feed it; the
predicted remainder at a stated rate."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from promp.evidence.pipeline import infer
from promp.inference import Observation, trajectory_at
from promp.learn import fit
from promp.model import Settings
from promp.rigs.streams import Stream, on_one_clock
from tests.live_fakes import (
    FakeStream,
    FakeTransport,
    flt_dataset,
    hand_model,
    held,
    instances_made,
    replay,
    session_with,
)
from tests.synthetic import LAYOUT, make_dataset


def same_inference(online, offline) -> None:
    """Every number the outlets publish, equal within 1e-9 (the online likelihood adds the
    new rows' terms to sums it kept: the same numbers but for the order of the additions)."""
    assert online.index == offline.index
    close = {"rtol": 0.0, "atol": 1e-9}
    assert_allclose(online.probabilities, offline.probabilities, **close)
    for a, b in ((online.timing.duration, offline.timing.duration),
                 (online.timing.observed_fraction, offline.timing.observed_fraction)):
        assert_allclose([a.value, a.low, a.high], [b.value, b.low, b.high], **close)
    assert_allclose(online.posterior.mean, offline.posterior.mean, **close)
    assert online.observed_until == offline.observed_until


@pytest.mark.parametrize("recognition", [None, "mixture:0.6"])
def test_each_update_is_the_offline_inference_on_the_samples_so_far(recognition) -> None:
    model = hand_model()
    if recognition is not None:
        model = dataclasses.replace(model, settings=dataclasses.replace(
            model.settings, recognition=recognition))  # fmt: skip
    demo = held(flt_dataset()["left"][0], 1.0, 1.0)
    transport = FakeTransport()
    stream = transport.add(FakeStream("MocapHand", ("hx", "hy", "hz"), rate=100.0))
    session = session_with(model, ["hand=MocapHand:hx,hy,hz@mm"], transport, start="still")
    values_mm = demo.select(["x", "y", "z"]) * 1000.0
    stamps = replay(session, transport, stream, demo.times, values_mm)
    predictions = session.predictions
    assert len(predictions) > 30
    assert [p.seq for p in predictions] == list(range(1, len(predictions) + 1))
    for p in predictions:
        i0 = int(np.flatnonzero(stamps == p.start)[0])
        times = stamps[i0:i0 + p.n_observed]
        assert p.last == times[-1]
        obs = Observation(times - times[0], values_mm[i0:i0 + p.n_observed] * 1e-3, ("hand",))
        same_inference(p.inference, infer(model, obs))
    # while the movement goes on, each prediction sees more rows; the last is on the ended
    # movement's final rows (its end cut the stillness after the motion: fewer rows)
    assert np.all(np.diff([p.n_observed for p in predictions[:-1]]) > 0)
    (movement,) = session.snapshot().ended
    assert predictions[-1].n_observed == len(movement) < predictions[-2].n_observed
    assert predictions[-1].last == movement.times[-1]
    final = predictions[-1].probabilities
    assert_allclose(final.sum(), 1.0)
    assert final.argmax() == model.names.index("left")


def test_streams_at_two_rates_are_observed_on_the_xdf_readers_clock() -> None:
    dataset = make_dataset(seed=3, n_demos=5)
    model = fit(dataset, LAYOUT, Settings(n_basis=7, width=1.0, noise_scale=1.5,
                                          duration_temperature=1.0))  # fmt: skip
    demo = dataset["right"][0]
    t = demo.times - demo.times[0]
    fine = np.arange(0.0, t[-1], 0.01)  # the hand at 100 Hz, the head at 25 Hz, in degrees
    hand = np.column_stack([np.interp(fine, t, c) for c in demo.select(["x", "y", "z"]).T])
    head = np.degrees(demo.select(["roll", "pitch", "yaw"]))[::2]
    transport = FakeTransport()
    mocap = transport.add(FakeStream("Mocap", ("x", "y", "z"), ("m",) * 3, rate=100.0))
    tracker = transport.add(FakeStream("Head", ("r", "p", "y"), ("deg",) * 3, rate=25.0,
                                       type="HeadTracker"))  # fmt: skip
    session = session_with(model, ["hand=Mocap:x,y,z", "head=type=HeadTracker:0,1,2"],
                           transport, start="call")  # fmt: skip
    t0 = transport.now + 0.001
    session.begin(time=t0)
    stamps_hand, stamps_head = t0 + fine, t0 + t[::2]
    k_hand = k_head = 0
    while k_hand < fine.size:
        transport.now += 1 / 60
        a, b = k_hand, int(np.searchsorted(stamps_hand, transport.now, side="right"))
        c, d = k_head, int(np.searchsorted(stamps_head, transport.now, side="right"))
        if b > a:
            mocap.push(stamps_hand[a:b], hand[a:b])
        if d > c:
            tracker.push(stamps_head[c:d], head[c:d])
        k_hand, k_head = b, d
        session.step()
    streams = [Stream("hand", stamps_hand, hand, ("m",) * 3),
               Stream("head", stamps_head, np.radians(head), ("rad",) * 3)]  # fmt: skip
    end = min(stamps_hand[-1], stamps_head[-1])
    times, (h, g) = on_one_clock(streams, t0, end, None, "offline")
    assert session.predictions and times[0] == t0
    for p in session.predictions:
        n = p.n_observed
        assert_array_equal(p.observation.times, times[:n] - times[0])
        assert_allclose(p.observation.values, np.hstack([h[:n], np.unwrap(g[:n], axis=0)]),
                        rtol=0, atol=1e-12)  # fmt: skip
        same_inference(p.inference, infer(model, p.observation))
    assert session.predictions[-1].n_observed >= times.size - 2


def test_the_remainder_runs_at_its_rate_to_the_predicted_end() -> None:
    model = hand_model()
    demo = held(flt_dataset()["top"][0], 1.0, 0.0)
    transport = FakeTransport()
    stream = transport.add(FakeStream("MocapHand", ("x", "y", "z"), ("m",) * 3))
    session = session_with(model, ["hand=MocapHand:0,1,2"], transport, start="still",
                           remainder="hand", remainder_rate=50.0)  # fmt: skip
    replay(session, transport, stream, demo.times, demo.select(["x", "y", "z"]))
    assert len(session.predictions) >= 10, "no movement predicted: the test would check nothing"
    for p in session.predictions[::10]:
        r = p.remainder
        inference = p.inference
        left = max(inference.duration - inference.observed_until, 0.0)
        assert (r.modality, r.columns) == ("hand", ("x", "y", "z"))
        assert r.after[-1] == left and np.all(np.diff(r.after[:-1]) > 0.0199)
        if left > 0.02:  # the steps run up to the end: the last one within a step of it
            assert r.after.size >= 2 and left - 0.02 - 1e-12 <= r.after[-2] < left
        assert_allclose(r.after[:-1], np.arange(1, r.after.size) / 50.0)
        phases = np.clip((inference.observed_until + r.after) / inference.duration, 0, 1)
        mean, std = trajectory_at(model, inference.posterior, inference.alpha, phases)
        assert_array_equal(r.mean, mean)
        assert_array_equal(r.std, std)
        assert_allclose(r.mean[-1], inference.prediction.mean[-1], atol=1e-12)
        assert_allclose(p.remaining.value, left, rtol=1e-12)


# The predictor alone (no session): what it refuses, the observation it makes of the rows,
# each update's numbers, on a model of the synthetic set (a hand in metres, a head in radians).

_MODELS: dict = {}


def synthetic_model():
    if "model" not in _MODELS:
        dataset = make_dataset(seed=3, n_demos=5)
        _MODELS["model"] = fit(dataset, LAYOUT, Settings(n_basis=7, width=1.0, noise_scale=1.5,
                                                         duration_temperature=1.0))  # fmt: skip
        _MODELS["demo"] = dataset["right"][0]
    return _MODELS["model"], _MODELS["demo"]


def test_the_predictor_refuses_what_it_cannot_observe_or_give() -> None:
    import math

    import pytest

    from promp.live.predictor import OnlinePredictor

    model, _ = synthetic_model()
    both = {"hand": slice(0, 3), "head": slice(3, 6)}
    for columns in ({"hand": slice(0, 3), "eyes": slice(3, 6)}, {}):
        with pytest.raises(ValueError):
            OnlinePredictor(model, columns)
    with pytest.raises(ValueError):
        OnlinePredictor(model, both, alpha_method="fastest")
    with pytest.raises(ValueError):
        OnlinePredictor(model, both, remainder="eyes")
    for rate in (0.0, -50.0, math.nan, math.inf):
        with pytest.raises(ValueError):
            OnlinePredictor(model, both, rate=rate)
    p = OnlinePredictor(model, {"head": slice(0, 3)}, "model", remainder="hand", rate=1e-3)
    assert (p.modalities, p.alpha_method, p.remainder, p.rate, p.n_points) == (
        ("head",), "model", "hand", 1e-3, None)
    assert isinstance(p.rate, float) and OnlinePredictor(model, both, rate=7).rate == 7.0
    default = OnlinePredictor(model, both)
    assert (default.alpha_method, default.remainder, default.rate) == ("ml", None, 50.0)


def test_the_observation_takes_each_modality_from_its_columns_in_layout_order() -> None:
    from promp.live.predictor import OnlinePredictor

    model, _ = synthetic_model()
    # the head first in the rows, the hand after a column of something else
    p = OnlinePredictor(model, {"head": slice(0, 3), "hand": slice(4, 7)})
    assert p.modalities == ("hand", "head")
    times = np.array([10.0, 10.5, 11.0, 11.5])
    yaw = np.array([3.0, -3.1, -3.0, 3.1])  # across pi: unwrapped
    x = np.array([0.0, 5.0, -1.0, 6.0])  # jumps of metres: kept as they are
    # roll and pitch 4 rad apart: unwrapped along time only, never across the columns
    values = np.column_stack([np.full(4, -2.0), np.full(4, 2.0), yaw, np.full(4, 9.0), x,
                              np.ones(4), 2 * np.ones(4)]).astype(np.float32)  # fmt: skip
    obs = p.observation(times, values)
    assert obs.values.dtype == np.float64 and obs.modalities == ("hand", "head")
    assert_array_equal(obs.times, [0.0, 0.5, 1.0, 1.5])
    assert_array_equal(obs.values[:, 0], values[:, 4])
    assert_array_equal(obs.values[:, 1:3], values[:, 5:7])
    assert_allclose(obs.values[:, 5], np.unwrap(yaw.astype(np.float32).astype(float)))
    assert obs.values[1, 5] > 3.0 and obs.values[:, 3:5].tolist() == [[-2.0, 2.0]] * 4
    assert values[1, 2] < 0  # the caller's rows untouched
    hand_only = OnlinePredictor(model, {"hand": slice(0, 3)}).observation(
        times, np.column_stack([x, x, x]))  # fmt: skip
    assert_array_equal(hand_only.values[:, 0], x)


def test_each_update_extends_the_movement_or_begins_a_new_one() -> None:
    import time

    from promp.live.predictor import OnlinePredictor

    model, demo = synthetic_model()
    rows = demo.values
    t = 100.0 + demo.times - demo.times[0]
    p = OnlinePredictor(model, {"hand": slice(0, 3), "head": slice(3, 6)}, n_points=17)
    first = p.predict(1, t[:20], rows[:20])
    before = time.perf_counter()
    second = p.predict(1, t[:40], rows[:40])
    spent = time.perf_counter() - before
    assert (first.seq, second.seq, second.movement) == (1, 2, 1)
    assert (second.start, second.last) == (t[0], t[39]) and type(second.start) is float
    assert 0.0 <= second.compute_s <= spent
    assert second.n_observed == 40 and second.remainder is None
    assert second.inference.prediction.mean.shape[0] == 17
    same_inference(second.inference, infer(model, second.observation))
    assert second.elapsed == second.inference.observed_until == t[39] - t[0]
    assert_array_equal(second.probabilities, second.inference.probabilities)
    assert second.primitive == second.inference.primitive == "right"
    assert second.phase == second.inference.timing.observed_fraction
    assert second.duration == second.inference.timing.duration
    assert second.remaining == second.inference.timing.remaining_after(second.elapsed)
    # a new movement: the evidence of its own rows only, whatever came before
    third = p.predict(2, t[25:45], rows[25:45])
    assert (third.seq, third.movement, third.start, third.n_observed) == (3, 2, t[25], 20)
    same_inference(third.inference, infer(model, third.observation))
    # the speed's method given is the one inferred with
    fresh = OnlinePredictor(model, {"hand": slice(0, 3), "head": slice(3, 6)}, "model")
    again = fresh.predict(0, t[:30], rows[:30])
    same_inference(again.inference, infer(model, again.observation, alpha_method="model"))


def test_the_columns_of_inputs_side_by_side() -> None:
    import pytest

    from promp.live.predictor import observed_columns

    assert observed_columns(["hand", "head", "emg"], [3, 2.0, 4]) == {
        "hand": slice(0, 3), "head": slice(3, 5), "emg": slice(5, 9)}
    assert observed_columns([], []) == {}
    with pytest.raises(ValueError):
        observed_columns(["hand", "head"], [3])


def test_the_remainder_of_a_modality_not_observed_at_its_rate() -> None:
    from promp.live.predictor import OnlinePredictor

    model, demo = synthetic_model()
    p = OnlinePredictor(model, {"hand": slice(0, 3)}, remainder="head", rate=20.0)
    for n in (15, demo.n_samples):  # early, and the whole movement (little or nothing left)
        pred = p.predict(1, demo.times[:n], demo.values[:n, :3])
        inference, r = pred.inference, pred.remainder
        left = max(inference.duration - inference.observed_until, 0.0)
        assert (r.modality, r.columns) == ("head", ("roll", "pitch", "yaw"))
        assert r.after[-1] == left
        assert_allclose(r.after[:-1], np.arange(1, r.after.size) / 20.0)
        assert np.all(r.after[:-1] < left) and left - r.after[:-1].max(initial=0) <= 0.05
        phases = np.clip((inference.observed_until + r.after) / inference.duration, 0, 1)
        mean, std = trajectory_at(model, inference.posterior, inference.alpha, phases)
        assert_array_equal(r.mean, mean[:, 3:6])
        assert_array_equal(r.std, std[:, 3:6])
    assert r.after.size < 5  # the whole movement seen: its end is near


def test_a_movement_s_updates_extend_one_evidence_and_a_new_movement_begins_another(
        monkeypatch) -> None:  # fmt: skip
    """The cost: each update of a movement extends the evidence of its earlier rows (built
    again, the numbers are the same: only the count of evidences built tells)."""
    import promp.live.predictor
    from promp.live.predictor import OnlinePredictor

    built = instances_made(monkeypatch, promp.live.predictor, "Evidence")
    model, demo = synthetic_model()
    p = OnlinePredictor(model, {"hand": slice(0, 3), "head": slice(3, 6)})
    for n in (10, 14, 18):
        p.predict(1, demo.times[:n], demo.values[:n])
    assert len(built) == 1
    p.predict(2, demo.times[20:30], demo.values[20:30])
    p.predict(2, demo.times[20:34], demo.values[20:34])
    assert len(built) == 2


def test_a_remainder_whose_end_falls_on_a_step_ends_once() -> None:
    from types import SimpleNamespace as Of

    from promp.live.predictor import OnlinePredictor

    model, demo = synthetic_model()
    p = OnlinePredictor(model, {"hand": slice(0, 3)}, remainder="hand", rate=20.0)
    real = p.predict(1, demo.times[:15], demo.values[:15, :3]).inference
    inference = Of(observed_until=0.5, duration=1.5, posterior=real.posterior, alpha=real.alpha)
    r = p._remainder(inference)
    assert_allclose(r.after, np.arange(1, 21) / 20.0)  # the end (1 s left) once, last
    assert r.after[-1] == 1.0 and r.after.size == 20
