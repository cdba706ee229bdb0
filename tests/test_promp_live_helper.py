"""The recognition's helper process (promp.live.helper): an update shared with it gives the
numbers of one process bit for bit, whichever primitive is recognised and whichever process
integrates it; a helper that dies, hangs or talks nonsense is stopped and the updates go on in
one process, said once; a session stops its helper when it closes."""

from __future__ import annotations

import dataclasses
import os
import signal
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from promp.learn import fit
from promp.live import helper as helper_module
from promp.live.helper import Helper, decode, encode, shares
from promp.live.predictor import OnlinePredictor
from promp.model import Settings
from tests.synthetic import LAYOUT, make_dataset

TARGETS = {
    "left": np.array([0.2, -0.2, 0.1, 0.0, 0.3, -0.6]),
    "right": np.array([0.2, 0.2, 0.1, 0.0, 0.3, 0.6]),
    "up": np.array([0.1, 0.0, 0.4, 0.2, -0.3, 0.0]),
}
_CACHE: dict = {}


def model_and_takes(n_classes: int = 3):
    """A model of ``n_classes`` synthetic primitives, and a held-out take of each."""
    if n_classes not in _CACHE:
        targets = dict(list(TARGETS.items())[:n_classes])
        data = make_dataset(seed=11, n_demos=6, targets=targets)
        settings = Settings(n_basis=7, width=1.0, noise_scale=1.5, duration_temperature=1.0)
        model = fit({k: v[1:] for k, v in data.items()}, LAYOUT, settings)
        _CACHE[n_classes] = model, [v[0] for v in data.values()]
    return _CACHE[n_classes]


def columns():
    return {"hand": slice(0, 3), "head": slice(3, 6)}


def updates(predictor: OnlinePredictor, takes, step: int = 4, on_update=None) -> list:
    """Every take as one movement, predicted after each ``step`` new rows."""
    out = []
    for number, take in enumerate(takes, start=1):
        values = LAYOUT.extract(take)
        for n in range(6, take.times.shape[0] + 1, step):
            if on_update is not None:
                on_update(number, n)
            out.append(predictor.predict(number, take.times[:n], values[:n]))
    return out


def started(predictor: OnlinePredictor) -> Helper:
    predictor.open()
    assert predictor._helper.ready(wait=60.0), predictor._helper.failure
    return predictor._helper


def same_bits(a, b) -> None:
    assert a.primitive == b.primitive and a.seq == b.seq
    assert_array_equal(a.probabilities, b.probabilities)
    assert a.duration == b.duration and a.phase == b.phase
    assert_array_equal(a.inference.posterior.mean, b.inference.posterior.mean)
    assert_array_equal(a.inference.prediction.mean, b.inference.prediction.mean)
    assert_array_equal(a.remainder.mean, b.remainder.mean)
    assert_array_equal(a.remainder.std, b.remainder.std)


@pytest.mark.parametrize("n_classes, recognition", [(2, None), (3, None), (3, "mixture:0.5")])
def test_an_update_shared_with_the_helper_gives_one_process_numbers_bit_for_bit(n_classes,
                                                                               recognition):
    model, takes = model_and_takes(n_classes)
    if recognition is not None:  # the helper reads the variant and the residuals from the file
        model = dataclasses.replace(model, settings=dataclasses.replace(
            model.settings, recognition=recognition))  # fmt: skip
    takes = takes + takes[::-1]  # the recognised primitive changes between movements
    alone = OnlinePredictor(model, columns(), remainder="hand")
    shared = OnlinePredictor(model, columns(), remainder="hand", helper=True)
    helper = started(shared)
    asked = []
    submit = helper.submit
    helper.submit = lambda *a: asked.append(list(a[2])) or submit(*a)
    try:
        one, two = updates(alone, takes), updates(shared, takes)
    finally:
        shared.close()
    assert len(one) == len(two) > 40
    for a, b in zip(one, two, strict=True):
        same_bits(a, b)
    assert len(asked) == len(two) and helper.failure == "it was closed"
    own, theirs = shares(n_classes)
    assert {tuple(sorted(a)) for a in asked} == {theirs}
    # the primitive recognised last is asked first when it is the helper's
    recognised = {p.inference.recognition.index for p in two}
    assert recognised == set(range(n_classes))
    firsts = {a[0] for a in asked}
    assert firsts == set(theirs)  # each of the helper's primitives went first at some update


