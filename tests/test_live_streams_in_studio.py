"""The Live streams (LSL) source in the studio, in Chromium, over real LSL on the loopback
(tests/lsl_loopback.cfg): an outlet replaying a demonstration of lab-records-flt (in mm, at
its real rate and 2.5 times faster) is listed, its mapping guessed, a wrong one refused, the
right one started; each movement's prediction reaches the bars and the 3D view and equals
promp.evidence.infer on the samples pushed, and the studio's published streams carry the
same numbers; injected faults show their status in the page; a movement recorded in Teach's
Live takes lands in the workspace; the commit rule chosen in the page says its commitment;
with Robot takes over, the arm finishes a committed movement along its predicted remainder."""

from __future__ import annotations

import itertools
import os
import threading
import time

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.live.inference import TUBE_POINTS
from app.panels.infer import InferPanel
from app.panels.infer.view_model import LSL
from promp.evidence.pipeline import infer
from promp.inference import Observation
from robots.icub.ik import POSITION_TOLERANCE_M
from tests.browser import (
    choose,
    click,
    close_notifications,
    notification,
    open_tab,
    screenshot,
)
from tests.conftest import PATIENCE_S, PageSpec, StudioSpec, wait_frames, wait_until
from tests.live_fakes import flt_dataset, flt_workspace, held, offset_in

pylsl = pytest.importorskip("pylsl")  # the live extra (make test installs it)

from tests import lsl_push  # noqa: E402
from tests.lsl_push import hand_outlet, open_inlet, push_when_due, release  # noqa: E402

pytestmark = pytest.mark.browser

_COUNT = itertools.count(1)
LABELS = ("hand_x", "hand_y", "hand_z")


def unique(stem: str) -> str:
    """A stream name no other test (another worker, another run) uses."""
    return f"{stem}-{os.getpid()}-{next(_COUNT)}"


STUDIO = StudioSpec(make=lambda root, _: flt_workspace(root, per_class=6),
                    ready=lambda s: s.session.snapshot().model is not None)  # fmt: skip
PAGE = PageSpec(tab="Infer")


def infer_panel(studio) -> InferPanel:
    return next(p for p in studio.panels if isinstance(p, InferPanel))


def store(studio):
    """The studio's store, as its loop sees it now."""
    return studio.session.snapshot().store


def row(page, label: str):
    return page.locator("label", has_text=label).first.locator(
        "xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]"
    )


class Replayer:
    """An LSL outlet of the hand in millimetres at 100 Hz, labelled, whose samples a test
    pushes at their times (stamps on this machine's clock)."""

    def __init__(self, name: str, n_channels: int = 3):
        self.name = name
        self.outlet = hand_outlet(name, (LABELS + ("extra_1", "extra_2"))[:n_channels])
        self.last = pylsl.local_clock()
        self.sent: list[tuple[np.ndarray, np.ndarray]] = []  # (stamps, values in m) pushed

    def history(self) -> tuple[np.ndarray, np.ndarray]:
        """Every sample pushed: stamps (n,) and values (n, 3) in metres (a movement's
        observation may start with still rows of the push before)."""
        return (np.concatenate([t for t, _ in self.sent]),
                np.concatenate([v for _, v in self.sent]))  # fmt: skip

    def push(self, values_mm: np.ndarray, step: float = 0.01, jump: float = 0.0) -> np.ndarray:
        """Push ``values_mm`` (n, k) one every ``step`` seconds of real time, stamped as
        pushed (plus ``jump``); their stamps."""
        start = max(pylsl.local_clock(), self.last) + 0.02
        stamps = start + step * np.arange(values_mm.shape[0])
        push_when_due(self.outlet, values_mm, stamps, stamps + jump)
        self.last = stamps[-1] + jump
        self.sent.append((stamps + jump, values_mm / 1000.0))
        return stamps + jump

    def push_paced(self, values_mm: np.ndarray, paced, chunk: int = 5) -> np.ndarray:
        """Push ``values_mm`` (n, k) stamped one step (0.01 s) apart, ``chunk`` rows at a time,
        each chunk when due or, when later, once ``paced()`` returned after the one before
        (a sender that waits for its receiver: the stamps are the same whatever the
        machine's load, only their lateness grows); their stamps."""
        start = max(pylsl.local_clock(), self.last) + 0.02
        stamps = start + 0.01 * np.arange(values_mm.shape[0])
        for i in range(0, values_mm.shape[0], chunk):
            part = slice(i, i + chunk)
            push_when_due(self.outlet, values_mm[part], stamps[part], stamps[part])
            paced()
        self.last = stamps[-1]
        self.sent.append((stamps, values_mm / 1000.0))
        return stamps


