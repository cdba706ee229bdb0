"""A session file's records, one by one (promp.live.session_file): arrivals, predictions and
options survive JSON exactly (NaN and the infinities too), the journal is read back as written
(a record cut by a kill left out, a broken one refused), the MCAP file keeps each record at
its time, a kill's journals are recovered under free names, and a replay's first difference
names what differs. Small hand-made records, no session running."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from promp.decision import CommitRule
from promp.live.options import LiveOptions
from promp.live.pipeline import Arrivals, Call, build, step
from promp.live.session_file import (
    JOURNALS,
    MAGIC,
    SessionSink,
    decode_arrivals,
    encode_arrivals,
    journal_for,
    model_sha256,
    prediction_record,
    read_session,
    recover_sessions,
    replay_session,
    write_session_file,
)
from promp.live.sinks import Output
from promp.live.source import Opened, Pulled
from promp.live.status import LiveEvent
from tests.live_fakes import FakeStream, synthetic_model

pytest.importorskip("mcap")

INPUTS = ["hand=Hand:0,1,2"]


def strict_json(value) -> object:
    """``value`` through JSON as the files keep it (no NaN literal allowed)."""
    return json.loads(json.dumps(value, allow_nan=False))


def test_arrivals_survive_json_exactly_with_non_finite_numbers():
    stream = FakeStream("Hand", ("x", "y"), units=("mm", "mm"), rate=100.0).description
    arrivals = Arrivals(
        now=12.5,
        opened=(Opened(0, stream), Opened(1, None, "not there")),
        pulled={0: Pulled(np.array([1.0, 1.0 + 1e-17, 2.0]),
                          np.array([[0.1, np.nan], [np.inf, -np.inf], [1 / 3, 2.0]]),
                          offset=-0.25),
                1: Pulled(np.array([1.5]), ["start left"]),
                2: Pulled.LOST},
        calls=(Call("start", 1.25, "left"), Call("end", 3.0)),
        notes=(LiveEvent(2.0, "a note"),),
    )  # fmt: skip
    back = decode_arrivals(strict_json(encode_arrivals(arrivals)))
    assert back.now == 12.5
    assert back.opened == arrivals.opened
    assert isinstance(back.opened[0].stream.labels, tuple)
    assert sorted(back.pulled) == [0, 1, 2]
    np.testing.assert_array_equal(back.pulled[0].times, arrivals.pulled[0].times)
    np.testing.assert_array_equal(back.pulled[0].values, arrivals.pulled[0].values)
    assert back.pulled[0].values.shape == (3, 2)
    assert back.pulled[0].offset == -0.25 and not back.pulled[0].lost
    assert back.pulled[1].values == ["start left"] and back.pulled[1].times.tolist() == [1.5]
    assert back.pulled[2].lost and back.pulled[2].times.size == 0
    assert back.calls == arrivals.calls
    assert back.notes == arrivals.notes


def predicted(decide=None):
    """Two steps of a pipeline over one stream: a movement started by a call, predicted."""
    state = build(synthetic_model(), INPUTS,
                  LiveOptions(start="call", remainder="hand", decide=decide), now=0.0)  # fmt: skip
    d = FakeStream("Hand", ("x", "y", "z"), rate=100.0).description
    first = Arrivals(0.0, (Opened(0, d),))
    state, *_ = step(state, first)
    t = np.arange(1, 41) / 100
    second = Arrivals(0.4, calls=(Call("start", 0.0),),
                      pulled={0: Pulled(t, np.column_stack([np.sin(t), np.cos(t), t]) * 0.1)})
    state, events, boundaries, predictions = step(state, second)
    return [first, second], events, predictions


def test_a_prediction_record_holds_every_number_it_publishes():
    _, _, [p] = predicted(decide=CommitRule(0.5, window=0.0))
    record = strict_json(prediction_record(p))
    assert record["seq"] == p.seq and record["movement"] == p.movement
    assert record["start"] == p.start and record["last"] == p.last
    assert record["n_observed"] == p.n_observed and record["primitive"] == p.primitive
    assert record["probabilities"]["data"] == p.probabilities.tolist()
    for name in ("phase", "duration", "remaining"):
        e = getattr(p, name)
        assert record[name] == [e.value, e.low, e.high]
    r = p.remainder
    assert record["remainder"]["modality"] == "hand"
    assert record["remainder"]["after"]["data"] == r.after.ravel().tolist()
    assert record["remainder"]["mean"]["shape"] == list(r.mean.shape)
    assert record["remainder"]["std"]["data"] == r.std.ravel().tolist()
    assert record["committed"] == (None if p.committed is None else p.committed.primitive)
    _, _, [plain] = predicted()
    assert prediction_record(plain)["committed"] is None


def test_journal_of_a_session_file_is_in_its_folder_s_sessions():
    assert journal_for("a/b/run.mcap") == journal_for("a/b/run.mcap").parent / "run.journal"
    assert journal_for("a/b/run.mcap").parent.as_posix() == f"a/b/{JOURNALS}"


def recorded_journal(folder, options=None):
    """A session sink given the two steps' outputs (as a session gives them), closed or not."""
    rule = CommitRule(0.5, window=0.0)  # commits at the first prediction
    options = options or LiveOptions(start="call", remainder="hand", decide=rule)
    model = synthetic_model()
    sink = SessionSink(folder / "run.mcap", model, INPUTS, options, 3.5)
    arrivals, events, predictions = predicted(decide=rule)
    assert predictions[0].committed is not None
    assert sink.view(Output(0.0)) is None
    for alone in (Output(0.0, predictions=tuple(predictions)), Output(0.0, events=tuple(events))):
        assert sink.view(alone) is alone
    outputs = [Output(0.0, arrivals=(arrivals[0],)),
               Output(0.4, events, (), predictions, None, (arrivals[1],))]  # fmt: skip
    for output in outputs:
        assert sink.view(output) is output
        sink.take(output)
    return model, sink, arrivals, events, predictions


