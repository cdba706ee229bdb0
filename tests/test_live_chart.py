"""The Infer tab's live recognition chart, without a browser: every prediction of the movement
going on kept (bounded, at an even density), the commitment's vertical mark at the time of the
prediction that committed, the note saying it; and a session file replayed in the studio's
live source (:meth:`app.live.lsl_source.LslSource.replay`): the recorded predictions again,
bit for bit, into the chart's curves; a missing, foreign, cut or other model's file refused
with nothing started and the file untouched."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from app.live.live_curve import CurveSink, LiveCurves
from app.live.lsl_source import LslSource
from app.panels.infer.live_chart import X_STEP_S, commit_text, live_chart_data, x_end
from promp.decision import CommitRule
from promp.live.sinks import Output
from tests.conftest import wait_until
from tests.live_fakes import FakeTransport, synthetic_model
from tests.test_promp_live_decision import Run


@pytest.fixture(scope="module")
def run() -> Run:
    """Two unseen movements (right, left) of a session committing at 0.95 for 0.1 s."""
    return Run(CommitRule(threshold=0.95, window=0.1))


def fed(run: Run, max_points: int = 512) -> LiveCurves:
    curves = LiveCurves(synthetic_model().names, max_points)
    sink = CurveSink(curves)
    for output in run.outputs:
        if sink.view(output) is not None:
            sink.take(output)
    return curves


def test_the_curve_holds_every_prediction_of_the_latest_movement(run) -> None:
    curves = fed(run)
    curve = curves.curve()
    last = max(p.movement for p in run.predictions)
    mine = [p for p in run.predictions if p.movement == last]
    forward = [mine[0]]  # (a movement's end may come back on its clock: not drawn)
    for p in mine[1:]:
        if p.elapsed > forward[-1].elapsed:
            forward.append(p)
    assert curve.movement == last and curve.predictions == len(mine) > 10
    assert_array_equal(curve.times, [p.elapsed for p in forward])
    assert_array_equal(curve.phases, [p.phase.value for p in forward])
    assert_array_equal(curve.probabilities, [p.probabilities for p in forward])
    assert curves.curve() is curve  # the same object until a prediction comes


def test_the_commit_mark_stands_at_the_committing_prediction_and_the_note_says_it(run) -> None:
    curve = fed(run).curve()
    made = curve.committed
    committing = next(p for p in run.predictions
                      if p.committed is not None and p.movement == curve.movement)  # fmt: skip
    assert made is committing.committed and made.at == committing.last
    assert made.time == committing.elapsed
    x, *series = live_chart_data(curve)
    mark = series[-1]
    (where,) = np.flatnonzero(np.isfinite(mark)).reshape(1, -1)
    assert_array_equal(x[where], [made.time, made.time])
    assert_array_equal(mark[where], [0.0, 100.0])
    assert len(series) == len(curve.names) + 1
    assert np.all(np.diff(x) >= 0)
    assert commit_text(curve, rule=True).endswith(
        f"committed to **'{made.primitive}'** at {made.time:.2f} s "
        f"({100 * made.phase:.0f} %), p={made.probability:.2f} (the dashed line).")
    assert x_end(curve) > max(curve.times[-1], made.time)
    assert x_end(curve) - X_STEP_S <= max(curve.times[-1], made.time)


def test_without_a_commitment_there_is_no_mark_and_the_note_says_why() -> None:
    curve = fed(Run(None, classes=("right",))).curve()
    assert curve.committed is None and curve.times.size > 10
    x, *series = live_chart_data(curve)
    assert x.size == curve.times.size and np.all(np.isnan(series[-1]))
    assert commit_text(curve, rule=False).endswith("no commit rule (tick Commit to a "
                                                   "primitive before Start).")  # fmt: skip
    assert commit_text(curve, rule=True).endswith("not committed yet.")


def test_a_long_movement_keeps_a_bounded_evenly_spread_curve(run) -> None:
    full = fed(run).curve()
    curve = fed(run, max_points=8).curve()
    assert curve.predictions == full.predictions
    assert 4 <= curve.times.size <= 9
    assert curve.times[0] == full.times[0] and curve.times[-1] == full.times[-1]  # the latest
    kept = np.searchsorted(full.times, curve.times[:-1])
    assert_array_equal(full.times[kept], curve.times[:-1])  # predictions, not made up
    made = curve.committed
    assert made is not None and made.time in curve.times  # the committing one stays
    strided = kept[full.times[kept] != made.time]
    assert np.unique(np.diff(strided)).size == 1  # one stride: an even density
    with pytest.raises(ValueError, match="even count"):
        LiveCurves(("a",), max_points=5)


# ------------------------------------------------------------------------ a session file


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    from tests.test_promp_live_session_file import recorded_session

    folder = tmp_path_factory.mktemp("session")
    model, _, predictions = recorded_session(folder)
    return folder / "session.mcap", model, predictions


def test_a_session_file_replays_in_the_live_source_bit_for_bit(recorded) -> None:
    path, model, predictions = recorded
    kept = path.read_bytes()
    source = LslSource(transport=FakeTransport)
    running = source.replay(model, path, fast=True)
    replay = running.replay
    wait_until(lambda: replay.done, what="the replay's end")
    assert replay.result.equal and replay.result.predictions == len(predictions)
    assert replay.snapshot().prediction.seq == predictions[-1].seq
    assert_array_equal(replay.snapshot().prediction.probabilities,
                       predictions[-1].probabilities)  # fmt: skip
    curve = running.curves.curve()
    assert curve.movement == predictions[-1].movement
    assert curve.predictions == sum(p.movement == curve.movement for p in predictions)
    with pytest.raises(ValueError, match="Stop it first"):
        source.replay(model, path)  # one at a time
    source.stop()
    assert source.running is None and path.read_bytes() == kept


def test_a_replayed_prediction_on_other_phases_is_drawn_on_the_tube_s(recorded) -> None:
    """The command's predictions are on the model's own samples; the 3D tube's mesh has
    TUBE_POINTS rings: the view draws them there, every number the same."""
    from app.live.inference import TUBE_POINTS
    from app.panels.infer.lsl_view import LslObserved, lsl_view, on_tube_phases
    from app.panels.infer.view_model import LSL, InferState

    path, model, predictions = recorded
    p = predictions[-1]
    assert p.inference.prediction.mean.shape[0] != TUBE_POINTS  # (the command's default)
    state = InferState(source=LSL, primitive="", demo="", observed="", alpha_method="ml",
                       percent=100, show_3d=True, priors="", hold_out=None)  # fmt: skip
    result = lsl_view(state, LslObserved(p, model)).result
    shown = result.inference
    assert shown.prediction.mean.shape[0] == shown.prior.mean.shape[0] == TUBE_POINTS
    assert shown.probabilities is p.inference.probabilities and shown.timing is p.inference.timing
    assert_array_equal(shown.prediction.mean[[0, -1]], p.inference.prediction.mean[[0, -1]])
    assert on_tube_phases(model, shown) is shown  # as it is when on the tube's phases


@pytest.fixture(scope="module")
def hour_apart(tmp_path_factory):
    """A session file of two movements an hour apart on the session's clock."""
    from promp.live.options import LiveOptions
    from promp.live.session import LiveSession
    from promp.live.session_file import SessionSink
    from tests.live_fakes import FakeStream, replay
    from tests.synthetic import make_dataset

    path = tmp_path_factory.mktemp("hour") / "hour.mcap"
    model, transport = synthetic_model(), FakeTransport()
    inputs, options = ["hand=Hand:0,1,2"], LiveOptions(start="still")
    sink = SessionSink(path, model, inputs, options, transport.clock())
    session = LiveSession(model, inputs, transport, options, sinks=[sink], now=transport.clock())
    stream = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    session.connect()
    session.step()
    for name in ("left", "right"):
        values = make_dataset(seed=11, n_demos=1)[name][0].select(["x", "y", "z"])
        rows = np.vstack([np.repeat(values[:1], 40, axis=0), values,
                          np.repeat(values[-1:], 60, axis=0)])  # fmt: skip
        replay(session, transport, stream, np.arange(len(rows)) * 0.02, rows)
        transport.now += 3600.0
    session.close()
    return path, model


