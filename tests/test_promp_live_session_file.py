"""A live session recorded (``python -m promp.live ... --session FILE.mcap``) and replayed
(``--replay FILE.mcap --model M``): the replay gives every recorded prediction again, bit for
bit, through faults; a kill loses nothing acknowledged; a wrong model or file is refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from promp.io import save_model
from promp.live.options import LiveOptions
from promp.live.session import LiveSession
from tests.live_fakes import FakeStream, FakeTransport, Tap, replay, synthetic_model
from tests.synthetic import make_dataset

pytest.importorskip("mcap")

INPUTS = ["hand=Hand:0,1,2"]


def recorded_session(folder, close: bool = True):
    """Unseen movements found by the stillness rule, with a stall, a restart of the stream
    (a new one, its clock back by 0.5 s) and NaN samples between them; recorded to
    ``folder/session.mcap``. The tap's outputs (what the sinks were given)."""
    from promp.io import load_model
    from promp.live.session_file import SessionSink

    save_model(folder / "model.json", synthetic_model())
    model = load_model(folder / "model.json")  # as the command loads it
    transport = FakeTransport()
    options = LiveOptions(start="still", remainder="hand")
    start = transport.clock()
    sink = SessionSink(folder / "session.mcap", model, INPUTS, options, start)
    tap = Tap()
    session = LiveSession(model, INPUTS, transport, options, sinks=[sink, tap], now=start)
    stream = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    session.connect()
    session.step()
    unseen = make_dataset(seed=11, n_demos=1)
    for k, name in enumerate(("left", "right", "left")):
        demo = unseen[name][0]
        values = demo.select(["x", "y", "z"])
        rest = np.repeat(values[:1], 40, axis=0)
        if k == 1:
            rest[5] = np.nan  # a broken sample in a rest
        t = np.concatenate([np.arange(40) * 0.02, 0.8 + demo.times - demo.times[0]])
        replay(session, transport, stream, t, np.vstack([rest, values]))
        transport.now += 1.0  # a stall
        session.step()
        if k == 1:  # the sender restarts: a new stream, stamps back by half a second
            stream.gone = True
            session.step()
            stream = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
            session.connect()
            transport.now -= 0.5
    replay(session, transport, stream, np.arange(60) * 0.02,
           np.repeat(values[-1:], 60, axis=0))  # fmt: skip
    if close:
        session.close()
    else:
        session.flush()
    return model, session, [p for o in tap.outputs for p in o.predictions]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    folder = tmp_path_factory.mktemp("session")
    model, _, predictions = recorded_session(folder)
    return folder, model, predictions


def test_a_replayed_session_gives_every_recorded_prediction_bit_for_bit(recorded) -> None:
    from promp.live.session_file import prediction_record, read_session, replay_session

    folder, model, predictions = recorded
    assert not (folder / ".sessions" / "session.journal").exists()  # made into the file
    assert len(predictions) > 20 and len({p.movement for p in predictions}) >= 3
    kept = read_session(folder / "session.mcap")
    assert kept.of("p") == [json.loads(json.dumps(prediction_record(p))) for p in predictions]
    replayed = replay_session(model, folder / "session.mcap")
    assert replayed.equal, replayed.difference
    assert len(replayed.predictions) == len(predictions)
    for got, live in zip(replayed.predictions, predictions, strict=True):
        np.testing.assert_array_equal(got.probabilities, live.probabilities)
        np.testing.assert_array_equal(got.remainder.mean, live.remainder.mean)
        assert got.phase == live.phase and got.remaining == live.remaining
    texts = {e.text for e in replayed.events}
    assert any("lost" in t or "gone" in t for t in texts)  # the restart went through it too


def test_a_replay_notices_a_prediction_that_differs(recorded, tmp_path) -> None:
    from promp.live.session_file import replay_session
    from tests.live_fakes import one_ulp_changed

    folder, model, _ = recorded
    changed = tmp_path / "changed.mcap"
    one_ulp_changed(folder / "session.mcap", changed)
    replayed = replay_session(model, changed)
    assert not replayed.equal and "phase" in replayed.difference


def test_a_killed_recording_is_recovered_at_the_next_start(tmp_path) -> None:
    from promp.live.session_file import read_session, recover_sessions

    model, session, predictions = recorded_session(tmp_path, close=False)  # "killed"
    journal = tmp_path / ".sessions" / "session.journal"
    assert journal.exists() and not (tmp_path / "session.mcap").exists()
    with open(journal, "a") as handle:
        handle.write('{"k": "a", "now": 12')  # a record the kill cut short
    recovered = recover_sessions(tmp_path)
    assert [(j.name, p.name) for j, p in recovered] == [("session.journal", "session.mcap")]
    assert not journal.exists()
    kept = read_session(tmp_path / "recovered" / "session.mcap")
    assert len(kept.of("p")) == len(predictions)  # every acknowledged prediction
    session.close()  # (its own close finds the journal gone: said, nothing else lost)


def test_the_replay_refuses_another_model_and_a_file_that_is_not_a_session(
    recorded, tmp_path
) -> None:
    from promp.learn import fit
    from promp.live.session_file import replay_session
    from promp.model import Settings
    from tests.synthetic import LAYOUT

    folder, _, _ = recorded
    other = fit(make_dataset(seed=6, n_demos=5), LAYOUT,
                Settings(n_basis=7, width=1.0, noise_scale=1.5, duration_temperature=1.0))
    with pytest.raises(ValueError, match="another model"):
        replay_session(other, folder / "session.mcap")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file")
    with pytest.raises(ValueError, match="not a readable session file"):
        replay_session(synthetic_model(), junk)


def test_the_command_records_and_replays(recorded, tmp_path, capsys) -> None:
    from promp.live.cli import main

    folder, model, predictions = recorded
    model_path = folder / "model.json"
    assert main(["--replay", str(folder / "session.mcap"), "--model", str(model_path),
                 "--fast"]) == 0  # fmt: skip
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["equal"] is True and summary["predictions"] == len(predictions)
    existing = tmp_path / "kept.mcap"
    existing.write_bytes(b"a user's file")
    assert main(["--model", str(model_path), "--in", INPUTS[0], "--out", "session-test",
                 "--session", str(existing)]) == 2  # fmt: skip
    assert existing.read_bytes() == b"a user's file"


def test_a_prediction_without_a_remainder_is_recorded_without_one() -> None:
    """A session without ``--remainder``: its predictions' records say no remainder."""
    from promp.live.predictor import OnlinePredictor
    from promp.live.session_file import prediction_record

    model = synthetic_model()
    demo = make_dataset(seed=11, n_demos=1)["left"][0]
    p = OnlinePredictor(model, {"hand": slice(0, 3)}).predict(
        1, demo.times[:30], demo.select(["x", "y", "z"])[:30])  # fmt: skip
    assert p.remainder is None
    record = prediction_record(p)
    assert record["remainder"] is None and record["n_observed"] == 30
