"""The movements a live session finds, as the model knows them, over real LSL on the loopback
(tests/lsl_loopback.cfg): takes of lab-records-flt slowed in their middle as a guided arm
slows near a waypoint (the model learned from takes slowed alike), pushed by a sender on a busy
machine (pauses of 0.1-0.35 s in push-time stamps, then a burst): each take is one movement,
recognised as the offline engine recognises the whole take; a pause longer than any the model
learned ends the movement."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from promp.data import Layout, Modality
from promp.evidence.pipeline import infer
from promp.learn import fit
from promp.model import Settings
from promp.observation import Observation
from promp.stillness import SMOOTH_S
from tests.live_fakes import flt_dataset, guided_split, replay_over_lsl, slowed_middle

pytest.importorskip("pylsl")  # the live extra (make test installs it)

UNIQUE = f"{os.getpid()}-{time.monotonic_ns() % 10**9}"  # other runs on this machine
LAYOUT = Layout((Modality("hand", ("x", "y", "z"), unit="m"),))
SETTINGS = Settings(n_basis=7, width=1.0, noise_scale=1.5, duration_temperature=1.0)


@pytest.fixture(scope="module")
def guided():
    """A model learned from takes with a slow phase of 0.5-1 s in their middle, and two takes
    of each class (not learned from) with one of 0.5-0.9 s."""
    train, replayed = guided_split(flt_dataset(), 2, seed=0, slow=(0.5, 1.0),
                                   replayed_slow=(0.5, 0.9))  # fmt: skip
    return fit(train, LAYOUT, SETTINGS), replayed


def offline(model, demo) -> str:
    return infer(model, Observation(demo.times - demo.times[0], demo.select(["x", "y", "z"]),
                                    ("hand",))).primitive  # fmt: skip


def test_each_guided_take_from_a_busy_sender_is_one_movement_recognised_as_offline(
    guided,
) -> None:
    model, replayed = guided
    ended, predictions, spans = replay_over_lsl(model, replayed, f"Guided-{UNIQUE}",
                                                np.random.default_rng(1), late=True)  # fmt: skip
    assert [m.ended for m in ended] == ["still"] * len(replayed)
    ends = {m.number: m.times[-1] for m in ended}  # the last prediction within the movement
    final = {p.movement: p for p in predictions if p.last <= ends.get(p.movement, np.inf)}
    for (klass, demo), movement, (stamps, _) in zip(replayed, ended, spans, strict=True):
        # the movement holds its take's motion, not the hold or the jump around it (by the
        # samples' stamps, the session's clock: a busy machine's sender pushes them late)
        assert stamps[0] - 0.5 < movement.times[0] < stamps[-1]
        assert stamps[0] < movement.times[-1] < stamps[-1] + 0.5
        assert final[movement.number].primitive == offline(model, demo) == klass


def test_a_pause_longer_than_any_learned_ends_the_movement(guided) -> None:
    model, replayed = guided
    longest = max(p.pause(["hand"]) for p in model.primitives)
    klass, demo = replayed[0]
    seconds = longest + 1.0 + SMOOTH_S  # measured, a slow phase loses up to a window to motion
    long_pause = slowed_middle(flt_dataset()[klass][0], seconds)
    ended, _, _ = replay_over_lsl(model, [(klass, long_pause)], f"Paused-{UNIQUE}",
                                  np.random.default_rng(2), late=True)  # fmt: skip
    assert len(ended) == 2 and [m.ended for m in ended] == ["still", "still"]
    assert ended[1].times[0] - ended[0].times[-1] > longest
