"""What a live session adds to its viewer file (promp.live.viewer_sink.SessionItems), item by
item, without writing a file: the series declared at the start, each movement's rows written
once, each prediction's probabilities, phase, time left and remainder, each event."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.live.options import LiveOptions, live_inputs
from promp.live.pipeline import Arrivals, Call, build, step
from promp.live.sinks import Output
from promp.live.source import Opened, Pulled
from promp.live.status import LiveEvent
from promp.live.viewer_sink import LSL_TIME, REMAINDER_COLOR, SessionItems
from promp.viewers.scene_log import Event, Note, Series, Strips
from tests.live_fakes import FakeStream, synthetic_model

INPUTS = ["hand=Hand:0,1,2", "head=Head:0,1,2"]


def items_of(model):
    return SessionItems(model, live_inputs(model, INPUTS))


def test_the_declared_series_are_each_input_column_and_each_prediction_empty():
    model = synthetic_model()
    declared = items_of(model).declared()
    assert isinstance(declared[0], Note) and declared[0].path == "about"
    series = declared[1:]
    assert all(isinstance(s, Series) and s.timeline == LSL_TIME.name and s.times.size == 0
               for s in series)  # fmt: skip
    names = [p.name for p in model.primitives]
    assert [(s.path, s.label, s.unit) for s in series] == [
        *[(f"inputs/hand/{c}", f"hand {c}", "m") for c in ("x", "y", "z")],
        *[(f"inputs/head/{c}", f"head {c}", "rad") for c in ("roll", "pitch", "yaw")],
        *[(f"predictions/probability/{n}", f"p({n})", "1") for n in names],
        ("predictions/phase", "observed share", "1"),
        ("predictions/time_left", "time left", "s"),
    ]


def predicted_session(remainder: str | None = "hand"):
    """A pipeline that saw one movement of 40 rows (a Record button's start), and its outputs
    of the two steps."""
    model = synthetic_model()
    state = build(model, INPUTS, LiveOptions(start="call", remainder=remainder), now=0.0)
    streams = [FakeStream(n, ("a", "b", "c"), rate=100.0).description for n in ("Hand", "Head")]
    state, *_ = step(state, Arrivals(0.0, tuple(Opened(i, d) for i, d in enumerate(streams))))
    t = np.arange(1, 41) / 100
    v = np.column_stack([np.sin(t), np.cos(t), t]) * 0.1
    state, events, boundaries, predictions = step(state, Arrivals(
        0.4, calls=(Call("start", 0.0),), pulled={0: Pulled(t, v), 1: Pulled(t, v)}))
    first = Output(0.4, events, boundaries, predictions, state.segmenter.movement)
    t2 = 0.4 + np.arange(1, 11) / 100
    v2 = np.column_stack([np.sin(t2), np.cos(t2), t2]) * 0.1
    state, events, boundaries, predictions = step(state, Arrivals(
        0.5, calls=(Call("end", 0.45),), pulled={0: Pulled(t2, v2), 1: Pulled(t2, v2)}))
    second = Output(0.5, events, boundaries, predictions, state.segmenter.movement)
    return model, first, second


def test_each_movement_s_rows_are_written_once_across_outputs():
    model, first, second = predicted_session()
    items = items_of(model)
    rows = [i for i in items.of(first) if isinstance(i, Series) and i.path.startswith("inputs/")]
    movement = first.movement
    assert [r.path for r in rows] == [c[0] for c in items.columns]
    for j, r in enumerate(rows):
        assert_allclose(r.times, movement.times)
        assert_allclose(r.values, movement.values[:, j])
    # the end (a boundary's movement) adds only the rows not written yet
    assert second.movement is None and [b.kind for b in second.boundaries] == ["end"]
    ended = second.boundaries[0].movement
    later = [i for i in items.of(second) if isinstance(i, Series) and i.path.startswith("inputs/")]
    assert len(later) == 6
    assert_allclose(later[0].times, ended.times[len(movement):])
    assert items.written == {1: len(ended)}
    assert [i for i in items.of(second) if i.path.startswith("inputs/")] == []  # all written


def test_every_item_written_later_has_the_label_and_unit_its_series_was_declared_with():
    model, first, second = predicted_session()
    items = items_of(model)
    declared = {s.path: (s.label, s.unit) for s in items.declared() if isinstance(s, Series)}
    written = [i for o in (first, second) for i in items.of(o) if isinstance(i, Series)]
    assert {i.path for i in written} == set(declared)
    assert all((i.label, i.unit) == declared[i.path] for i in written)


def test_a_movement_ended_and_the_next_begun_in_one_output_both_give_their_rows():
    model, first, _ = predicted_session()
    items = items_of(model)
    items.of(first)  # movement 1's first 40 rows
    state = build(model, INPUTS, LiveOptions(start="call"), now=0.0)
    streams = [FakeStream(n, ("a", "b", "c"), rate=100.0).description for n in ("Hand", "Head")]
    state, *_ = step(state, Arrivals(0.0, tuple(Opened(i, d) for i, d in enumerate(streams))))
    t = np.arange(1, 61) / 100
    v = np.column_stack([np.sin(t), np.cos(t), t]) * 0.1
    state, events, boundaries, predictions = step(state, Arrivals(
        0.6, calls=(Call("start", 0.0), Call("start", 0.45)),
        pulled={0: Pulled(t, v), 1: Pulled(t, v)}))
    both = Output(0.6, events, boundaries, predictions, state.segmenter.movement)
    ended = [b.movement for b in boundaries if b.movement is not None]
    assert [m.number for m in ended] == [1] and both.movement.number == 2
    rows = [i for i in items_of(model).of(both) if i.path == "inputs/hand/x"]
    assert [len(r.times) for r in rows] == [len(ended[0]), len(both.movement)]


def test_a_prediction_gives_its_probabilities_phase_time_left_and_remainder_at_its_last_row():
    model, first, _ = predicted_session()
    [p] = first.predictions
    made = SessionItems(model, live_inputs(model, INPUTS)).of(
        Output(first.time, predictions=(p,)))  # fmt: skip
    series = {i.path: i for i in made if isinstance(i, Series)}
    names = [q.name for q in model.primitives]
    assert list(series) == [*(f"predictions/probability/{n}" for n in names),
                            "predictions/phase", "predictions/time_left"]  # fmt: skip
    for n, value in zip(names, p.probabilities, strict=True):
        assert_allclose(series[f"predictions/probability/{n}"].values, [value])
    assert_allclose(series["predictions/phase"].values, [p.phase.value])
    assert_allclose(series["predictions/time_left"].values, [p.remaining.value])
    assert all(list(s.times) == [p.last] for s in series.values())
    [strips] = [i for i in made if isinstance(i, Strips)]
    assert strips.path == "predictions/remainder/hand" and strips.color == REMAINDER_COLOR
    assert_allclose(strips.strips[0], p.remainder.mean)
    assert strips.at.value == p.last and strips.at.timeline == LSL_TIME.name


def test_no_remainder_strip_without_a_remainder_or_for_angles():
    model, first, _ = predicted_session(remainder=None)
    made = items_of(model).of(Output(first.time, predictions=first.predictions))
    assert not any(isinstance(i, Strips) for i in made)
    model, first, _ = predicted_session(remainder="head")
    made = items_of(model).of(Output(first.time, predictions=first.predictions))
    assert first.predictions[0].remainder is not None
    assert not any(isinstance(i, Strips) for i in made)


def test_each_event_is_an_event_item_at_its_time():
    model = synthetic_model()
    made = items_of(model).of(Output(3.0, events=(LiveEvent(1.5, "one"), LiveEvent(2.5, "two"))))
    assert [(i.path, i.at.timeline, i.at.value) for i in made] == [
        ("events", LSL_TIME.name, 1.5), ("events", LSL_TIME.name, 2.5)]
    assert all(isinstance(i, Event) for i in made)


def test_a_viewer_file_is_made_in_new_folders_and_each_format_s_sink_is_named_apart(tmp_path):
    pytest.importorskip("rerun")
    pytest.importorskip("foxglove")
    from promp.live.viewer_sink import ViewerSink, session_log

    model = synthetic_model()
    inputs = live_inputs(model, INPUTS)
    sinks = [ViewerSink(tmp_path / "a" / "b" / "run.rrd", model, inputs),
             ViewerSink(tmp_path / "c" / "d" / "run.MCAP", model, inputs)]  # fmt: skip
    for sink in sinks:
        sink.close()
        assert sink.path.exists() and sink.path.stat().st_size > 0
    names = [s.name for s in sinks]
    assert all(isinstance(n, str) and n for n in names) and len(set(names)) == 2
    declared = items_of(model).declared()
    assert session_log(declared).items == tuple(declared)


def test_a_viewer_sink_takes_only_busy_outputs_and_its_mcap_file_grows_as_it_takes(tmp_path):
    pytest.importorskip("foxglove")
    from promp.live.viewer_sink import ViewerSink

    model, first, second = predicted_session()
    sink = ViewerSink(tmp_path / "run.mcap", model, live_inputs(model, INPUTS))
    assert sink.view(Output(1.0)) is None
    for busy in (Output(1.0, movement=first.movement), Output(1.0, boundaries=second.boundaries),
                 Output(1.0, predictions=first.predictions), Output(1.0, events=first.events)):
        assert sink.view(busy) is busy
    size = sink.path.stat().st_size
    sink.take(first)
    grown = sink.path.stat().st_size
    assert grown > size  # written as it runs, not held until the end
    sink.close()
    assert "mcap" in sink.name.lower()
    rrd = ViewerSink(tmp_path / "run.rrd", model, live_inputs(model, INPUTS))
    rrd.close()
    assert "rerun" in rrd.name.lower() and "rerun" not in sink.name.lower()
