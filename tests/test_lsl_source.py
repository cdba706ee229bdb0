"""The studio's live source without LSL (a fake transport): the streams listed with their
channels' labels, a start refused when its configuration is wrong, the predictions published
while the checkbox says so, a live hand placed as the workspace's is, and live movements
journalled into takes (app.live.live_takes): armed or not, into the primitive chosen or the
one the start marker names, released once saved, and the journals a kill left recovered at
the next start, each exactly once."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from app.core.store import Store
from app.live.live_takes import JOURNALS_DIR, TakeRecorder, recover_takes, save_recorded
from app.live.lsl_placement import PlacedTransport
from app.live.lsl_source import LiveConfig, LslSource
from app.panels.infer.live_status import commitment_html, session_html
from promp.data import Demonstration
from promp.evidence.pipeline import infer
from promp.inference import Observation
from promp.live.journal import read_journal
from promp.live.recorder import Recorder, movement_of
from promp.live.session import LiveOptions, LiveSession, live_columns
from promp.live.source import LiveInput
from robots.icub.placement import Placement
from tests.conftest import wait_until
from tests.live_fakes import (
    FakeStream,
    FakeTransport,
    flt_dataset,
    flt_workspace,
    hand_model,
    offset_in,
    replay,
    session_with,
)

LABELS = ("hand_x", "hand_y", "hand_z")


class ResolverLike(FakeTransport):
    """As LSL's resolver: a stream's labels and units come only with an inlet."""

    def find(self, wait):
        return [dataclasses.replace(d, labels=("",) * d.n_channels, units=("",) * d.n_channels)
                for d in super().find(wait)]  # fmt: skip


def top_demo():
    return flt_dataset()["top"][0]


# ---------------------------------------------------------------------- the source


def test_streams_are_listed_with_the_labels_their_inlets_tell() -> None:
    fake = ResolverLike()
    fake.add(FakeStream("Vicon", LABELS, units=("mm",) * 3, rate=250.0))
    source = LslSource(transport=lambda: fake)
    try:
        source.watch()
        (found,) = wait_until(lambda: source.found() or None, what="the stream listed")
        assert found.labels == LABELS and found.units == ("mm",) * 3 and found.rate == 250.0
    finally:
        source.close()


def test_a_stream_that_does_not_answer_does_not_hold_back_the_list() -> None:
    """A stream whose inlet hangs (gone between the look and the open: opening gives up only
    after seconds) while its description is read: a marker stream started meanwhile is listed
    at the next look, and the hung one's labels come once it answers. (The look once waited
    for each new stream's description: another program's streams coming and going then left
    a new marker stream out of the studio's list for minutes.)"""
    import threading

    entered, answer = threading.Event(), threading.Event()

    class Hanging(ResolverLike):
        def open(self, description):
            if description.name == "Stuck":
                entered.set()
                answer.wait(timeout=600.0)  # (until the test lets it answer)
            return super().open(description)

    fake = Hanging()
    fake.add(FakeStream("Stuck", LABELS, rate=100.0))
    source = LslSource(transport=lambda: fake)
    try:
        source.watch()
        wait_until(entered.is_set, what="the hung stream's inlet opened")
        fake.add(FakeStream("Cues", ("marker",), rate=0.0, markers=True))
        wait_until(lambda: any(s.name == "Cues" for s in source.found()),
                   what="the marker stream listed while the other hangs")  # fmt: skip
        assert entered.is_set() and not answer.is_set()
        answer.set()
        wait_until(lambda: {s.name: s.labels for s in source.found()}.get("Stuck") == LABELS,
                   what="the hung stream's labels once it answers")  # fmt: skip
    finally:
        answer.set()
        source.close()


def test_where_lsl_cannot_load_nothing_starts_and_the_message_says_what_to_do(
    monkeypatch,
) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "pylsl", None)
    monkeypatch.delitem(sys.modules, "promp.live.lsl", raising=False)
    source = LslSource()
    assert not source.available
    assert "pip install 'icub-intention-studio[live]'" in source.unavailable
    source.watch()  # nothing to watch with
    with pytest.raises(ValueError, match="LSL is not available"):
        source.start(hand_model(), LiveConfig("hand=Vicon:0,1,2"))
    assert source.running is None