def test_shares_keep_about_one_primitive_fewer_here_than_in_the_helper() -> None:
    assert shares(2) == ((), (0, 1))
    assert shares(3) == ((2,), (0, 1))
    assert shares(4) == ((3,), (0, 1, 2))
    assert shares(5) == ((3, 4), (0, 1, 2))


def test_frames_hold_their_arrays_exactly_and_refuse_a_wrong_length() -> None:
    rng = np.random.default_rng(0)
    arrays = [rng.normal(size=(5, 3)), np.empty(0), np.array([np.inf, -np.inf, 1e-300])]
    frame = encode({"indices": [2, 0]}, arrays)
    text_length = int.from_bytes(frame[8:12], "little")
    header, got = decode(frame[12 : 12 + text_length], frame[12 + text_length :])
    assert header == {"indices": [2, 0]}
    for a, b in zip(arrays, got, strict=True):
        assert_array_equal(a, b)
    for body in (frame[12 + text_length : -8], frame[12 + text_length :] + bytes(8)):
        with pytest.raises(ValueError):  # an array cut short, or bytes left over
            decode(frame[12 : 12 + text_length], body)


def _faulty(kill_at: int, fault: str):
    """A shared predictor whose helper meets ``fault`` before movement 2's ``kill_at``-th row."""
    model, takes = model_and_takes(3)
    alone = OnlinePredictor(model, columns(), remainder="hand")
    shared = OnlinePredictor(model, columns(), remainder="hand", helper=True)
    helper = started(shared)
    news, submitted = [], []
    submit = helper.submit
    helper.submit = lambda *a: submitted.append(a[0]) or submit(*a)

    def on_update(number: int, n: int) -> None:
        if number == 2 and n == kill_at and not news:
            pid = helper._process.pid
            if fault == "dies":
                os.kill(pid, signal.SIGKILL)
            elif fault == "hangs":
                os.kill(pid, signal.SIGSTOP)
            news.append(fault)

    try:
        one = updates(alone, takes)
        two = updates(shared, takes, on_update=on_update)
        said = [shared.news(), shared.news()]
    finally:
        shared.close()
    # a helper stopped is never asked again (its failure said, not left empty: it would seem
    # alive and be asked at the next movement's start)
    assert max(submitted) == 2
    return one, two, said, helper


@pytest.mark.parametrize("fault", ["dies", "hangs"])
def test_a_helper_that_dies_or_hangs_is_stopped_and_the_updates_go_on_here(monkeypatch, fault):
    monkeypatch.setattr(helper_module, "ANSWER_TIMEOUT_S", 0.5)
    one, two, said, helper = _faulty(10, fault)
    assert len(one) == len(two)
    assert said[0] and said[1] == ""  # said once
    assert helper._process.poll() is not None  # stopped (a hung one killed)
    model, takes = model_and_takes(3)
    per_take = [len(range(6, t.times.shape[0] + 1, 4)) for t in takes]
    first, second = per_take[0], per_take[0] + per_take[1]
    for a, b in zip(one[:first], two[:first], strict=True):
        same_bits(a, b)
    # the movement under way: its sums recomputed here, the same numbers to round-off
    for a, b in zip(one[first:second], two[first:second], strict=True):
        assert a.primitive == b.primitive
        assert_allclose(b.probabilities, a.probabilities, rtol=0, atol=1e-9)
        assert_allclose(b.inference.posterior.mean, a.inference.posterior.mean, atol=1e-9)
    for a, b in zip(one[second:], two[second:], strict=True):  # the next: one process's
        same_bits(a, b)


def test_a_helper_that_sends_nonsense_or_never_starts_is_given_up(monkeypatch) -> None:
    model, takes = model_and_takes(2)
    nonsense = [sys.executable, "-c", "import sys; sys.stdout.write('x' * 64); sys.stdout.flush()"]
    helper = Helper("{}", "ml", ("hand", "head"), command=nonsense)
    assert not helper.ready(wait=30.0)
    assert helper.failure and helper._process.poll() is not None
    monkeypatch.setattr(helper_module, "READY_TIMEOUT_S", 0.0)
    silent = [sys.executable, "-c", "import time; time.sleep(60)"]
    helper = Helper("{}", "ml", ("hand", "head"), command=silent)
    assert not helper.ready() and "did not start" in helper.failure
    assert helper._process.poll() is not None
    missing = Helper("{}", "ml", ("hand", "head"), command=["/nonexistent/python"])
    assert not missing.ready(wait=1.0) and "could not start" in missing.failure
    assert not missing.submit(1, None, [0]) and missing.collect() is None
    missing.close()
    # a predictor with such a helper predicts in one process from its first movement
    alone = OnlinePredictor(model, columns(), remainder="hand")
    shared = OnlinePredictor(model, columns(), remainder="hand", helper=True)
    shared._helper = helper
    for a, b in zip(updates(alone, takes), updates(shared, takes), strict=True):
        same_bits(a, b)


