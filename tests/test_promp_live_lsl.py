"""Live sessions over real LSL on the loopback (tests/lsl_loopback.cfg): an outlet replays a
recorded demonstration of a shared set, at its real rate and faster, into a session on its own
threads; the predictions equal promp.evidence.infer on the samples pushed, and docs/live.md's
robot-side reader reads them from the published streams. A stream that vanishes is found
again. Where liblsl cannot load, the message says what to do."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from promp.evidence.pipeline import infer
from promp.inference import Observation
from promp.live.status import Condition
from tests.conftest import PATIENCE_S, REPO, wait_until
from tests.live_fakes import flt_dataset, hand_model, held, robot_side_code

pylsl = pytest.importorskip("pylsl")  # the live extra (make test installs it)

from promp.live.lsl import LslTransport  # noqa: E402
from promp.live.outlets import PredictionOutlets, outlet_specs  # noqa: E402
from promp.live.session import LiveOptions, LiveSession  # noqa: E402
from tests.lsl_push import hand_outlet, push_when_due, release  # noqa: E402

UNIQUE = f"{os.getpid()}-{time.monotonic_ns() % 10**9}"  # other runs on this machine


def reader_code(name: str) -> str:
    """docs/live.md's robot-side reader, for the outputs ``name``."""
    return robot_side_code("live.md", "test_promp_live_lsl.py", "the robot-side reader", name)


@pytest.mark.parametrize("speed", [1.0, 2.5])
def test_a_replayed_demonstration_is_predicted_live_and_published(speed) -> None:
    model = hand_model()
    demo = held(flt_dataset()["top"][0], 0.6 * speed, 0.8 * speed)  # rests of 0.6, 0.8 s
    name, out = f"Hand-{UNIQUE}-{speed}", f"robot-{UNIQUE}-{speed}"
    outlet = hand_outlet(name)
    transport = LslTransport()
    outlets = PredictionOutlets(outlet_specs(model, out, "hand"), transport.outlet)
    predictions = []
    session = LiveSession(model, [f"hand={name}:hx,hy,hz"], transport,
                          LiveOptions(start="still", remainder="hand"), outlets=outlets,
                          on_prediction=predictions.append)  # fmt: skip
    reader = subprocess.Popen([sys.executable, "-c", reader_code(out)], stdout=subprocess.PIPE,
                              text=True, env=dict(os.environ))  # fmt: skip
    session.start()
    try:
        wait_until(lambda: session.snapshot().statuses[0].condition is Condition.OK,
                   what="the session to find the replayed stream")  # fmt: skip
        assert outlets.wait_for_readers(PATIENCE_S, ("probabilities", "remainder"))
        assert outlet.wait_for_consumers(PATIENCE_S)
        values_mm = demo.select(["x", "y", "z"]) * 1000.0
        start = pylsl.local_clock() + 0.05
        stamps = start + demo.times / speed  # faster: the partner moves 2.5 times as fast
        push_when_due(outlet, values_mm, stamps, stamps)
        wait_until(lambda: session.snapshot().ended, what="the movement's end (stillness)")
        assert session.flush()  # the callback had every prediction up to the end
        (movement,) = session.snapshot().ended
        # how many predictions a second is the machine's load; the last is on the movement's
        # final rows (its end cuts the still rows after the motion), whatever the load
        assert len(predictions) >= 2
        assert predictions[-1].movement == movement.number
        assert predictions[-1].n_observed == len(movement)
        assert predictions[-1].last == movement.times[-1]
        lines = []
        while len(lines) < len(predictions):
            line = reader.stdout.readline()
            assert line, "the robot-side reader stopped"
            lines.append(line)
    finally:
        reader.kill()
        session.close()
    offset = None
    for p in predictions:
        i0 = int(np.argmin(np.abs(stamps - p.start)))
        offset = p.start - stamps[i0] if offset is None else offset
        assert abs(p.start - stamps[i0] - offset) < 1e-6  # one clock correction throughout
        n = p.n_observed
        assert_allclose(p.observation.times, stamps[i0:i0 + n] - stamps[i0], rtol=0, atol=1e-9)
        assert_array_equal(p.observation.values, values_mm[i0:i0 + n] * 1e-3)
        same = infer(model, Observation(stamps[i0:i0 + n] - stamps[i0],
                                        values_mm[i0:i0 + n] * 1e-3, ("hand",)))  # fmt: skip
        # ``same`` observes times computed from the stamps another way (apart by ~1e-12 s:
        # the likelihood of hundreds of samples moves by ~1e-9 with them); the equality to
        # 1e-9 is on the very samples the prediction observed, below.
        assert_allclose(p.probabilities, same.probabilities, rtol=0, atol=1e-8)
        assert_allclose(p.duration.value, same.timing.duration.value, rtol=0, atol=1e-8)
        exact = infer(model, p.observation)
        assert_allclose(p.probabilities, exact.probabilities, rtol=0, atol=1e-9)
        assert_allclose(p.duration.value, exact.timing.duration.value, rtol=0, atol=1e-9)
    for line, p in zip(lines, predictions, strict=True):
        seq, probabilities, left, goal = ast.literal_eval(line)
        assert seq == p.seq
        assert_array_equal(probabilities, p.probabilities)
        assert left == p.remainder.after[-1]
        assert_array_equal(goal, p.remainder.mean[-1])