def test_a_session_file_keeps_the_header_and_each_record_in_order_at_its_time(tmp_path):
    model, sink, arrivals, events, predictions = recorded_journal(tmp_path)
    assert journal_for(tmp_path / "run.mcap").exists()
    sink.close()
    assert not journal_for(tmp_path / "run.mcap").exists()
    kept = read_session(tmp_path / "run.mcap")
    header = kept.header
    assert header["format"] == 1 and header["model_sha256"] == model_sha256(model)
    assert header["inputs"] == INPUTS and header["start"] == 3.5
    assert header["options"]["decide"] == {"threshold": 0.5, "window": 0.0}
    assert header["options"]["remainder"] == "hand"
    assert [k for k, _ in kept.records] == ["a", "a", "p"] + ["e"] * len(events)
    assert [decode_arrivals(r).now for r in kept.of("a")] == [0.0, 0.4]
    assert kept.of("p") == [strict_json(prediction_record(p)) for p in predictions]
    assert [(r["time"], r["text"]) for r in kept.of("e")] == [(e.time, e.text) for e in events]
    # the log times: an arrival's now, a prediction's last, an event's time
    from mcap.reader import make_reader

    with open(tmp_path / "run.mcap", "rb") as handle:
        stamps = [(c.topic, m.log_time, m.publish_time)
                  for _, c, m in make_reader(handle).iter_messages(log_time_order=False)]
    expected = [("/arrivals", 0), ("/arrivals", 400_000_000),
                ("/predictions", round(predictions[0].last * 1e9))]  # fmt: skip
    expected += [("/events", round(e.time * 1e9)) for e in events]
    assert [(t, log) for t, log, _ in stamps] == expected
    assert all(log == publish for _, log, publish in stamps)


def test_the_options_recorded_build_the_same_pipeline_on_replay(tmp_path):
    model, sink, arrivals, _, predictions = recorded_journal(tmp_path)
    sink.close()
    replayed = replay_session(model, tmp_path / "run.mcap")
    assert replayed.steps == 2 and replayed.equal and replayed.difference == ""
    assert len(replayed.predictions) == 1 and replayed.predictions[0].committed is not None
    seen = []
    replay_session(model, tmp_path / "run.mcap", on_output=seen.append)
    assert [o.time for o in seen] == [0.0, 0.4]
    assert [len(o.predictions) for o in seen] == [0, 1] and seen[1].arrivals[0].now == 0.4


def test_a_replay_names_the_fields_that_differ_and_a_missing_prediction(tmp_path):
    model, sink, *_ = recorded_journal(tmp_path)
    sink.close()
    from promp.live.session_file import _difference

    record = strict_json(prediction_record(replay_session(model, tmp_path / "run.mcap")
                                           .predictions[0]))  # fmt: skip
    other = {**record, "primitive": "elsewhere", "n_observed": 1}
    said = _difference([other], [record])
    assert said and "primitive" in said and "n_observed" in said and "seq" not in said
    assert _difference([record], [record]) == ""
    assert _difference([], [record]) != "" and _difference([record, record], [record]) != ""


def test_a_journal_cut_by_a_kill_loses_the_cut_record_and_a_broken_one_is_refused(tmp_path):
    _, sink, *_ = recorded_journal(tmp_path)
    sink._file.close()
    journal = journal_for(tmp_path / "run.mcap")
    text = journal.read_text()
    journal.write_text(text + '{"k": "a", "now": 1')  # cut short: never acknowledged
    [(found, made)] = recover_sessions(tmp_path)
    assert found == journal and made == tmp_path / "recovered" / "run.mcap"
    assert not journal.exists()
    kinds = [json.loads(line)["k"] for line in text.splitlines()[1:]]
    assert [k for k, _ in read_session(made).records] == kinds
    # the same name again: a free one; a journal that is not one stays, and why is said
    journal.parent.mkdir(exist_ok=True)
    journal.write_text(text)
    (journal.parent / "broken.journal").write_text(MAGIC + "{}\nnot json\n")
    (journal.parent / "alien.journal").write_text("something else\n")
    recovered = dict(recover_sessions(tmp_path))
    assert recovered[journal] == tmp_path / "recovered" / "run-2.mcap"
    assert isinstance(recovered[journal.parent / "broken.journal"], str)
    assert isinstance(recovered[journal.parent / "alien.journal"], str)
    assert (journal.parent / "broken.journal").exists()
    assert (journal.parent / "alien.journal").exists()
    assert recover_sessions(tmp_path / "nothing-here") == []