def test_a_session_with_a_helper_predicts_as_one_process_and_stops_it_on_close() -> None:
    from tests.live_fakes import FakeStream, FakeTransport, held, replay, session_with

    model, takes = model_and_takes(3)
    seen = {}
    for helper in (False, True):
        transport = FakeTransport()
        stream = transport.add(FakeStream("Hand", ("hx", "hy", "hz"), rate=100.0))
        session = session_with(model, ["hand=Hand:hx,hy,hz"], transport, start="still",
                               remainder="hand", helper=helper)  # fmt: skip
        predictor = session.state.predictor
        if helper:
            started(predictor)
        take = held(takes[0], 1.0, 1.0)
        replay(session, transport, stream, take.times, take.select(["x", "y", "z"]))
        seen[helper] = session.predictions
        if helper:
            process = predictor._helper._process
            assert predictor._shared and process.poll() is None
        session.close()
        if helper:
            assert process.poll() is not None
    assert len(seen[True]) == len(seen[False]) > 10
    for a, b in zip(seen[False], seen[True], strict=True):
        assert_array_equal(a.probabilities, b.probabilities)
        assert_array_equal(a.remainder.mean, b.remainder.mean)


def test_processes_default_to_two_on_two_cores(monkeypatch) -> None:
    from promp.live import cli

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    assert cli.processes(None) == 2 and cli.processes(1) == 1
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
    assert cli.processes(None) == 1 and cli.processes(2) == 2


@pytest.mark.parametrize("alpha_method", ["ml", "model"])
def test_the_helper_answers_each_update_from_its_own_evidence_of_the_movement(alpha_method):
    """``serve`` in this process (what ``python -m promp.live.helper`` runs): the model once,
    then per update the new rows; its answers are the integrals of an evidence extended by
    the same rows, bit for bit, the first index alone first, at the session's speed prior; a
    refused observation gets an error frame and the next update an answer, within the
    movement too (from an evidence of every row)."""
    import io

    from promp.evidence import Evidence
    from promp.inference import Observation
    from promp.io import model_to_json
    from promp.live.helper import integrals_from, read_frame, serve

    model, takes = model_and_takes(3)
    modalities = ("hand", "head")
    values = LAYOUT.extract(takes[1])
    times = takes[1].times - takes[1].times[0]
    asked = [(1, 0, 10, [1, 0]), (1, 10, 14, [0, 1]), (1, 14, 20, [1]), (2, 0, 8, [0, 1])]
    requests = io.BytesIO()
    requests.write(encode({"model": model_to_json(model), "alpha_method": alpha_method,
                           "modalities": list(modalities)}))  # fmt: skip
    for movement, start, stop, indices in asked:
        requests.write(encode({"movement": movement, "start": start, "indices": indices},
                              [times[start:stop], values[start:stop]]))  # fmt: skip
    bad = values[:5].copy()
    bad[2, 1] = np.nan
    requests.write(encode({"movement": 3, "start": 0, "indices": [0, 1]}, [times[:5], bad]))
    requests.write(encode({"movement": 3, "start": 0, "indices": [0, 1]},
                          [times[:5], values[:5]]))  # fmt: skip
    for start, stop, indices in [(5, 9, [7]), (9, 12, [1, 0])]:  # no primitive 7: refused
        requests.write(encode({"movement": 3, "start": start, "indices": indices},
                              [times[start:stop], values[start:stop]]))  # fmt: skip
    requests.seek(0)
    answers = io.BytesIO()
    serve(requests.read, answers.write)
    answers.seek(0)
    assert read_frame(answers.read)[0] == {"ready": True}
    evidence = None
    for _movement, start, stop, indices in asked:
        obs = Observation(times[:stop], values[:stop], modalities)
        evidence = Evidence(model, obs, alpha_method) if start == 0 \
            else evidence.extended(obs)  # fmt: skip
        first = integrals_from(*read_frame(answers.read))
        rest = integrals_from(*read_frame(answers.read))
        assert list(first) == indices[:1] and list(rest) == indices[1:]
        for k, got in {**first, **rest}.items():
            want = evidence.integral(k)
            for a, b in zip(got, want, strict=True):
                assert_array_equal(a, b)
    assert "error" in read_frame(answers.read)[0]  # the NaN refused
    again = Evidence(model, Observation(times[:5], values[:5], modalities), alpha_method)
    first = integrals_from(*read_frame(answers.read))
    assert_array_equal(first[0].log_likelihoods, again.integral(0).log_likelihoods)
    assert read_frame(answers.read) is not None
    assert "error" in read_frame(answers.read)[0]
    fresh = Evidence(model, Observation(times[:12], values[:12], modalities), alpha_method)
    first = integrals_from(*read_frame(answers.read))
    assert list(first) == [1]
    for a, b in zip(first[1], fresh.integral(1), strict=True):
        assert_array_equal(a, b)
    assert read_frame(answers.read) is not None and read_frame(answers.read) is None