def test_a_replay_at_the_recorded_timing_ends_at_stop_during_an_hour_s_wait(hour_apart) -> None:
    from promp.live.session_file import read_session

    path, model = hour_apart
    times = [r["now"] for r in read_session(path).of("a")]
    before = int(np.argmax(np.diff(times))) + 1  # the steps before the hour's wait
    source = LslSource(transport=FakeTransport)
    replay = source.replay(model, path, fast=False).replay
    wait_until(lambda: replay.steps == before, what="the steps before the hour replayed")
    source.stop()  # (waits up to 10 s for the replay's thread: not an hour)
    assert replay.done and replay.result.stopped and not replay.result.equal


def test_bad_session_files_are_refused_and_nothing_starts(recorded, tmp_path) -> None:
    from promp.learn import fit
    from promp.model import Settings
    from tests.synthetic import LAYOUT, make_dataset

    path, model, _ = recorded
    other = fit(make_dataset(seed=6, n_demos=5), LAYOUT,
                Settings(n_basis=7, width=1.0, noise_scale=1.5, duration_temperature=1.0))
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file")
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    source = LslSource(transport=FakeTransport)
    for given, who, why in ((path, other, "another model"),
                            (tmp_path / "absent.mcap", model, "no such file"),
                            ("", model, "give the path"),
                            (junk, model, "not a readable session file"),
                            (cut, model, "not a readable session file")):  # fmt: skip
        before = given.read_bytes() if given and given.exists() else None
        with pytest.raises(ValueError, match=why):
            source.replay(who, given)
        assert source.running is None
        if before is not None:
            assert given.read_bytes() == before


def test_the_curve_sink_reads_only_outputs_with_predictions() -> None:
    sink = CurveSink(LiveCurves(("a", "b")))
    assert sink.view(Output(0.0)) is None