@pytest.mark.parametrize("config, message", [
    (LiveConfig(""), "map at least one"),
    (LiveConfig("hand=Vicon:0,1"), "maps 2 channel"),
    (LiveConfig("hand=Vicon:0,1,2", start="marker"), "choose the marker stream"),
    (LiveConfig("hand=Vicon:0,1,2", start="marker", markers="type="), "no stream named"),
    (LiveConfig("hand=Vicon:0,1,2", publish=True, out="two words"), "output streams' name"),
    (LiveConfig("hand=Vicon:0,1,2", start="sometimes"), "unknown movement start"),
    (LiveConfig("hand=Vicon:0,1,2", commit=1.0), "commit threshold is a probability in"),
    (LiveConfig("hand=Vicon:0,1,2", commit=0.0), "commit threshold is a probability in"),
])  # fmt: skip
def test_a_wrong_configuration_starts_nothing(config, message) -> None:
    fake = FakeTransport()
    fake.add(FakeStream("Vicon", LABELS))
    source = LslSource(transport=lambda: fake)
    with pytest.raises(ValueError, match=message):
        source.start(hand_model(), config)
    assert source.running is None and fake.outlets == {}


def test_the_predictions_are_published_while_the_checkbox_says_so() -> None:
    fake = FakeTransport()
    stream = fake.add(FakeStream("Vicon", LABELS))
    source = LslSource(transport=lambda: fake)
    config = LiveConfig("hand=Vicon:0,1,2", start="call", publish=True, out="robot",
                        remainder="hand")  # fmt: skip
    running = source.start(hand_model(), config)
    try:
        assert source.outlets.names == ("robot-probabilities", "robot-timing", "robot-events",
                                        "robot-remainder")  # fmt: skip
        with pytest.raises(ValueError, match="running already"):
            source.start(hand_model(), config)
        wait_until(lambda: running.session.snapshot().statuses[0].healthy, what="connected")
        source.begin()
        demo = top_demo()
        stream.push(fake.now + demo.times[:40], demo.values[:40, :3])
        fake.now += demo.times[39] + 0.01
        wait_until(lambda: fake.outlets["robot-timing"].pushed, what="a prediction published")
        assert source.publish(False, "robot") == () and source.outlets.names == ()
        assert source.publish(True, "other")[0] == "other-probabilities"
        with pytest.raises(ValueError, match="output streams' name"):
            source.publish(True, "a b")
    finally:
        source.stop()
    assert source.running is None and source.outlets.names == ()
    with pytest.raises(ValueError, match="start the live source first"):
        source.publish(True, "robot")


@pytest.mark.parametrize("commit", [None, 0.9])
def test_the_commit_rule_runs_when_chosen_and_the_status_says_its_commitment(commit) -> None:
    fake = FakeTransport()
    stream = fake.add(FakeStream("Vicon", LABELS))
    source = LslSource(transport=lambda: fake)
    running = source.start(hand_model(), LiveConfig("hand=Vicon:0,1,2", start="call",
                                                    commit=commit))  # fmt: skip
    session = running.session
    try:
        wait_until(lambda: session.snapshot().statuses[0].healthy, what="connected")
        source.begin()
        demo = top_demo()
        stamps = fake.now + demo.times - demo.times[0]
        for i in range(0, demo.n_samples, 4):  # a few at a time: predictions along the way
            stream.push(stamps[i:i + 4], demo.values[i:i + 4, :3])
            fake.now = stamps[min(i + 3, demo.n_samples - 1)] + 1e-3
            seen = min(i + 4, demo.n_samples)
            last = wait_until(lambda n=seen: (p := session.snapshot().prediction) is not None
                              and p.n_observed == n and p, what="the samples seen")
    finally:
        source.stop()
    decisions = [e for e in session.snapshot().events if e.kind == "decision"]
    html = commitment_html(session.snapshot())
    if commit is None:
        assert last.committed is None and decisions == [] and html == ""
        return
    c = last.committed  # (early and wrong on flt: docs/evaluation.md, when the robot acts)
    assert c is not None and len(decisions) == 1 and decisions[0].text == c.text
    assert session.state.committing.rule.threshold == commit
    assert f"committed to {c.primitive}</b> at {c.time:.2f} s ({100 * c.phase:.0f} %)" in html
    assert html in session_html(session.snapshot(), fake.now, 30.0)


def test_a_live_hand_is_placed_as_the_workspaces_hand_is() -> None:
    """A workspace imported from another rig has its hand placed in the iCub's frame; the
    live hand (in millimetres, in the rig's frame) is placed the same way before the
    predictor sees it."""
    model, demo = hand_model(), top_demo()
    placement = Placement((0.3, -0.1, 0.05), 0.4)
    fake = FakeTransport()
    stream = fake.add(FakeStream("Vicon", LABELS, units=("mm",) * 3))
    rig = placement.undo(demo.values[:, :3]) * 1000.0  # the hand as the rig streams it
    transport = PlacedTransport(fake, LiveInput.parse("hand=Vicon:0,1,2"), placement)
    session = session_with(model, ["hand=Vicon:0,1,2"], transport, start="call")
    session.begin()
    replay(session, fake, stream, demo.times - demo.times[0], rig)
    p = session.predictions[-1]
    assert_allclose(p.observation.values, demo.values[:p.n_observed, :3], rtol=0, atol=1e-12)
    same = infer(model, Observation(p.observation.times, demo.values[:p.n_observed, :3],
                                    ("hand",)))  # fmt: skip
    assert_allclose(p.probabilities, same.probabilities, rtol=0, atol=1e-9)


