"""The Record button's state machine, without a browser or a thread: refusals, the countdown,
cancel, start, stop and a failing recorder, on a clock the test moves."""

from __future__ import annotations

import pytest

from app.live.take_machine import (
    HEAD_FAILED,
    Event,
    Phase,
    RecordingMachine,
    Take,
    refusal,
)
from promp.data import Layout, Modality
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT


def test_a_take_counts_down_then_records_until_stopped() -> None:
    machine = RecordingMachine(countdown_s=3.0)
    assert machine.phase is Phase.IDLE and machine.take is None
    event, take = machine.press(10.0, "curved", 50.0)
    assert event is Event.COUNTDOWN and take == Take("curved", 13.0, 50.0)
    assert machine.phase is Phase.COUNTDOWN and machine.take is take
    digits = [machine.remaining(t) for t in (10.0, 10.5, 11.0, 11.2, 12.4, 12.999)]
    assert digits == [3, 3, 2, 2, 1, 1]
    assert machine.tick(12.999) == (Event.NONE, take)
    assert machine.tick(13.0) == (Event.STARTED, take)
    assert machine.phase is Phase.RECORDING and machine.remaining(13.5) == 0
    assert machine.tick(20.0) == (Event.NONE, take)  # recording goes on until pressed
    assert machine.press(25.0) == (Event.STOPPED, take)
    assert machine.phase is Phase.IDLE and machine.take is None


def test_each_take_may_have_its_own_countdown() -> None:
    machine = RecordingMachine(countdown_s=3.0)
    _, take = machine.press(10.0, "curved", 50.0, countdown_s=0.5)
    assert take.starts_at == 10.5 and machine.remaining(10.0) == 1
    assert machine.tick(10.5) == (Event.STARTED, take)
    machine.press(11.0)
    _, take = machine.press(20.0, "curved", 50.0, countdown_s=0.0)  # at once
    assert machine.tick(20.0) == (Event.STARTED, take)
    machine.press(21.0)
    assert machine.press(30.0, "curved", 50.0)[1].starts_at == 33.0  # the machine's own
    machine.press(31.0)
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="countdown"):
            machine.press(40.0, "curved", 50.0, countdown_s=bad)
        assert machine.phase is Phase.IDLE and machine.take is None


def test_a_press_during_the_countdown_cancels() -> None:
    machine = RecordingMachine(countdown_s=3.0)
    _, take = machine.press(0.0, "direct", 40.0)
    assert machine.press(1.0) == (Event.CANCELLED, take)
    assert machine.phase is Phase.IDLE
    assert machine.tick(5.0) == (Event.NONE, None)  # nothing starts after a cancel


def test_a_failing_recorder_ends_the_take_and_only_a_recording_can_fail() -> None:
    machine = RecordingMachine(countdown_s=0.0)
    assert machine.fail() == (Event.NONE, None)
    _, take = machine.press(0.0, "curved", 50.0)
    assert machine.fail() == (Event.NONE, None)  # still counting down
    assert machine.tick(0.0) == (Event.STARTED, take)
    assert machine.fail() == (Event.STOPPED, take)
    assert machine.phase is Phase.IDLE


def test_a_refused_press_changes_nothing() -> None:
    machine = RecordingMachine()
    assert machine.press(0.0, None, 50.0, refused="no primitive") == (Event.REFUSED, None)
    assert machine.phase is Phase.IDLE and machine.take is None
    with pytest.raises(ValueError, match="needs a primitive"):
        machine.press(0.0, None, 50.0)
    with pytest.raises(ValueError, match="countdown"):
        RecordingMachine(countdown_s=-1.0)


def test_refusals_say_why() -> None:
    assert refusal("curved", LAYOUT, None, 50.0) is None
    assert "Create a primitive first" in refusal(None, LAYOUT, None, 50.0)
    failed = refusal("curved", LAYOUT, "camera 9: cannot be opened", 50.0)
    assert failed.startswith(HEAD_FAILED) and "camera 9" in failed
    assert "within 10-100 Hz, got 5" in refusal("curved", LAYOUT, None, 5.0)
    forces = Layout((LAYOUT.modality("hand"), Modality("force", ("fx", "fy", "fz"), unit="N")))
    assert "also hold force" in refusal("curved", forces, None, 50.0)
    hand_only = Layout((LAYOUT.modality("hand"),))
    assert refusal("curved", hand_only, "no camera", 50.0) is None  # the head is not recorded
