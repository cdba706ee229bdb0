"""A live session kept as a viewer file (``python -m promp.live ... --rerun FILE.rrd --mcap
FILE.mcap``, :mod:`promp.live.viewer_sink`): read back with Rerun's and the ``mcap`` package's
own readers, the file holds every row the pipeline saw, every prediction and every event, on
LSL time."""

from __future__ import annotations

import numpy as np
import pytest

from promp.io import save_model
from promp.live.options import live_inputs
from promp.live.session import LiveOptions
from tests.live_fakes import Tap, begun_and_ended, replay, synthetic_model
from tests.viewer_readers import json_series, read_mcap, read_rrd

pytest.importorskip("rerun")
pytest.importorskip("foxglove")

NS = 1e-9


def kept_session(folder):
    """Two unseen movements (Begin / End) of the synthetic model's hand, kept as both files;
    the session's outputs as a tap saw them."""
    from promp.live.viewer_sink import ViewerSink

    model = synthetic_model()
    inputs = live_inputs(model, ["hand=Hand:0,1,2"])
    files = [ViewerSink(folder / "session.rrd", model, inputs),
             ViewerSink(folder / "session.mcap", model, inputs)]  # fmt: skip
    tap = Tap()
    session, transport, stream, demos = begun_and_ended(
        model, LiveOptions(start="call", remainder="hand"), ("left", "right"), inputs,
        sinks=[*files, tap])  # fmt: skip
    rest = demos[-1].select(["x", "y", "z"])[-1:]  # rows past the last end, which waits for them
    replay(session, transport, stream, np.arange(10) * 0.02, np.repeat(rest, 10, axis=0))
    session.close()
    return model, list(tap.outputs)


@pytest.fixture(scope="module")
def kept(tmp_path_factory):
    folder = tmp_path_factory.mktemp("viewer-session")
    model, outputs = kept_session(folder)
    return folder, model, outputs


def ended_movements(outputs) -> list:
    return [b.movement for o in outputs for b in o.boundaries if b.movement is not None]


def test_the_rerun_file_holds_every_row_prediction_and_event(kept) -> None:
    folder, model, outputs = kept
    entities = read_rrd(folder / "session.rrd")
    movements = ended_movements(outputs)
    assert len(movements) == 2
    times = np.concatenate([m.times for m in movements])
    values = np.vstack([m.values for m in movements])
    for j, column in enumerate(("x", "y", "z")):
        t, v = entities[f"inputs/hand/{column}"].series("lsl_time")
        np.testing.assert_allclose(t * NS, times, rtol=0, atol=1e-6)  # ns on the timeline
        np.testing.assert_array_equal(v, values[:, j])
    predictions = [p for o in outputs for p in o.predictions]
    assert len(predictions) > 10
    for k, primitive in enumerate(model.primitives):
        t, v = entities[f"predictions/probability/{primitive.name}"].series("lsl_time")
        np.testing.assert_allclose(t * NS, [p.last for p in predictions], rtol=0, atol=1e-6)
        np.testing.assert_array_equal(v, [p.probabilities[k] for p in predictions])
    _, phase = entities["predictions/phase"].series("lsl_time")
    np.testing.assert_array_equal(phase, [p.phase.value for p in predictions])
    _, left = entities["predictions/time_left"].series("lsl_time")
    np.testing.assert_array_equal(left, [p.remaining.value for p in predictions])
    paths = [c for _, c in entities["predictions/remainder/hand"].rows
             if "LineStrips3D:strips" in c]  # fmt: skip
    drawn = [p for p in predictions if p.remainder.mean.shape[0] >= 2]
    assert len(paths) == len(drawn) > 0
    np.testing.assert_allclose(np.array(paths[-1]["LineStrips3D:strips"][0]),
                               drawn[-1].remainder.mean, rtol=1e-6)  # fmt: skip
    texts = [c["TextLog:text"][0] for _, c in entities["events"].rows]
    events = [e.text for o in outputs for e in o.events]
    assert sorted(texts) == sorted(events) and "movement 2 ended (ended)" in texts


def test_the_mcap_file_holds_the_same_series_and_events(kept) -> None:
    folder, model, outputs = kept
    messages, metadata = read_mcap(folder / "session.mcap")
    movements = ended_movements(outputs)
    values = np.vstack([m.values for m in movements])
    _, x = json_series(messages, "/inputs/hand/x", "lsl_time")
    np.testing.assert_array_equal(x, values[:, 0])
    predictions = [p for o in outputs for p in o.predictions]
    name = model.primitives[0].name
    t, p0 = json_series(messages, f"/predictions/probability/{name}", "lsl_time")
    np.testing.assert_array_equal(p0, [p.probabilities[0] for p in predictions])
    np.testing.assert_allclose(t, [p.last for p in predictions], rtol=0, atol=1e-6)
    logged = [m.message.message for m in messages if m.topic == "/events"]
    assert sorted(logged) == sorted(e.text for o in outputs for e in o.events)
    assert "recording" in metadata


def test_the_command_refuses_a_viewer_file_it_would_write_over_before_it_starts(
    tmp_path,
) -> None:
    from promp.live.cli import main

    model_path = tmp_path / "model.json"
    save_model(model_path, synthetic_model())
    existing = tmp_path / "kept.rrd"
    existing.write_bytes(b"a user's file")
    base = ["--model", str(model_path), "--in", "hand=Hand:0,1,2", "--out", "viewer-test",
            "--wait", "0"]  # fmt: skip
    assert main([*base, "--rerun", str(existing)]) == 2
    assert existing.read_bytes() == b"a user's file"
    assert main([*base, "--mcap", str(tmp_path / "session.rrd")]) == 2  # not an .mcap
    kept_mcap = tmp_path / "kept.mcap"
    kept_mcap.write_bytes(b"another")
    assert main([*base, "--rerun", str(tmp_path / "new.rrd"), "--mcap", str(kept_mcap)]) == 2
    assert kept_mcap.read_bytes() == b"another"
    assert not (tmp_path / "new.rrd").exists()  # neither is made when one is refused
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.mcap", "kept.rrd", "model.json"]