def test_a_record_without_its_kind_is_refused(tmp_path):
    journal = tmp_path / "x.journal"
    journal.write_text(MAGIC + '{"format": 1}\n{"now": 1.0}\n')
    with pytest.raises(ValueError):
        write_session_file(journal, tmp_path / "x.mcap")
    journal.write_text(MAGIC + '{"format": 1}\n[1, 2]\n')
    with pytest.raises(ValueError):
        write_session_file(journal, tmp_path / "x.mcap")
    assert not (tmp_path / "x.mcap").exists()


def test_times_before_zero_or_not_finite_are_kept_at_zero(tmp_path):
    journal = tmp_path / "t.journal"
    lines = [{"k": "e", "time": -1.0, "text": "a"}, {"k": "e", "time": "nan", "text": "b"},
             {"k": "e", "time": 2.5e-9, "text": "c"}, {"k": "e", "time": 1000.5, "text": "d"}]
    journal.write_text(MAGIC + '{"format": 1}\n' + "".join(json.dumps(x) + "\n" for x in lines))
    write_session_file(journal, tmp_path / "t.mcap")
    from mcap.reader import make_reader

    with open(tmp_path / "t.mcap", "rb") as handle:
        times = [m.log_time for _, _, m in make_reader(handle).iter_messages(log_time_order=False)]
    assert times[:2] == [0, 0] and times[2] in (2, 3) and times[3] == 1_000_500_000_000
    assert read_session(tmp_path / "t.mcap").header == {"format": 1}


def test_a_file_of_another_format_or_without_its_header_is_refused(tmp_path):
    journal = tmp_path / "f.journal"
    journal.write_text(MAGIC + '{"format": 2}\n')
    write_session_file(journal, tmp_path / "f.mcap")
    with pytest.raises(ValueError):
        read_session(tmp_path / "f.mcap")


def test_the_model_s_hash_is_its_content_s():
    model = synthetic_model()
    digest = model_sha256(model)
    assert len(digest) == 64 and int(digest, 16) >= 0
    assert model_sha256(model) == digest
    from promp.io import model_from_dict, model_to_dict

    assert model_sha256(model_from_dict(model_to_dict(model))) == digest


def test_a_journal_that_exists_is_not_recorded_over(tmp_path):
    recorded_journal(tmp_path)
    journal = journal_for(tmp_path / "run.mcap")
    size = journal.stat().st_size
    with pytest.raises(ValueError):
        SessionSink(tmp_path / "run.mcap", synthetic_model(), INPUTS, LiveOptions(), 0.0)
    assert journal.stat().st_size == size


def test_a_session_file_declares_json_messages_for_its_readers(tmp_path):
    _, sink, *_ = recorded_journal(tmp_path)
    sink.close()
    from mcap.reader import make_reader

    with open(tmp_path / "run.mcap", "rb") as handle:
        reader = make_reader(handle)
        header = reader.get_header()
        summary = reader.get_summary()
    assert header.library == "promp-live" and header.profile == ""
    assert {c.topic: c.message_encoding for c in summary.channels.values()} == {
        "/arrivals": "json", "/predictions": "json", "/events": "json"}
    [schema] = summary.schemas.values()
    assert schema.name == "promp.live.Record" and schema.encoding == "jsonschema"
    assert json.loads(schema.data) == {"type": "object"}


def test_a_journal_with_a_byte_that_is_not_utf8_is_still_recovered(tmp_path):
    journal = tmp_path / JOURNALS / "odd.journal"
    journal.parent.mkdir()
    journal.write_bytes((MAGIC + '{"format": 1}\n{"k": "e", "time": 1.0, "text": "a').encode()
                        + b"\xff" + b'"}\n')
    [(_, made)] = recover_sessions(tmp_path)
    [(kind, record)] = read_session(made).records
    assert kind == "e" and record["time"] == 1.0


def test_a_paced_replay_keeps_the_recorded_timing_and_predictions(tmp_path):
    model, sink, *_ = recorded_journal(tmp_path)
    sink.close()
    began = time.monotonic()
    replayed = replay_session(model, tmp_path / "run.mcap", paced=True)
    assert time.monotonic() - began >= 0.4  # its steps 0.4 s apart (a lower bound)
    assert replayed.equal and replayed.steps == 2
