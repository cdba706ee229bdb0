"""A take without a browser: the Record button's state machine (refusals, the countdown,
cancel, start, stop, the save, a failing recorder, on a clock the test moves), what a take
becomes (:func:`app.live.takes.save_take`, pure) and the controller that records and saves
it into a store on a worker."""

from __future__ import annotations

import numpy as np
import pytest

from app.live.take_controller import (
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
    assert machine.phase is Phase.SAVING and machine.take is take
    assert machine.press(25.5) == (Event.NONE, None)  # nothing while the take is saved
    machine.saved()
    assert machine.phase is Phase.IDLE and machine.take is None


def test_each_take_may_have_its_own_countdown() -> None:
    machine = RecordingMachine(countdown_s=3.0)
    _, take = machine.press(10.0, "curved", 50.0, countdown_s=0.5)
    assert take.starts_at == 10.5 and machine.remaining(10.0) == 1
    assert machine.tick(10.5) == (Event.STARTED, take)
    machine.press(11.0)
    machine.saved()
    _, take = machine.press(20.0, "curved", 50.0, countdown_s=0.0)  # at once
    assert machine.tick(20.0) == (Event.STARTED, take)
    machine.press(21.0)
    machine.saved()
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


def test_a_take_becomes_a_demonstration_or_says_why_not() -> None:
    from app.live.recorder import Recording
    from app.live.takes import TakeOptions, save_take

    times = np.arange(0.0, 4.0, 0.02)
    z = np.clip(times - 1.5, 0.0, 1.0) * 0.2  # still 1.5 s, 1 s up, still 1.5 s
    hand = np.column_stack([np.zeros_like(z), np.zeros_like(z), z])
    head = np.zeros((times.size, 3))
    new, text = save_take(Recording(times, hand, head), TakeOptions(LAYOUT))
    assert new is not None and new.raw is not None and new.values.shape[1] == 6
    assert "still ends cut" in text and f"{new.times.size} samples" in text
    assert new.times.size < times.size and np.ptp(new.values[:, 2]) > 0.19
    whole, text = save_take(Recording(times, hand, head), TakeOptions(LAYOUT, trim=False))
    assert whole.raw is None and whole.times.size == times.size and "still" not in text
    still = Recording(times, np.zeros_like(hand), head)
    refused, why = save_take(still, TakeOptions(LAYOUT))
    assert refused is None and "untick Trim idle ends" in why
    refused, why = save_take(Recording(times[:1], hand[:1], head[:1]), TakeOptions(LAYOUT))
    assert refused is None and "at least 2 are needed" in why


def test_the_controller_records_and_saves_a_take_into_the_store(tmp_path) -> None:
    """Record, the countdown, the recorder's thread, Stop, the save on a worker: the take is
    in the store, its outcome names it and the workspace it concerns; Discard sends it to the
    trash."""
    from app.core.store import Store
    from app.io.workspace import WorkspaceData
    from app.io.workspace_index import PrimitiveEntry
    from app.live.take_controller import TakeController
    from app.live.takes import TakeOptions
    from tests.conftest import wait_until

    store = Store.open(tmp_path / "ws", lambda: WorkspaceData(
        primitives=[PrimitiveEntry("wave", (1, 2, 3))], demos={"wave": []}
    ))  # fmt: skip
    def sample(t: float):
        return np.array([0.0, 0.0, 0.5 * t]), np.zeros(3)

    takes = TakeController(sample, store, countdown_s=0.0)
    options = TakeOptions(store.state.layout, trim=False)
    assert takes.press(0.0, "wave", 50.0, 0.0, None) is Event.COUNTDOWN
    assert takes.step(0.0, options)[0] is Event.STARTED and takes.phase is Phase.RECORDING
    wait_until(lambda: takes.recording().n_samples >= 5, what="five samples")
    assert takes.press(1.0, None, 0.0, 0.0, None) is Event.STOPPED
    outcome = wait_until(lambda: takes.step(1.0, options)[1], what="the save")
    assert outcome.kind == "saved" and outcome.saved == ("wave", "wave_000")
    assert outcome.root == store.state.workspace.root and takes.phase is Phase.IDLE
    (demo,) = store.state.demos["wave"]
    assert demo.n_samples >= 5 and outcome.text.startswith("Saved **wave_000**")
    assert ("wave", "wave_000") in store.state.takes  # the learner scores it
    assert takes.discard().kind == "discarded" and store.state.demos["wave"] == ()
    with pytest.raises(ValueError, match="no take saved"):
        takes.discard()
    refused = takes.press(2.0, None, 50.0, 0.0, "Create a primitive first.")
    assert refused is Event.REFUSED and takes.outcome.kind == "refused"
    takes.close()


def test_a_state_history_answers_what_was_current_at_any_recent_moment() -> None:
    """The recorder's source (app/live/history.py): the value recorded last at or before the
    time asked; before the first one, or older than what is kept, a LookupError."""
    from app.live.history import StateHistory

    now = [10.0]
    history = StateHistory(kept_s=5.0, clock=lambda: now[0])
    with pytest.raises(LookupError, match="nothing recorded"):
        history.at(10.0)
    for t, value in ((10.0, "a"), (10.5, "b"), (12.0, "c")):
        now[0] = t
        history.record(value)
    assert [history.at(t) for t in (10.0, 10.49, 10.5, 11.9, 12.0, 99.0)] == list("aabbcc")
    assert history.latest() == "c"
    with pytest.raises(LookupError, match="no value at 9.999"):
        history.at(9.999)
    now[0] = 30.0  # much later: what is older than kept_s goes, the value current then stays
    history.record("d")
    assert history.at(29.0) == "c" and history.at(30.0) == "d"
    with pytest.raises(LookupError):
        history.at(10.2)
    with pytest.raises(ValueError, match="positive"):
        StateHistory(kept_s=0.0)