def top_demo(speed: float):
    return held(flt_dataset()["top"][0], 0.6 * speed, 0.8 * speed)


def expected(model, stamps: np.ndarray, values_m: np.ndarray, start: float, n: int):
    """promp.evidence.infer on the ``n`` samples pushed from the one stamped ``start``."""
    i0 = int(np.argmin(np.abs(stamps - start)))
    obs = Observation(stamps[i0:i0 + n] - stamps[i0], values_m[i0:i0 + n], ("hand",))
    return obs, infer(model, obs, n_points=TUBE_POINTS)


def read_published(name: str, into: list, stop: threading.Event) -> threading.Event:
    """Read the studio's ``name``-timing and -probabilities into ``into`` (pairs by seq)."""
    ready = threading.Event()

    def run() -> None:
        inlets = {}
        try:
            for kind in ("timing", "probabilities"):
                (info,) = pylsl.resolve_byprop("name", f"{name}-{kind}", 1, PATIENCE_S)
                inlets[kind] = open_inlet(info, 30.0, max_buflen=60, recover=False)
            ready.set()
            rows: dict = {}
            while not stop.is_set():
                for kind, inlet in inlets.items():
                    samples, _ = inlet.pull_chunk(timeout=0.05)
                    for sample in samples:
                        rows.setdefault(int(sample[0]), {})[kind] = np.array(sample)
                for seq in sorted(s for s, r in rows.items() if len(r) == 2):
                    into.append(rows.pop(seq))
        finally:  # released by the thread that pulls from them, once it stopped
            for inlet in inlets.values():
                release(inlet)

    threading.Thread(target=run, daemon=True).start()
    return ready


def shown_movement(page, studio, hand: Replayer, speed: float, movement: int):
    """Replay the demonstration at ``speed``: a new movement, whose last prediction shown in
    the bars and in 3D equals the engine's on the samples pushed. The samples' stamps and
    values (m). (A pusher the loaded machine starves for over 0.5 s pauses the stream, which
    ends a movement: the rest is then one more, predicted and compared as well.)"""
    panel, model = infer_panel(studio), studio.live.running.model
    demo = top_demo(speed)
    values_m = demo.select(["x", "y", "z"])
    session = studio.live.running.session
    ended = len(session.snapshot().ended)
    stamps = hand.push(values_m * 1000.0, step=0.01 / speed)
    wait_until(lambda: len(session.snapshot().ended) > ended and
               session.snapshot().movement is None, what="the movement's end (stillness)")
    prediction = session.snapshot().prediction
    assert prediction.movement >= movement and prediction.n_observed > 20
    # the movement's answer is on its final rows (its end cut the still rows after it)
    assert prediction.n_observed == len(session.snapshot().ended[-1])
    view = wait_until(lambda: panel.view if panel.view is not None and
                      panel.view.samples.prediction is prediction else None,
                      what="the last prediction shown")  # fmt: skip
    result = view.result
    wait_until(lambda: studio.scene.inference.drawn.result is result,
               what="the prediction drawn in 3D")  # fmt: skip
    assert studio.scene.inference.has_shape
    # The rows observed are rows pushed, in order, on the pushes' steps; a movement's first
    # rows may be still ones of the push before, the pause between re-anchored by the time
    # base: the rows are found by value, the steps checked within this push.
    every_stamp, every_value = hand.history()
    n, observed = prediction.n_observed, result.observation
    base = max(0, every_stamp.size - stamps.size - 100)  # this push, a second before it
    i0 = base + offset_in(every_value[base:], observed.values)
    assert_allclose(observed.values, every_value[i0:i0 + n], rtol=0, atol=1e-12)
    k = min(n, i0 + n - (every_stamp.size - stamps.size)) - 1  # steps within this push
    assert_allclose(np.diff(observed.times)[-k:], np.diff(every_stamp[i0:i0 + n])[-k:],
                    rtol=0, atol=1e-6)  # fmt: skip
    same = infer(model, observed, n_points=TUBE_POINTS)  # the engine on the same samples
    assert_allclose(result.inference.probabilities, same.probabilities, rtol=0, atol=1e-9)
    assert_allclose(result.inference.prediction.mean, same.prediction.mean, rtol=0, atol=1e-9)
    assert_allclose(result.inference.duration, same.duration, rtol=0, atol=1e-9)
    for name, p in zip(model.names, same.probabilities, strict=True):
        page.locator(f'[data-primitive="{name}"][data-p="{p:.6f}"]').wait_for()
    page.get_by_text(f"Observed: {prediction.n_observed} samples").wait_for()
    return stamps, values_m