def test_the_helpers_command_serves_its_input_on_its_own_output_and_ignores_ctrl_c(
        monkeypatch) -> None:  # fmt: skip
    """``main`` (what ``python -m promp.live.helper`` runs), in this process: Ctrl-C ignored
    (the session closes its input instead), the frames written to a copy of the standard
    output taken before it is pointed at the error stream (a stray print cannot corrupt
    them), its input read until it ends."""
    import io
    import signal as signal_module

    from promp.io import model_to_json
    from promp.live import helper
    from promp.live.helper import read_frame

    model, _ = model_and_takes(2)
    calls, written = [], io.BytesIO()
    setup = encode({"model": model_to_json(model), "alpha_method": "ml",
                    "modalities": ["hand", "head"]})  # fmt: skip

    class Out:
        def write(self, data):
            written.write(data)

    class In:
        buffer = io.BytesIO(setup)

    monkeypatch.setattr(helper.signal, "signal", lambda *a: calls.append(("signal", *a)))
    monkeypatch.setattr(helper.os, "dup", lambda fd: calls.append(("dup", fd)) or 99)
    monkeypatch.setattr(helper.os, "dup2", lambda a, b: calls.append(("dup2", a, b)))
    monkeypatch.setattr(helper.os, "fdopen",
                        lambda fd, mode, buffering: calls.append(("fdopen", fd, mode, buffering))
                        or Out())  # fmt: skip
    monkeypatch.setattr(helper.sys, "stdin", In())
    helper.main()
    assert calls == [("signal", signal_module.SIGINT, signal_module.SIG_IGN), ("dup", 1),
                     ("fdopen", 99, "wb", 0), ("dup2", 2, 1)]  # fmt: skip
    written.seek(0)
    assert read_frame(written.read)[0] == {"ready": True}
    assert read_frame(written.read) is None


def test_a_frame_holds_several_integrals_any_numbers_as_float64_and_reads_in_pieces(
        monkeypatch) -> None:  # fmt: skip
    """Two integrals in one answer come back apart; integers are sent as float64; a frame
    read a few bytes at a time (a pipe gives what it holds) is the frame; a header longer
    than its frame, or a frame over MAX_FRAME, is refused (exactly MAX_FRAME is not)."""
    import io

    from promp.evidence.evidence import Integral
    from promp.live.helper import integral_arrays, integrals_from, read_frame

    rng = np.random.default_rng(1)
    integrals = {2: Integral(*rng.normal(size=(3, 7)), -3.5),
                 0: Integral(*rng.normal(size=(3, 9)), 1.25)}  # fmt: skip
    frame = encode({"indices": [2, 0]}, [a for i in integrals.values() for a in integral_arrays(i)])
    pieces = io.BytesIO(frame)
    got = integrals_from(*read_frame(lambda n: pieces.read(min(n, 5))))
    assert list(got) == [2, 0]
    for k, want in integrals.items():
        for a, b in zip(got[k], want, strict=True):
            assert_array_equal(a, b)
    header, (counts,) = read_frame(io.BytesIO(encode({}, [np.arange(4)])).read)
    assert counts.dtype == np.float64 and counts.tolist() == [0.0, 1.0, 2.0, 3.0]
    lying = helper_module._LENGTH.pack(4, 5) + b"{}abc"  # a 5-byte header in 4 bytes
    with pytest.raises(ValueError):
        read_frame(io.BytesIO(lying).read)
    length = len(frame) - helper_module._LENGTH.size
    monkeypatch.setattr(helper_module, "MAX_FRAME", length)
    assert list(integrals_from(*read_frame(io.BytesIO(frame).read))) == [2, 0]
    monkeypatch.setattr(helper_module, "MAX_FRAME", length - 1)
    with pytest.raises(ValueError):
        read_frame(io.BytesIO(frame).read)


