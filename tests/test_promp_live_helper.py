"""The recognition's helper process (promp.live.helper): an update shared with it gives the
numbers of one process bit for bit, whichever primitive is recognised and whichever process
integrates it; a helper that dies, hangs or talks nonsense is stopped and the updates go on in
one process, said once; a session stops its helper when it closes."""

from __future__ import annotations

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


@pytest.mark.parametrize("n_classes", [2, 3])
def test_an_update_shared_with_the_helper_gives_one_process_numbers_bit_for_bit(n_classes):
    model, takes = model_and_takes(n_classes)
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
    news = []

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


def test_the_helper_answers_each_update_from_its_own_evidence_of_the_movement() -> None:
    """``serve`` in this process (what ``python -m promp.live.helper`` runs): the model once,
    then per update the new rows; its answers are the integrals of an evidence extended by
    the same rows, bit for bit, the first index alone first; a refused observation gets an
    error frame and the next update an answer."""
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
    requests.write(encode({"model": model_to_json(model), "alpha_method": "ml",
                           "modalities": list(modalities)}))  # fmt: skip
    for movement, start, stop, indices in asked:
        requests.write(encode({"movement": movement, "start": start, "indices": indices},
                              [times[start:stop], values[start:stop]]))  # fmt: skip
    bad = values[:5].copy()
    bad[2, 1] = np.nan
    requests.write(encode({"movement": 3, "start": 0, "indices": [0, 1]}, [times[:5], bad]))
    requests.write(encode({"movement": 3, "start": 0, "indices": [0, 1]},
                          [times[:5], values[:5]]))  # fmt: skip
    requests.seek(0)
    answers = io.BytesIO()
    serve(requests.read, answers.write)
    answers.seek(0)
    assert read_frame(answers.read)[0] == {"ready": True}
    evidence = None
    for _movement, start, stop, indices in asked:
        obs = Observation(times[:stop], values[:stop], modalities)
        evidence = Evidence(model, obs) if start == 0 else evidence.extended(obs)
        first = integrals_from(*read_frame(answers.read))
        rest = integrals_from(*read_frame(answers.read))
        assert list(first) == indices[:1] and list(rest) == indices[1:]
        for k, got in {**first, **rest}.items():
            want = evidence.integral(k)
            for a, b in zip(got, want, strict=True):
                assert_array_equal(a, b)
    assert "error" in read_frame(answers.read)[0]  # the NaN refused
    again = Evidence(model, Observation(times[:5], values[:5], modalities))
    first = integrals_from(*read_frame(answers.read))
    assert_array_equal(first[0].log_likelihoods, again.integral(0).log_likelihoods)
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