def test_a_vanished_stream_is_found_again_when_it_restarts() -> None:
    name = f"Vanishing-{UNIQUE}"
    outlet = hand_outlet(name)
    session = LiveSession(hand_model(), [f"hand={name}:0,1,2@mm"], LslTransport(),
                          LiveOptions(start="call"))  # fmt: skip
    session.start()
    try:
        status = lambda: session.snapshot().statuses[0].condition  # noqa: E731
        wait_until(lambda: status() is Condition.OK, what="the stream found")
        release(outlet)
        wait_until(lambda: status() is Condition.VANISHED, what="the stream vanished")
        outlet = hand_outlet(name)
        wait_until(lambda: status() is Condition.RESTARTED, what="the stream found again")
        session.begin()
        # 0.3 s of samples, stamped when taken (after the begin, none in the future) and pushed
        # at once, as a sender catching up does (stamped up to 0.3 s ahead of this machine's
        # clock instead, a loaded run read them as a clock jump that ended the movement)
        time.sleep(0.35)
        t0 = pylsl.local_clock() - 0.3
        for k in range(30):
            outlet.push_sample([k, 0.0, 0.0], t0 + 0.01 * k)
        wait_until(lambda: session.snapshot().predictions > 0, what=lambda: (
            f"predictions again (events: {[e.text for e in session.snapshot().events]})"))
    finally:
        session.close()


def test_where_liblsl_cannot_load_the_message_says_what_to_do(tmp_path, monkeypatch) -> None:
    from promp.live import lsl_available

    monkeypatch.setitem(sys.modules, "pylsl", None)  # pylsl not installed
    monkeypatch.delitem(sys.modules, "promp.live.lsl")
    available, message = lsl_available()
    assert not available
    assert "pip install 'icub-intention-studio[live]'" in message and "PYLSL_LIB" in message
    fake = tmp_path / "pylsl"  # a pylsl whose liblsl does not load, as pylsl itself says it
    fake.mkdir()
    (fake / "__init__.py").write_text("raise RuntimeError('LSL binary library file was not "
                                      "found. Please make sure that the binary file can be "
                                      "found in the package lib folder')\n")  # fmt: skip
    result = subprocess.run(
        [sys.executable, "-c", "import promp.live.lsl"], capture_output=True, text=True,
        env={**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{REPO}"}, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 1
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith("promp.live.transport.LSLUnavailable: LSL is not available: pylsl "
                           "cannot load liblsl (LSL binary library file was not found")
    assert "glibc >= 2.35" in last and "PYLSL_LIB" in last


def test_the_robot_side_reader_waits_for_a_predictor_that_is_not_there_yet() -> None:
    """No stream within a resolve's wait is said and waited for, never an IndexError."""
    reader = subprocess.Popen([sys.executable, "-c", reader_code(f"absent-{UNIQUE}")],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env=dict(os.environ))  # fmt: skip
    lines = []
    try:
        while len(lines) < 2:  # two resolves' waits gone by, each said
            line = reader.stdout.readline()
            assert line, f"the reader ended: {reader.stderr.read()}"
            lines.append(line)
    finally:
        reader.kill()
        _, err = reader.communicate(timeout=30)
    assert lines == [f"waiting for the stream absent-{UNIQUE}-probabilities\n"] * 2
    assert "Traceback" not in err


def test_lsl_available_says_whether_it_loads_and_passes_on_why_not(monkeypatch) -> None:
    from promp.live import lsl_available
    from promp.live.transport import LSLUnavailable

    assert lsl_available() == (True, "")
    refusal = LSLUnavailable("liblsl cannot be loaded here")

    class Refusing:
        @staticmethod
        def find_spec(name, path=None, target=None):
            if name == "promp.live.lsl":
                raise refusal
            return None

    monkeypatch.delitem(sys.modules, "promp.live.lsl")
    monkeypatch.delattr("promp.live.lsl", raising=False)
    monkeypatch.setattr(sys, "meta_path", [Refusing(), *sys.meta_path])
    assert lsl_available() == (False, str(refusal))