# ---------------------------------------------------------------------- live takes

NAMES = ("front", "left", "top")


def recording_session(tmp_path, fake, stream_name="Vicon"):
    inputs = [f"hand={stream_name}:0,1,2"]
    recorder = TakeRecorder(tmp_path / JOURNALS_DIR, live_columns(hand_model(), inputs),
                            lambda: NAMES, "live-t")  # fmt: skip
    session = LiveSession(hand_model(), inputs, fake, LiveOptions(start="call"),
                          recorder=recorder)  # fmt: skip
    session.connect()
    session.step()
    return session, recorder


def movement(session, fake, stream, n: int, label: str = "") -> np.ndarray:
    """A movement of ``n`` samples of the replayed demonstration, begun and ended by calls."""
    demo = top_demo()
    session.begin(label)
    session.step()
    values = demo.values[:n, :3]
    stamps = replay(session, fake, stream, demo.times[:n] - demo.times[0] + 0.005, values)
    session.end(stamps[-1] - 0.005)  # ends with the rows up to then (the last one after it)
    session.step()
    session.flush()  # the recorder's sink finished it
    assert session.snapshot().movement is None
    return values


def test_a_movement_is_a_take_only_while_armed_into_the_primitive_chosen(tmp_path) -> None:
    fake = FakeTransport()
    stream = fake.add(FakeStream("Vicon", LABELS))
    session, recorder = recording_session(tmp_path, fake)
    movement(session, fake, stream, 30)
    assert session.snapshot().recorded == () and not (tmp_path / JOURNALS_DIR).exists()
    recorder.arm("top")
    session.begin()
    session.step()
    demo = top_demo()
    stamps = replay(session, fake, stream, demo.times[:25] - demo.times[0] + 0.005,
                    demo.values[:25, :3])  # fmt: skip
    number, primitive, rows = recorder.under_way()
    assert (number, primitive) == (2, "top") and rows == len(session.snapshot().movement)
    (journal,) = (tmp_path / JOURNALS_DIR / "top").glob("*.journal")
    assert read_journal(journal)[0].n_samples == rows  # acknowledged: in the journal
    session.end(stamps[-1] - 0.005)
    session.step()
    session.flush()
    (recorded,) = session.snapshot().recorded
    assert recorder.primitive_of(recorded) == "top" and recorded.journal == journal
    assert_array_equal(recorded.demo.values, demo.values[:recorded.demo.n_samples, :3])
    recorder.release(recorded)
    assert not journal.exists() and recorder.under_way() is None


def test_a_start_marker_naming_a_primitive_records_into_it(tmp_path) -> None:
    fake = FakeTransport()
    stream = fake.add(FakeStream("Vicon", LABELS))
    session, recorder = recording_session(tmp_path, fake)
    recorder.arm("top")
    movement(session, fake, stream, 30, label="left")
    movement(session, fake, stream, 30, label="unknown")
    first, second = session.snapshot().recorded
    assert recorder.primitive_of(first) == "left" and recorder.primitive_of(second) == "top"


def flt_store(tmp_path) -> Store:
    return Store.open(flt_workspace(tmp_path / "ws", per_class=4))


def journal_of(root, primitive: str, values: np.ndarray, times=None, columns=("x", "y", "z")):
    """A journal left by a kill: rows appended, never finished."""
    times = np.arange(values.shape[0]) * 0.01 + 100.0 if times is None else times
    recorder = Recorder(root / JOURNALS_DIR / primitive, columns, "live-k")
    recorder.append(movement_of(Demonstration(times, values, columns), 7))
    (path,) = (root / JOURNALS_DIR / primitive).glob("*.journal")
    return path  # the recorder is never closed: as a kill leaves it


