"""docs/robot.md's robot-side take-over, run as it is shown against a live session over real
LSL on the loopback (tests/lsl_loopback.cfg): a session committing (--decide) and publishing
the hand's remainder; a replayed demonstration commits; the controller, reading only the
published streams, commands the hand once along the committing prediction's remainder, row
by row, and nothing for the movement's later predictions."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from promp.decision import CommitRule
from promp.live.status import Condition
from tests.conftest import PATIENCE_S, REPO, wait_until
from tests.live_fakes import flt_dataset, hand_model, held, robot_side_code

pylsl = pytest.importorskip("pylsl")  # the live extra (make test installs it)

from promp.live.lsl import LslTransport  # noqa: E402
from promp.live.outlets import PredictionOutlets, outlet_specs  # noqa: E402
from promp.live.session import LiveOptions, LiveSession  # noqa: E402
from tests.lsl_push import hand_outlet, push_when_due  # noqa: E402

UNIQUE = f"{os.getpid()}-{time.monotonic_ns() % 10**9}"  # other runs on this machine


def controller_code(name: str) -> str:
    """docs/robot.md's robot-side take-over, for the outputs ``name``."""
    return robot_side_code("robot.md", "test_robot_side_takeover.py",
                           "the robot-side take-over", name)  # fmt: skip


def test_the_robot_side_controller_follows_the_committed_remainder_once() -> None:
    model = hand_model()
    demo = held(flt_dataset()["top"][0], 0.6, 0.8)
    name, out = f"Hand-{UNIQUE}", f"robot-{UNIQUE}"
    outlet = hand_outlet(name)
    transport = LslTransport()
    outlets = PredictionOutlets(outlet_specs(model, out, "hand"), transport.outlet)
    predictions = []
    session = LiveSession(model, [f"hand={name}:hx,hy,hz"], transport,
                          LiveOptions(start="still", remainder="hand",
                                      decide=CommitRule(0.9, 0.1)),
                          outlets=outlets, on_prediction=predictions.append)  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    controller = subprocess.Popen([sys.executable, "-c", controller_code(out)],
                                  stdout=subprocess.PIPE, text=True, env=env)  # fmt: skip
    lines: list = []  # what it printed: (movement, seq, index, position) per step commanded
    threading.Thread(target=lambda: lines.extend(ast.literal_eval(line)
                                                 for line in controller.stdout),
                     daemon=True).start()  # fmt: skip
    session.start()
    try:
        wait_until(lambda: session.snapshot().statuses[0].condition is Condition.OK,
                   what="the session to find the replayed stream")  # fmt: skip
        assert outlets.wait_for_readers(60.0, ("timing", "remainder"))
        assert outlet.wait_for_consumers(PATIENCE_S)
        values_mm = demo.select(["x", "y", "z"]) * 1000.0
        stamps = pylsl.local_clock() + 0.05 + demo.times
        push_when_due(outlet, values_mm, stamps, stamps)
        wait_until(lambda: session.snapshot().ended, what="the movement's end (stillness)")
        assert session.flush()
        committing = next(p for p in predictions if p.committed is not None)
        assert committing.committed.movement == committing.movement
        assert predictions[-1].seq > committing.seq  # later predictions of it came
        rows = committing.remainder.mean
        wait_until(lambda: len(lines) >= rows.shape[0] or controller.poll() is not None,
                   what="the controller's steps")  # fmt: skip
        assert controller.poll() is None, "the robot-side controller stopped"
    finally:
        controller.kill()
        session.close()
    assert [(m, seq, index) for m, seq, index, _ in lines] == [
        (committing.movement, committing.seq, k) for k in range(rows.shape[0])
    ]  # once, the committed prediction's rows; the movement's later ones commanded nothing
    assert_array_equal(np.array([xyz for *_, xyz in lines]), rows)  # the committed rest