# A stand-in helper: ready, then each update answered as its mode says ("error": the engine's
# refusal; "split": one integral's frame in two writes 0.3 s apart; "half": half a frame, then
# silence). It speaks the frames with the standard library alone: it starts in a few ms, where
# one importing numpy and the engine takes a second (each of the helper's mutants runs it).
FAKE_HELPER = """
import json, struct, sys, time
PREFIX = struct.Struct("<QI")
read, out, mode = sys.stdin.buffer.read, sys.stdout.buffer, sys.argv[1]

def request():
    prefix = read(PREFIX.size)
    if len(prefix) < PREFIX.size:
        return False
    length = PREFIX.unpack(prefix)[0]
    return len(read(length)) == length

def frame(header, arrays=()):
    text = json.dumps({**header, "shapes": [[len(a)] for a in arrays]}).encode()
    body = b"".join(struct.pack(f"<{len(a)}d", *a) for a in arrays)
    return PREFIX.pack(len(text) + len(body), len(text)) + text + body

request()
out.write(frame({"ready": True})); out.flush()
while request():
    if mode == "error":
        out.write(frame({"error": "ValueError: refused"})); out.flush()
        continue
    answer = frame({"indices": [0]}, [[0.0, 1.0, 2.0], [1.0] * 3, [0.0] * 3, [-2.0]])
    out.write(answer[: len(answer) // 2]); out.flush()
    time.sleep(0.3 if mode == "split" else 60)
    out.write(answer[len(answer) // 2 :]); out.flush()
"""


def _fake(mode: str) -> Helper:
    helper = Helper("{}", "ml", ("hand", "head"),
                    command=[sys.executable, "-c", FAKE_HELPER, mode])  # fmt: skip
    assert helper.ready(wait=60.0), helper.failure
    return helper


def _observation():
    from promp.inference import Observation

    _, takes = model_and_takes(2)
    return Observation(takes[0].times[:8] - takes[0].times[0], LAYOUT.extract(takes[0])[:8],
                       ("hand", "head"))  # fmt: skip


def test_a_refusal_from_the_helpers_engine_is_no_failure_of_the_helper() -> None:
    helper = _fake("error")
    try:
        for _ in range(2):  # each update refused, the helper still asked
            assert helper.submit(1, _observation(), [0, 1]) and helper.waiting == 2
            assert helper.collect() is None
            assert helper.waiting == 0 and helper.alive
    finally:
        helper.close()


def test_an_answer_written_in_pieces_is_waited_for_and_one_cut_off_is_a_failure(
        monkeypatch) -> None:  # fmt: skip
    helper = _fake("split")
    try:
        assert helper.submit(1, _observation(), [0])
        got = helper.collect()
        assert got is not None and list(got) == [0], helper.failure
        assert_array_equal(got[0].nodes, [0.0, 1.0, 2.0])
        assert got[0].log_evidence == -2.0
        assert helper.alive and helper.waiting == 1
    finally:
        helper.close()
    monkeypatch.setattr(helper_module, "ANSWER_TIMEOUT_S", 0.5)
    helper = _fake("half")
    assert helper.submit(1, _observation(), [0])
    assert helper.collect() is None
    assert not helper.alive and helper.failure and helper.waiting == 0
    assert helper._process.poll() is not None  # killed
    helper.close()


def test_a_helper_still_starting_is_not_ready_without_waiting_and_not_given_up(
        monkeypatch) -> None:  # fmt: skip
    """``ready()`` only looks (a session's update never waits for the helper's start), and a
    helper that has not answered yet is waited for until READY_TIMEOUT_S."""
    import select as select_module

    waits = []

    class Looking:
        @staticmethod
        def select(r, w, x, timeout=None):
            waits.append(timeout)
            return select_module.select(r, w, x, timeout)

    monkeypatch.setattr(helper_module, "select", Looking)
    slow = [sys.executable, "-c", "import sys; sys.stdin.buffer.read()"]  # reads, never answers
    helper = Helper("{}", "ml", ("hand", "head"), command=slow)
    try:
        for _ in range(3):
            assert not helper.ready()
        assert helper.alive and helper._process.poll() is None
        assert waits == [0.0, 0.0, 0.0]
    finally:
        helper.close()