def test_a_journal_a_kill_left_becomes_a_take_with_every_acknowledged_row(tmp_path) -> None:
    store = flt_store(tmp_path)
    root = store.state.workspace.root
    values = top_demo().values[:80, :3]
    path = journal_of(root, "top", values)
    before = len(store.state.demos["top"])
    ((color, message),) = recover_takes(root, store)
    assert color == "green" and message.startswith("Recovered top_") and "80 samples" in message
    new = store.state.demos["top"][-1]
    assert len(store.state.demos["top"]) == before + 1 and not path.exists()
    assert_array_equal(new.values, values)
    assert_allclose(new.times, np.arange(80) * 0.01, rtol=0, atol=1e-12)
    assert recover_takes(root, store) == []  # once


def test_a_take_saved_before_the_kill_is_not_recovered_twice(tmp_path) -> None:
    store = flt_store(tmp_path)
    root = store.state.workspace.root
    values = top_demo().values[:60, :3]
    times = 100.0 + np.arange(60) * 0.01
    saved = save_recorded(store, "top", Demonstration(times[:50] - times[0], values[:50],
                                                      ("x", "y", "z")))  # fmt: skip
    path = journal_of(root, "top", values, times)  # the journal holds a still tail more
    n = len(store.state.demos["top"])
    ((color, message),) = recover_takes(root, store)
    assert color == "gray" and "saved before the studio stopped" in message
    assert len(store.state.demos["top"]) == n and not path.exists()
    assert store.state.demos["top"][-1].name == saved.name


def test_a_journal_that_cannot_be_a_take_stays_where_it_is(tmp_path) -> None:
    store = flt_store(tmp_path)
    root = store.state.workspace.root
    values = top_demo().values[:40, :3]
    gone = journal_of(root, "gone", values)
    other = journal_of(root, "left", values, columns=("a", "b", "c"))
    torn = root / JOURNALS_DIR / "top" / "live-x-001.journal"
    torn.parent.mkdir(parents=True)
    torn.write_text("not a journal\n")
    messages = dict((m.split(" (")[0], c) for c, m in recover_takes(root, store))
    assert messages == {
        "An interrupted live take of gone cannot be saved": "red",
        "An interrupted live take of left cannot be saved": "red",
        "An interrupted live take cannot be read": "red",
    }
    assert gone.exists() and other.exists() and torn.exists()


def test_a_guided_take_from_a_busy_sender_is_one_live_take(tmp_path) -> None:
    """Teach's live takes follow the session's rule: a take slowed in its middle as a guided
    arm slows (the model learned from takes slowed alike), pushed by a sender that sleeps
    0.12-0.32 s now and then and stamps at the push, is one take, of every sample of its
    motion; the pauses in the stamps end nothing."""
    from promp.data import Layout, Modality
    from promp.learn import fit
    from promp.model import Settings
    from tests.live_fakes import guided_split, held, late_pushes

    train, replayed = guided_split(flt_dataset(), 1, seed=4, slow=(0.5, 1.0),
                                   replayed_slow=(0.6, 0.9))  # fmt: skip
    model = fit(train, Layout((Modality("hand", ("x", "y", "z"), unit="m"),)),
                Settings(n_basis=7, width=1.0, noise_scale=1.5, duration_temperature=1.0))
    fake = FakeTransport()
    stream = fake.add(FakeStream("Vicon", LABELS, rate=100.0))
    inputs = ["hand=Vicon:0,1,2"]
    recorder = TakeRecorder(tmp_path / JOURNALS_DIR, live_columns(model, inputs), lambda: NAMES,
                            "live-g")  # fmt: skip
    session = LiveSession(model, inputs, fake, LiveOptions(start="still"), recorder=recorder)
    session.connect()
    session.step()
    recorder.arm("top")
    klass, demo = next((k, d) for k, d in replayed if k == "top")
    take = held(demo, 1.0, 1.5)
    values = take.select(["x", "y", "z"])
    due = take.times - take.times[0]
    pushes = late_pushes(due, np.random.default_rng(7), pause_s=(0.12, 0.32))
    t0, i = fake.now, 0
    while i < due.size:
        fake.now += 0.004
        while i < due.size and t0 + pushes[i] <= fake.now:
            stream.push([fake.now + 1e-6 * i], values[i:i + 1])  # stamped at the push
            i += 1
        session.step()
    assert session.flush()
    (recorded,) = session.snapshot().recorded
    assert recorded.number == 1 and recorder.primitive_of(recorded) == "top"
    taken = recorded.demo.select(["x", "y", "z"])
    first = int(round(1.0 / demo.sample_period))  # the take's motion, inside what was kept
    i0 = offset_in(values, taken)
    assert i0 <= first + 20 and i0 + taken.shape[0] >= first + demo.n_samples - 20
    assert_allclose(taken, values[i0:i0 + taken.shape[0]], rtol=0, atol=1e-12)
    assert [e.text for e in session.snapshot().events if "paused" in e.text] == []