def test_a_replayed_demonstration_is_listed_mapped_started_and_predicted_in_the_page(
    page, studio, artifacts
) -> None:
    panel = infer_panel(studio)
    c, live = panel.controls, panel.lsl.controls
    hand = Replayer(unique("StudioHand"))
    choose(page, c.source, LSL)
    page.get_by_text(hand.name, exact=True).wait_for()  # listed, with its rate and channels
    guessed = f"hand={hand.name}:hand_x,hand_y,hand_z"
    wait_until(lambda: live.mapping.value == guessed, what="the mapping guessed from the labels")
    # A wrong mapping is refused, saying why; nothing starts.
    row(page, "Mapping").locator("textarea").fill(f"hand={hand.name}:hand_x,hand_y")
    wait_until(lambda: live.mapping.value.endswith("hand_y"), what="the mapping typed")
    click(page, "Start")
    notification(page, "Cannot start the live source", "maps 2 channel(s)")
    assert studio.live.running is None
    close_notifications(page)
    row(page, "Mapping").locator("textarea").fill(guessed)
    wait_until(lambda: live.mapping.value == guessed, what="the mapping typed")
    out = unique("studio-out")
    page.get_by_text("Predictions out (LSL)", exact=True).first.dispatch_event("click")
    row(page, "Streams' name").locator("input").first.fill(out)
    wait_until(lambda: live.out.value == out, what="the outputs' name typed")
    row(page, "Publish predictions").locator("input").first.dispatch_event("click")
    wait_until(lambda: live.publish.value, what="publishing on")
    click(page, "Start")
    page.locator(f'[data-stream="{hand.name}"][data-condition="ok"]').wait_for()
    page.get_by_text(f"Publishing {out}-probabilities").wait_for()
    published: list = []
    stop = threading.Event()
    assert read_published(out, published, stop).wait(PATIENCE_S)
    model = studio.live.running.model
    pushed = []
    try:
        for speed, movement in ((1.0, 1), (2.5, 2)):
            pushed.append(shown_movement(page, studio, hand, speed, movement))
            if movement == 1:
                screenshot(page, artifacts / "infer_live_source.png")
        last = studio.live.running.session.snapshot().prediction
        wait_until(lambda: published and int(published[-1]["timing"][0]) >= last.seq,
                   what="the last prediction published")  # fmt: skip
    finally:
        stop.set()
    # The predictions published equal the engine's on the samples each observed: those
    # whose start is a pushed sample's stamp (a movement after a pause is on the time base's
    # re-anchored clock: it was compared in the page above).
    assert len(published) >= 2  # two movements (how many a second is the machine's load)
    every_stamp, every_value = hand.history()
    checked = 0
    for row_ in published[:: max(1, len(published) // 40)] + published[-1:]:
        timing, probabilities = row_["timing"], row_["probabilities"]
        start, n = timing[2], int(timing[14])
        if np.min(np.abs(every_stamp - start)) > 1e-3:  # a step is 4 ms or more
            continue
        _, same = expected(model, every_stamp, every_value, start, n)
        assert_allclose(probabilities[2:], same.probabilities, rtol=0, atol=1e-9)
        assert_allclose(timing[7:10], [same.timing.duration.value, same.timing.duration.low,
                                       same.timing.duration.high], rtol=0, atol=1e-9)
        checked += 1
    assert checked >= 5
    studio.live.stop()
    wait_until(lambda: live.run.label == "Start", what="stopped")


def test_the_commit_rule_is_chosen_in_the_page_and_its_commitment_shown(
    page, studio, artifacts
) -> None:
    panel = infer_panel(studio)
    live = panel.lsl.controls
    hand = Replayer(unique("CommitHand"))
    mapped(page, studio, hand)
    assert not live.commit.value and not live.threshold.visible  # off by default
    row(page, "Commit to a primitive").locator("input").first.dispatch_event("click")
    wait_until(lambda: live.commit.value and live.threshold.visible, what="the rule chosen")
    click(page, "Start")
    page.locator(f'[data-stream="{hand.name}"][data-condition="ok"]').wait_for()
    session = studio.live.running.session
    assert session.state.committing.rule.threshold == live.threshold.value
    hand.push(top_demo(1.0).select(["x", "y", "z"]) * 1000.0)
    made = wait_until(lambda: (p := session.snapshot().prediction) is not None and p.committed,
                      what="a commitment")  # fmt: skip
    shown = page.locator(f'[data-committed="{made.index}"]')
    shown.wait_for()
    text = " ".join(shown.inner_text().split())
    assert text.startswith(f"Movement {made.movement}: committed to {made.primitive} at "
                           f"{made.time:.2f} s ({100 * made.phase:.0f} %)")  # fmt: skip
    screenshot(page, artifacts / "infer_live_commit.png")
    studio.live.stop()
    wait_until(lambda: live.run.label == "Start", what="stopped")


class Pusher(threading.Thread):
    """Pushes a slow circle (mm) into ``outlet`` at ``rate`` Hz, NaNs while ``nan``, nothing
    while ``paused``, its stamps ``jump`` seconds off from when it is set."""

    def __init__(self, outlet, rate: float = 100.0):
        super().__init__(daemon=True)
        self.outlet, self.rate = outlet, rate
        self.nan = self.paused = False
        self.jump = 0.0
        self.stop = threading.Event()

    def run(self) -> None:
        next_at = pylsl.local_clock()
        while not self.stop.is_set():
            next_at += 1.0 / self.rate
            time.sleep(max(0.0, next_at - pylsl.local_clock()))
            if self.paused:
                continue
            t = next_at
            row = [np.nan] * 3 if self.nan else [100 * np.cos(t), 100 * np.sin(t), 0.0]
            self.outlet.push_sample(row, t + self.jump)


def mapped(page, studio, hand: Replayer) -> None:
    """The Live source stopped, if it ran, and ``hand``'s three labelled channels mapped."""
    panel = infer_panel(studio)
    c, live = panel.controls, panel.lsl.controls
    choose(page, c.source, LSL)
    if studio.live.running is not None:
        click(page, "Stop")
        wait_until(lambda: studio.live.running is None, what="the source stopped")
    page.get_by_text(hand.name, exact=True).wait_for()
    mapping = f"hand={hand.name}:hand_x,hand_y,hand_z"
    row(page, "Mapping").locator("textarea").fill(mapping)
    wait_until(lambda: live.mapping.value == mapping, what="the mapping typed")


def start_mapped(page, studio, hand: Replayer) -> None:
    """The Live source (re)started on ``hand``, its three labelled channels mapped."""
    mapped(page, studio, hand)
    click(page, "Start")
    page.locator(f'[data-stream="{hand.name}"][data-condition="ok"]').wait_for()


def test_faults_of_a_stream_show_their_status_and_nothing_breaks(page, studio, artifacts):
    # A marker stream on the network fills the (hidden) marker dropdown; movements start by
    # stillness, so the session opens no marker stream (it once read the studio's own events
    # back, each event the next marker, until the memory ran out).
    cues_name = unique("Cues")
    cues = lsl_push.outlet(pylsl.StreamInfo(cues_name, "Markers", 1, 0, pylsl.cf_string,
                                            f"src-{cues_name}"))  # fmt: skip
    panel = infer_panel(studio)
    choose(page, panel.controls.source, LSL)  # (the file's first test chose it: not relied on)
    markers = panel.lsl.controls.markers
    wait_until(lambda: any(cues_name in o for o in markers.options), what="the cues listed")
    faulty = Replayer(unique("FaultyHand"))
    start_mapped(page, studio, faulty)
    assert studio.live.running.config.markers == ""
    assert len(studio.live.running.session.snapshot().statuses) == 1  # the hand's alone
    cues.push_sample(["start top"])
    pusher = Pusher(faulty.outlet)
    pusher.start()

    def shows(condition: str, detail: str = "") -> None:
        """The status, or (when the next fault came before the page showed it: a loaded
        machine) its line in the session's news."""
        status = page.locator(f'[data-stream="{faulty.name}"][data-condition="{condition}"]')
        news = page.get_by_text(f"stream '{faulty.name}': {condition}")
        (status.filter(has_text=detail) if detail else status).or_(news).first.wait_for()

    try:
        shows("ok")
        pusher.nan = True
        shows("bad values", "NaN")
        screenshot(page, artifacts / "infer_live_fault.png")
        pusher.nan = False
        pusher.jump = 5.0
        shows("clock jumped")
        pusher.paused = True
        shows("stalled", "no sample")
        pusher.rate, pusher.paused = 40.0, False
        shows("rate changed")
    finally:
        pusher.stop.set()
        pusher.join()
    release(faulty.outlet)
    shows("vanished")
    two = Replayer(faulty.name, n_channels=2)  # the same name, without the mapping's channels
    shows("wrong channels", "hand_z")
    release(two.outlet)
    back = Replayer(faulty.name)
    shows("restarted")
    start = len(studio.live.running.session.snapshot().ended)
    back.push(np.tile([[0.0, 0.0, 0.0]], (10, 1)))
    wait_frames(studio)
    assert studio.live.running is not None and studio.loop.frames_done > 0
    assert not [n for n in studio.notices if n[0] == "Internal error"]
    assert not [e for e in studio.live.running.session.snapshot().events if "marker" in e.text]
    release(cues)
    assert len(studio.live.running.session.snapshot().ended) >= start
    click(page, "Stop")
    wait_until(lambda: studio.live.running is None, what="the source stopped")


def test_a_live_movement_recorded_in_teach_lands_in_the_workspace(page, studio, artifacts):
    """With Record live movements on, the movement stillness finds is journalled as it comes
    (the rows acknowledged shown) and saved as a take of the chosen primitive: every sample
    pushed between its start and its end, in metres, on its own times."""
    hand = Replayer(unique("TakeHand"))
    start_mapped(page, studio, hand)
    primitive = studio.session.snapshot().primitive
    before = [d.name for d in store(studio).demos[primitive]]
    open_tab(page, "Teach")
    try:
        page.get_by_text("Live takes (LSL)", exact=True).first.dispatch_event("click")
        row(page, "Record live movements").locator("input").first.dispatch_event("click")
        page.get_by_text("Recording each live movement into").wait_for()
        ended = len(studio.live.running.session.snapshot().ended)
        demo = top_demo(1.0)
        values_m = demo.select(["x", "y", "z"])
        stamps = hand.push(values_m * 1000.0)
        notification(page, "Live take saved", f"into {primitive} from live movement")
        screenshot(page, artifacts / "teach_live_take.png")
    finally:
        open_tab(page, "Infer")
    session = studio.live.running.session
    assert len(session.snapshot().ended) == ended + 1
    wait_until(lambda: len(store(studio).demos[primitive]) == len(before) + 1,
               what="the take in the store")  # fmt: skip
    (take,) = [d for d in store(studio).demos[primitive] if d.name not in before]
    assert (studio.workspace / "demos" / primitive / f"{take.name}.csv").is_file()
    taken = take.select(["x", "y", "z"])
    assert take.n_samples > 50
    i0 = offset_in(values_m, taken)
    assert_allclose(taken, values_m[i0:i0 + take.n_samples], rtol=0, atol=1e-9)
    assert_allclose(np.diff(take.times), np.diff(stamps[i0:i0 + take.n_samples]), atol=1e-6)
    journals = studio.workspace / "live-journals"
    assert journals.is_dir() and not [p for p in journals.rglob("*") if p.is_file()]  # released
    click(page, "Stop")
    wait_until(lambda: studio.live.running is None, what="the source stopped")


def read_events(name: str, into: list, stop: threading.Event) -> threading.Event:
    """Read the studio's ``name``-events markers into ``into``."""
    ready = threading.Event()

    def run() -> None:
        (info,) = pylsl.resolve_byprop("name", f"{name}-events", 1, PATIENCE_S)
        inlet = open_inlet(info, 30.0, max_buflen=60, recover=False)
        ready.set()
        try:
            while not stop.is_set():
                samples, _ = inlet.pull_chunk(timeout=0.05)
                into.extend(s[0] for s in samples)
        finally:  # released by the thread that pulls from it, once it stopped
            release(inlet)

    threading.Thread(target=run, daemon=True).start()
    return ready


def distance_to_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Each point's (n, 3) distance to the polyline ``path`` (m, 3), metres."""
    a, b = path[:-1], path[1:]
    ab = b - a
    t = np.einsum("pmk,mk->pm", points[:, None] - a, ab) / np.maximum(
        np.einsum("mk,mk->m", ab, ab), 1e-18)
    closest = a + np.clip(t, 0.0, 1.0)[..., None] * ab
    return np.linalg.norm(points[:, None] - closest, axis=2).min(axis=1)


def test_the_robot_takes_over_a_committed_movement_along_its_predicted_remainder(
    page, studio, artifacts
) -> None:
    """With Commit to a primitive and Robot takes over ticked, the movement commits, the
    decision is published, and the arm's hand goes along the remainder of the prediction the
    take-over started from (each commanded target on it, each hand position reached within
    IK's reach of it, ending at its predicted end), not where it was, nor at another
    primitive's end; later predictions of the movement do not move it elsewhere."""
    from app.live.inference import InferResult
    from app.live.replay import Phase

    panel = infer_panel(studio)
    live, arm, replay = panel.lsl.controls, panel.ctx.arm, panel.playback.replay
    hand = Replayer(unique("TakeOverHand"))
    mapped(page, studio, hand)
    assert not live.takeover.value and not live.takeover.disabled  # off by default, available
    for label, handle in (("Commit to a primitive", live.commit),
                          ("Robot takes over", live.takeover)):  # fmt: skip
        if not handle.value:
            row(page, label).locator("input").first.dispatch_event("click")
            wait_until(lambda h=handle: h.value, what=f"{label} ticked")
    out = unique("takeover-out")
    name_field = row(page, "Streams' name").locator("input").first
    if not name_field.is_visible():  # the folder is closed (an earlier test may have opened it)
        page.get_by_text("Predictions out (LSL)", exact=True).first.dispatch_event("click")
    name_field.fill(out)
    wait_until(lambda: live.out.value == out, what="the outputs' name typed")
    if not live.publish.value:
        row(page, "Publish predictions").locator("input").first.dispatch_event("click")
        wait_until(lambda: live.publish.value, what="publishing on")
    click(page, "Start")
    page.locator(f'[data-stream="{hand.name}"][data-condition="ok"]').wait_for()
    page.locator('[data-takeover="waiting"]').wait_for()
    events: list = []
    stop = threading.Event()
    assert read_events(out, events, stop).wait(PATIENCE_S)
    commanded: list = []  # (target, hand reached) of every step the arm was commanded
    move = replay.move_hand

    def recorded(target):
        result = move(target)
        commanded.append((np.array(target, dtype=float), arm.hand_position()))
        return result

    replay.move_hand = recorded
    before = arm.hand_position()

    def paced() -> None:
        """While a movement is under way, a prediction after each chunk: the movement gets
        one every 50 ms of its samples however busy the machine (at a busy machine's own
        pace, the movement of under a second can commit at its last prediction, and leave
        none after the commitment to check, nor a remainder longer than IK's tolerance)."""
        session = studio.live.running.session
        seen = session.snapshot()
        if seen.movement is not None:
            wait_until(lambda: (session.snapshot().predictions > seen.predictions
                                or session.snapshot().movement is None),
                       what="a prediction on the samples pushed")  # fmt: skip

    try:
        hand.push_paced(top_demo(1.0).select(["x", "y", "z"]) * 1000.0, paced)
        start = wait_until(lambda: panel.takeover.state.started, what=lambda: (
            f"the robot taking over; the session's events so far: {events[-12:]}"))  # fmt: skip
        c = start.commitment
        assert c is not None and c.movement == start.prediction.movement
        wait_until(lambda: any(f"movement {c.movement} committed to {c.primitive!r}" in e
                               for e in events), what="the decision event published")
        wait_until(lambda: replay.phase is Phase.FINISHED, what="the take-over played out")
        shown = page.locator(f'[data-takeover="{c.movement}"]')
        shown.wait_for()
        text = " ".join(shown.inner_text().split())
        assert text.startswith(f"Movement {c.movement}: the robot takes over (committed to "
                               f"{c.primitive!r} at {c.time:.2f} s")  # fmt: skip
        wait_until(lambda: len(studio.live.running.session.snapshot().ended) >= 1,
                   what="the movement's end")  # the predictions after it came and went
        wait_frames(studio)
        screenshot(page, artifacts / "takeover.png")  # docs/takeover.png: copied from here
    finally:
        stop.set()
        replay.move_hand = move
    model = studio.live.running.model
    p = start.prediction
    future = InferResult(model, p.observation, p.inference).future
    path = future.hand
    assert_allclose(replay.positions, path, rtol=0, atol=0)  # the committed path, kept
    later = studio.live.running.session.snapshot().prediction
    assert later.seq > p.seq  # later predictions of the movement came, and changed nothing
    targets = np.array([t for t, _ in commanded])
    reached = np.array([h for _, h in commanded])
    # its start and its end at least (the steps on the way are one a frame: a busy machine
    # commits late, once at 99 % observed, and a remainder shorter than a frame has none)
    assert len(commanded) >= 2
    assert_allclose(targets[0], path[0], rtol=0, atol=1e-12)  # first step: onto its start
    assert_allclose(targets[-1], path[-1], rtol=0, atol=1e-12)  # last: its predicted end
    assert distance_to_path(targets, path).max() < 1e-9  # every target on the path
    assert distance_to_path(reached, path).max() < 0.01  # every pose reached: within 1 cm
    length = np.linalg.norm(np.diff(path, axis=0), axis=1).sum()
    end = arm.hand_position()
    # at the predicted end: within 1 cm, and within half the path's length (nearer its end
    # than its start) or IK's tolerance, whichever is longer (the arm reaches a target that
    # close, and a late commitment leaves a short path)
    assert length > 0 and np.linalg.norm(end - path[-1]) < min(
        0.01, max(0.5 * length, POSITION_TOLERANCE_M))
    assert np.linalg.norm(end - before) > 0.5 * np.linalg.norm(path[-1] - before)
    # nearer the committed primitive's taught ends than any other primitive's
    ends = {name: np.median([d.select(["x", "y", "z"])[-1] for d in demos], axis=0)
            for name, demos in store(studio).demos.items()}  # fmt: skip
    away = {name: float(np.linalg.norm(end - e)) for name, e in ends.items()}
    assert min(away, key=away.get) == c.primitive
    assert all(a > 0.05 for name, a in away.items() if name != c.primitive)
    studio.live.stop()
    wait_until(lambda: live.run.label == "Start", what="stopped")
