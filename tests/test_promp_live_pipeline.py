"""The live pipeline's step (promp.live.pipeline), driven with hand-made arrivals: no thread,
no transport, no clock. What a step returns (events in order, boundaries, predictions) and
what its state keeps (the latest prediction, the inputs said to lag) for the calls, the
samples, the losses, the pauses and the markers that arrive."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from promp.live.commitment import CommitRule
from promp.live.options import LiveOptions
from promp.live.pipeline import Arrivals, Call, belief, build, shown, step
from promp.live.segmenter import Belief, StillRule
from promp.live.source import Opened, Pulled
from promp.live.status import LiveEvent
from tests.live_fakes import FakeStream, synthetic_model

RATE = 100.0


def motion(t0: float, n: int, rate: float = RATE) -> tuple[np.ndarray, np.ndarray]:
    """``n`` samples after ``t0`` of a hand that moves (metres)."""
    t = t0 + np.arange(1, n + 1) / rate
    return t, np.column_stack([np.sin(t), np.cos(t), t]) * 0.1


def started(inputs=("hand=Hand:0,1,2",), streams=(("Hand", 3),), rates=None, **options):
    """A pipeline with its streams opened at 0 (declaring ``rates``, default :data:`RATE`;
    a Record button starts movements unless ``options`` say otherwise)."""
    options = {"start": "call", **options}
    state = build(synthetic_model(), list(inputs), LiveOptions(**options), now=0.0)
    rates = rates or [RATE] * len(streams)
    descriptions = [FakeStream(name, [f"c{i}" for i in range(k)], rate=rate).description
                    for (name, k), rate in zip(streams, rates, strict=True)]  # fmt: skip
    state, events, _, _ = step(state, Arrivals(0.0, tuple(Opened(i, d) for i, d in
                                                          enumerate(descriptions))))
    assert [e.time for e in events] == [0.0] * len(descriptions)  # each stream opened, now
    return state


def test_build_keeps_the_options_the_step_needs():
    model = synthetic_model()
    state = build(model, ["hand=Hand:0,1,2"],
                  LiveOptions(max_movement_s=7.5, min_observed=4), now=12.0)  # fmt: skip
    assert state.wait_s == 7.5 and isinstance(state.wait_s, float)
    assert state.min_observed == 4
    assert dict(state.newest) == {"hand": 12.0}
    assert state.committing is None and state.prediction is None
    assert list(state.timebase.names) == ["hand"]
    assert [s.since for s in state.source.statuses()] == [12.0]  # waiting since the start
    assert state.timebase.rate is None
    at_rate = build(model, ["hand=Hand:0,1,2"], LiveOptions(rate=50.0))
    assert at_rate.timebase.rate == 50.0 and dict(at_rate.newest) == {"hand": 0.0}  # from 0
    assert state.segmenter.rule == StillRule.of(model, ["hand"])  # what the hand learned
    head = build(model, ["head=Head:0,1,2"], LiveOptions(remainder="head", n_points=9,
                                                         remainder_rate=20.0))  # fmt: skip
    assert head.segmenter.rule == StillRule.of(model, ["head"])  # angles are watched too
    p = head.predictor
    assert (p.remainder, p.n_points, p.rate) == ("head", 9, 20.0)
    decided = build(model, ["hand=Hand:0,1,2"], LiveOptions(decide=CommitRule(0.9)))
    assert decided.committing is not None


def test_notes_come_first_then_the_movement_and_its_prediction():
    state = started()
    note = LiveEvent(0.2, "a note")
    t, v = motion(0.0, 50)
    state, events, boundaries, predictions = step(
        state, Arrivals(0.5, calls=(Call("start", 0.0, "left"),), pulled={0: Pulled(t, v)},
                        notes=(note,)))  # fmt: skip
    assert events[0] is note and len(events) == 2 and events[1].time == 0.0
    assert [(b.kind, b.number, b.time) for b in boundaries] == [("start", 1, 0.0)]
    [p] = predictions
    assert (p.seq, p.movement, p.n_observed) == (1, 1, 50)
    assert state.prediction is p and state.predicted == (1, 50)


def test_a_movement_is_predicted_once_per_step_and_only_on_new_rows():
    state = started()
    t, v = motion(0.0, 30)
    state, *_, predictions = step(state, Arrivals(0.3, calls=(Call("start", 0.0),),
                                                  pulled={0: Pulled(t, v)}))  # fmt: skip
    assert [p.n_observed for p in predictions] == [30]
    state, events, boundaries, predictions = step(state, Arrivals(0.35))  # nothing new
    assert (events, boundaries, predictions) == ((), (), ())
    t, v = motion(0.3, 10)
    state, *_, predictions = step(state, Arrivals(0.4, pulled={0: Pulled(t, v)}))
    assert [(p.seq, p.n_observed) for p in predictions] == [(2, 40)]


def test_an_end_that_cuts_the_rows_back_predicts_them_once_more():
    state = started()
    t, v = motion(0.0, 50)
    state, *_ = step(state, Arrivals(0.5, calls=(Call("start", 0.0),), pulled={0: Pulled(t, v)}))
    state, events, boundaries, predictions = step(state, Arrivals(0.6, calls=(Call("end", 0.3),)))
    [end] = boundaries
    assert (end.kind, end.number, end.time, len(end.movement)) == ("end", 1, 0.3, 30)
    assert [(p.seq, p.movement, p.n_observed) for p in predictions] == [(2, 1, 30)]
    assert [e.time for e in events] == [0.3]
    assert state.predicted == (1, 30)


def test_an_end_on_the_rows_already_predicted_predicts_nothing_more():
    state = started()
    t, v = motion(0.0, 50)
    state, *_ = step(state, Arrivals(0.5, calls=(Call("start", 0.0),), pulled={0: Pulled(t, v)}))
    t, v = motion(0.5, 10)  # the rows after the end reach it
    state, _, boundaries, predictions = step(state, Arrivals(0.6, calls=(Call("end", 0.5),),
                                                             pulled={0: Pulled(t, v)}))  # fmt: skip
    assert [len(b.movement) for b in boundaries] == [50]
    assert predictions == () and state.predicted == (1, 50)


@pytest.mark.parametrize("rows, predicted", [(4, False), (5, True)])
def test_no_prediction_before_the_rows_a_movement_needs(rows, predicted):
    state = started(min_observed=5)
    t, v = motion(0.0, rows)
    state, _, _, predictions = step(state, Arrivals(0.1, calls=(Call("start", 0.0),),
                                                    pulled={0: Pulled(t, v)}))  # fmt: skip
    assert len(predictions) == int(predicted)


def test_a_lost_stream_ends_the_movement_and_its_rows_start_again():
    state = started()
    t, v = motion(0.0, 40)
    state, *_ = step(state, Arrivals(0.4, calls=(Call("start", 0.0),), pulled={0: Pulled(t, v)}))
    state, events, boundaries, _ = step(state, Arrivals(0.5, pulled={0: Pulled.LOST}))
    assert [(b.kind, b.number) for b in boundaries] == [("end", 1)]
    assert boundaries[0].time == pytest.approx(0.4)
    assert len(events) == 2  # the stream vanished, the movement ended
    assert state.timebase._buffers["hand"].times.size == 0
    assert state.segmenter.movement is None


def test_a_pause_in_the_stamps_ends_the_movement_at_its_last_row():
    state = started()
    t, v = motion(0.0, 40)
    state, *_ = step(state, Arrivals(0.4, calls=(Call("start", 0.0),), pulled={0: Pulled(t, v)}))
    t, v = motion(1.4, 10)  # a second without samples
    state, events, boundaries, _ = step(state, Arrivals(1.5, pulled={0: Pulled(t, v)}))
    assert [(b.kind, b.number) for b in boundaries] == [("end", 1)]
    assert boundaries[0].time == pytest.approx(0.4)
    assert events[0].time == 1.5 and len(events) == 2
    assert state.timebase._buffers["hand"].times[0] == pytest.approx(1.41)


def test_an_unknown_marker_is_said_once_at_its_time():
    state = started(inputs=("hand=Hand:0,1,2",), streams=(("Hand", 3), ("Marks", 1)),
                    start="marker", markers="Marks")  # fmt: skip
    state, events, boundaries, _ = step(state, Arrivals(1.0, pulled={
        1: Pulled(np.array([0.7]), ["hello"])}))  # fmt: skip
    assert [e.time for e in events] == [0.7] and boundaries == ()
    assert state.segmenter.unknown == []
    _, events, _, _ = step(state, Arrivals(1.1))
    assert events == ()


def test_markers_start_and_end_a_movement():
    state = started(inputs=("hand=Hand:0,1,2",), streams=(("Hand", 3), ("Marks", 1)),
                    start="marker", markers="Marks")  # fmt: skip
    t, v = motion(0.0, 50)
    state, _, boundaries, _ = step(state, Arrivals(0.5, pulled={
        0: Pulled(t, v), 1: Pulled(np.array([0.1, 0.4]), ["start left", "end left"])}))
    assert [(b.kind, b.time) for b in boundaries] == [("start", 0.1), ("end", 0.4)]
    assert boundaries[0].movement is None and len(boundaries[1].movement) == 31


def two_inputs(**options):
    return started(inputs=("hand=Hand:0,1,2", "head=Head:0,1,2"),
                   streams=(("Hand", 3), ("Head", 3)), max_movement_s=1.0, **options)


def test_an_input_silent_longer_than_a_movement_lags_and_its_wait_ends():
    state = two_inputs()
    th, vh = motion(0.0, 20)
    state, *_ = step(state, Arrivals(0.2, calls=(Call("start", 0.0),),
                                     pulled={0: Pulled(th, vh), 1: Pulled(th, vh)}))  # fmt: skip
    assert state.segmenter.movement is not None and state.lagging == frozenset()
    assert dict(state.newest) == {"hand": 0.2, "head": 0.2}
    # the head goes silent: the hand's samples wait for it, up to a movement's longest
    t, v = motion(0.2, 90)
    state, events, boundaries, _ = step(state, Arrivals(1.1, pulled={0: Pulled(t, v)}))
    assert state.lagging == frozenset() and boundaries == ()
    assert state.timebase._buffers["hand"].times.size > 90
    t, v = motion(1.1, 20)
    state, events, boundaries, _ = step(state, Arrivals(1.3, pulled={0: Pulled(t, v)}))
    assert state.lagging == frozenset({"head"})
    assert dict(state.newest) == {"hand": pytest.approx(1.3), "head": 0.2}
    assert [e.time for e in events] == [pytest.approx(1.3), pytest.approx(0.2)]  # lag, end
    assert [b.kind for b in boundaries] == ["end"]
    assert state.timebase._buffers["hand"].times.size == 0  # no longer waits
    assert state.timebase._buffers["head"].times.size > 0
    # said once while it lags
    t, v = motion(1.3, 10)
    state, events, boundaries, _ = step(state, Arrivals(1.4, pulled={0: Pulled(t, v)}))
    assert events == () and boundaries == () and state.lagging == frozenset({"head"})
    assert state.timebase._buffers["hand"].times.size == 0
    # back: no longer lags, and nothing it holds is dropped
    t, v = motion(1.4, 10)
    state, events, _, _ = step(state, Arrivals(1.5, pulled={0: Pulled(t, v), 1: Pulled(t, v)}))
    assert state.lagging == frozenset()
    assert state.timebase._buffers["hand"].times.size > 0


def test_a_step_without_samples_keeps_what_the_inputs_last_sent():
    state = two_inputs()
    t, v = motion(0.0, 20)
    state, *_ = step(state, Arrivals(0.2, pulled={0: Pulled(t, v)}))
    assert dict(state.newest) == {"hand": 0.2, "head": 0.0}
    same = step(state, Arrivals(5.0))[0]
    assert same is state


def test_a_failed_prediction_is_said_and_the_commit_rule_told_of_the_miss(monkeypatch):
    state = started(decide=CommitRule(0.9))
    missed = []
    committing = state.committing
    after = dataclasses.replace(committing)  # the rule's state after the miss

    def miss(number, elapsed):
        missed.append((number, elapsed))
        return after

    def refuse(number, times, values):
        raise ValueError("refused")

    monkeypatch.setattr(type(committing), "missed", lambda self, n, e: miss(n, e))
    monkeypatch.setattr(state.predictor, "predict", refuse)
    t, v = motion(0.0, 30)
    state, events, _, predictions = step(state, Arrivals(0.3, calls=(Call("start", 0.0),),
                                                         pulled={0: Pulled(t, v)}))  # fmt: skip
    assert predictions == () and state.prediction is None
    assert [e.time for e in events] == [0.0, pytest.approx(0.3)]
    assert missed == [(1, pytest.approx(0.29))]  # its first row to its last
    assert state.committing is after
    assert state.predicted == (1, 30)


def test_with_a_commit_rule_each_prediction_carries_the_rule_s_state():
    state = started(decide=CommitRule(0.9))
    t, v = motion(0.0, 30)
    state, _, _, [p] = step(state, Arrivals(0.3, calls=(Call("start", 0.0),),
                                            pulled={0: Pulled(t, v)}))  # fmt: skip
    assert state.committing is not None
    assert p.committed is state.committing.commitment


def test_belief_is_the_prediction_s_movement_primitive_and_phase():
    assert belief(None) is None
    state = started()
    t, v = motion(0.0, 30)
    _, _, _, [p] = step(state, Arrivals(0.3, calls=(Call("start", 0.0),), pulled={0: Pulled(t, v)}))
    assert belief(p) == Belief(1, p.primitive, p.phase.high)


def test_a_marker_s_label_is_quoted_and_cut_to_its_limit():
    assert shown("start left") == repr("start left")
    assert shown("a" * 60) == repr("a" * 60)
    assert shown("a" * 61) == repr("a" * 60 + "...")
    assert shown("abcdef", limit=3) == repr("abc...")


def test_a_record_call_s_label_is_its_movement_s():
    state = started()
    t, v = motion(0.0, 30)
    state, *_ = step(state, Arrivals(0.3, calls=(Call("start", 0.0, "left"),),
                                     pulled={0: Pulled(t, v)}))  # fmt: skip
    _, _, [end], _ = step(state, Arrivals(0.4, calls=(Call("end", 0.2),)))
    assert end.movement.label == "left"


def test_two_inputs_lost_or_paused_in_one_step_end_the_movement_once():
    for second in ("lost", "paused"):
        state = two_inputs()
        t, v = motion(0.0, 30)
        state, *_ = step(state, Arrivals(0.3, calls=(Call("start", 0.0),),
                                         pulled={0: Pulled(t, v), 1: Pulled(t, v)}))  # fmt: skip
        if second == "lost":
            pulled = {0: Pulled.LOST, 1: Pulled.LOST}
        else:
            t, v = motion(0.6, 5)  # both silent for 0.3 s, ten times their step
            pulled = {0: Pulled(t, v), 1: Pulled(t, v)}
        _, _, boundaries, _ = step(state, Arrivals(0.7, pulled=pulled))
        assert [(b.kind, b.number) for b in boundaries] == [("end", 1)], second


def test_a_pause_is_judged_by_the_stream_s_declared_rate():
    state = started()  # the stream declares 100 Hz
    t = np.arange(1, 26) * 0.02  # but sends at 50 Hz
    v = np.column_stack([np.sin(t), np.cos(t), t]) * 0.1
    state, *_ = step(state, Arrivals(0.5, calls=(Call("start", 0.0),), pulled={0: Pulled(t, v)}))
    t = 0.65 + np.arange(10) * 0.02  # 0.15 s: over ten declared steps, under ten sent ones
    v = np.column_stack([np.sin(t), np.cos(t), t]) * 0.1
    _, _, boundaries, _ = step(state, Arrivals(float(t[-1]), pulled={0: Pulled(t, v)}))
    assert [b.kind for b in boundaries] == ["end"]


def test_the_rows_are_on_the_input_declared_slowest():
    state = started(inputs=("hand=Hand:0,1,2", "head=Head:0,1,2"),
                    streams=(("Hand", 3), ("Head", 3)), rates=(100.0, 50.0))  # fmt: skip
    th, vh = motion(0.0, 25, rate=50.0)  # declared 100 Hz, sent at 50
    tv, vv = motion(0.0, 50, rate=100.0)  # declared 50 Hz, sent at 100
    state, *_ = step(state, Arrivals(0.5, calls=(Call("start", 0.0),),
                                     pulled={0: Pulled(th, vh), 1: Pulled(tv, vv)}))  # fmt: skip
    assert state.timebase.base == 1  # the head's, declared slower
    np.testing.assert_allclose(np.diff(state.segmenter.movement.times), 0.01)


def test_a_movement_begun_and_ended_in_one_step_is_predicted_and_decided_once():
    state = started(decide=CommitRule(0.5, window=0.0))  # commits at its first prediction
    t, v = motion(0.0, 50)
    state, events, boundaries, predictions = step(state, Arrivals(
        0.5, calls=(Call("start", 0.0), Call("end", 0.3)), pulled={0: Pulled(t, v)}))
    assert [b.kind for b in boundaries] == ["start", "end"]
    [p] = predictions
    assert p.n_observed == len(boundaries[1].movement) and p.committed is not None
    assert [e.kind for e in events].count("decision") == 1


def test_an_input_lags_only_past_a_movement_s_longest():
    state = two_inputs()  # max_movement_s 1.0
    t, v = motion(0.0, 25)  # both up to 0.25 s
    state, *_ = step(state, Arrivals(0.25, pulled={0: Pulled(t, v), 1: Pulled(t, v)}))
    t, v = motion(0.25, 100)  # the hand alone, up to 1.25 s: exactly 1.0 s ahead
    state, *_ = step(state, Arrivals(1.25, pulled={0: Pulled(t, v)}))
    assert dict(state.newest) == {"hand": 1.25, "head": 0.25}
    assert state.lagging == frozenset()
    t, v = motion(1.25, 1)
    state, *_ = step(state, Arrivals(1.26, pulled={0: Pulled(t, v)}))
    assert state.lagging == frozenset({"head"})


def test_the_segmenter_hears_the_latest_prediction_and_the_time_base_each_inputs_lateness(
        monkeypatch):  # fmt: skip
    """Each step hands the segmenter what the latest prediction says of its movement (the
    pause allowed depends on it) and the time base each input's recent lateness (a late
    sender's pause is no gap)."""
    from promp.live.segmenter import Segmenter
    from promp.live.source import Source
    from promp.live.timebase import TimeBase

    state = started()
    beliefs, lates = [], []
    feed, push = Segmenter.feed, TimeBase.push
    monkeypatch.setattr(Segmenter, "feed",
                        lambda self, rows, b=None: beliefs.append(b) or feed(self, rows, b))
    monkeypatch.setattr(TimeBase, "push", lambda self, *a: lates.append(a[-1]) or push(self, *a))
    monkeypatch.setattr(Source, "lateness", lambda self, name, now: 0.125 if now > 0.6 else 0.0)
    t, v = motion(0.0, 50)
    state, _, _, [p] = step(state, Arrivals(0.5, calls=(Call("start", 0.0, "left"),),
                                            pulled={0: Pulled(t, v)}))  # fmt: skip
    t, v = motion(0.5, 10)
    state, _, _, _ = step(state, Arrivals(0.7, pulled={0: Pulled(t, v)}))
    assert beliefs == [None, belief(p)] and beliefs[1].movement == 1
    assert lates == [0.0, 0.125]
