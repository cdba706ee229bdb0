"""State that outlived what it was about, tried in a real browser as a new user would (issue 26):
each of these showed before the studio drew every frame from one snapshot of its state.

- a take's message ("Discarded curved_004") stayed in the Record folder after the studio
  switched to another workspace;
- a refused upload's error stayed after a later good upload;
- the Learn folder said "Fit in N ms ... from M demonstrations" before that fit had finished
  (the time of the previous fit, the count of the new demonstrations);
- choosing the Infer tab did not change the 3D view until one of its controls was touched;
- after a replay, the arm and its gizmo kept the replay's pose while the slider moved the
  prediction.
"""

from __future__ import annotations

import re
import threading
import time

import numpy as np
import pytest

from app.io import exchange
from app.scene.look import INFER, TEACH
from tests.browser import click, close_notifications, notification, open_tab, press, upload_file
from tests.conftest import StudioSpec, open_page, scenario_workspace, start_studio, wait_until
from tests.test_dataset_import import BAD_ZIPS, csv_demo, zip_of

pytestmark = pytest.mark.browser


STUDIO = StudioSpec(seed=4, n_demos=4)  # 2 primitives x 4 simulated demonstrations


def panel(studio, kind: str):
    from app.panels.data import DataPanel
    from app.panels.infer import InferPanel
    from app.panels.teach import TeachPanel

    cls = {"teach": TeachPanel, "infer": InferPanel, "data": DataPanel}[kind]
    return next(p for p in studio.panels if isinstance(p, cls))


def text(page) -> str:
    return page.inner_text("body")


def wait_text(page, wanted: str, timeout: float = 60.0) -> None:
    wait_until(lambda: wanted in text(page), timeout=timeout, what=f"{wanted!r} in the page")


def takes_zip() -> bytes:
    """One's own recordings: two primitives of three takes each (hand only)."""
    return zip_of({f"{p}/take{i}.csv": csv_demo(10 * k + i) for k, p in enumerate(("up", "down"))
                   for i in range(3)})  # fmt: skip


@pytest.fixture
def other_studio(tmp_path):
    """A studio of its own: the test switches it to another workspace."""
    studio = start_studio(scenario_workspace(tmp_path / "ws", 4, 4))
    yield studio
    studio.stop()


def test_a_take_message_stays_with_its_workspace(browser, other_studio) -> None:
    studio = other_studio
    page, _ = open_page(browser, studio)
    record = panel(studio, "teach").record
    record.controls.countdown.value = 0.5
    record.controls.trim.value = False  # a still take is kept whole
    try:
        click(page, "Record")
        wait_text(page, "● Recording into curved")
        wait_until(lambda: record.takes.recording() is not None
                   and record.takes.recording().n_samples >= 5, what="five samples")  # fmt: skip
        click(page, "Stop")
        wait_text(page, "Saved curved_004")
        click(page, "Discard last take")
        wait_text(page, "Discarded curved_004")
    finally:
        record.controls.countdown.value = 3.0
        record.controls.trim.value = True
    # Another workspace, from one's own recordings (the Data tab's Import dataset).
    open_tab(page, "Data")
    importer = panel(studio, "data").importer
    upload_file(page, importer.upload_button, "takes.zip", takes_zip())
    page.get_by_text("2 primitives, 6 demonstrations").wait_for(timeout=60_000)
    click(page, "Create workspace")
    notification(page, "Workspace created")
    open_tab(page, "Teach")
    wait_text(page, "Ready to record into down")  # the new workspace's, shown
    assert "Discarded" not in text(page), "the other workspace's take is still spoken of"
    page.close()


def test_a_refused_file_is_forgotten_once_a_good_one_is_accepted(studio, page) -> None:
    data = panel(studio, "data")
    open_tab(page, "Data")
    for refusals in (data.refusals, data.importer.refusals):
        refusals.seconds = 600.0  # the refusals would stay: their going is the studio's doing
    try:
        upload_file(page, data.upload_button, "bad.json", b"\xff" * 64)
        refused = page.locator(".mantine-Notification-root", has_text="Cannot import bad.json")
        notification(page, "Cannot import bad.json")
        model = studio.session.wait_for_model()
        upload_file(page, data.upload_button, "good.json", exchange.model_bytes(model))
        notification(page, "Model imported")
        wait_until(lambda: refused.count() == 0, timeout=60, what="the refusal gone")
        click(page, "Use the learned model")
        # The dataset import: a refused zip, then a good one.
        content, _ = BAD_ZIPS["non-numeric"]
        upload_file(page, data.importer.upload_button, "bad.zip", content)
        refused = page.locator(".mantine-Notification-root", has_text="Cannot import bad.zip")
        notification(page, "Cannot import bad.zip")
        upload_file(page, data.importer.upload_button, "good.zip", takes_zip())
        page.get_by_text("2 primitives, 6 demonstrations").wait_for(timeout=60_000)
        wait_until(lambda: refused.count() == 0, timeout=60, what="the dataset's refusal gone")
        assert "Cannot import" not in data.importer.preview.content
    finally:
        data.refusals.seconds = data.importer.refusals.seconds = 20.0
        close_notifications(page)


def test_the_fit_line_never_shows_a_fit_it_has_not_made(studio, page) -> None:
    """While the refit of a deletion runs (held here until the test lets it go), the Learn
    folder says the model is learned again, and never gives the previous fit's time with the
    new count of demonstrations."""
    store, fits = studio.session.store, studio.session.learner.fits
    n_before = sum(len(d) for d in store.state.learned.values())
    gate, real = threading.Event(), fits.fit

    def gated(training, reuse=True):
        if training.previous is not None and training.n_demos == n_before - 1:  # the refit
            gate.wait(120)
        return real(training, reuse)

    fits.fit = gated
    open_tab(page, "Teach")  # the Learn folder
    try:
        wait_text(page, f"learned from {n_before} demonstrations")
        name = store.state.demos["curved"][1].name
        row = page.locator("label", has_text=name).first.locator(
            "xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]"
        )
        row.get_by_role("button", name="Delete").dispatch_event("click")
        click(page, "Delete demonstration")
        wait_text(page, f"Learning again from {n_before - 1} demonstrations")
        # The refit's clock moves while it runs (it has no count: the last fit is the estimate).
        clock = re.compile(r"Learning again from \d+ demonstrations\.\.\. (\d+:\d\d) elapsed")
        (first,) = wait_until(lambda: clock.findall(text(page)), what="the refit's clock")
        wait_until(lambda: clock.findall(text(page)) not in ([], [first]), what="it moved")
        page.get_by_text("Learning again from").first.evaluate(
            "e => e.scrollIntoView({block: 'center'})"
        )
        page.screenshot(path="/tmp/learn_refit.png")
        assert f"learned from {n_before - 1} demonstrations" not in text(page)
        gate.set()
        wait_text(page, f"learned from {n_before - 1} demonstrations")
        assert "Learning again" not in text(page)
    finally:
        gate.set()
        del fits.fit
    store.undo_delete()
    wait_text(page, f"learned from {n_before} demonstrations")


def test_choosing_a_tab_shows_its_look(studio, page) -> None:
    infer = panel(studio, "infer")
    wait_until(lambda: infer.view is not None and infer.view.result is not None,
               timeout=120, what="an inference to show")  # fmt: skip
    studio.scene.use_panel(TEACH)
    wait_until(lambda: not studio.scene.look.inference, what="Teach's look")
    open_tab(page, "Infer")
    wait_until(lambda: studio.scene.panel == INFER and studio.scene.look.inference,
               timeout=60, what="Infer's look, with no control touched")  # fmt: skip
    open_tab(page, "Teach")
    wait_until(lambda: studio.scene.panel == TEACH and studio.scene.look.start,
               timeout=60, what="Teach's look again")  # fmt: skip


class ManualClock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def test_scrubbing_after_a_replay_moves_the_arm_with_the_prediction(studio, page) -> None:
    infer = panel(studio, "infer")
    controls = infer.controls
    open_tab(page, "Infer")

    def shown_at(percent: int):
        view = infer.view
        ok = view is not None and view.result is not None and not view.state.live
        return view.result if ok and view.state.percent == percent else None

    # the model stays the one shown while the replay plays: a refit ending meanwhile gives a
    # new path (or, while it runs, none: the replay stops), and the end checked below is the
    # shown prediction's
    wait_until(lambda: studio.session.learner.idle, what="the learner, idle")
    controls.percent.value = 20
    early = wait_until(lambda: shown_at(20), timeout=120, what="the inference at 20 %")
    clock = ManualClock()
    replay = infer.playback.replay
    replay.clock = clock

    def replay_state() -> str:
        return (f"the end of the replay ({replay.phase.value}, {replay.elapsed:.3f} of "
                f"{replay.duration:.3f} s; the replay shown {infer.playback.replay is replay})")

    try:
        press(page, page.get_by_role("button", name="Play", exact=True))
        wait_until(lambda: replay.playing, what="the replay to start")
        clock.now += 2 * early.inference.remaining
        wait_until(lambda: replay.finished, timeout=60, what=replay_state)
    finally:
        replay.clock = time.monotonic
    assert np.linalg.norm(studio.arm.hand_position() - early.future.hand[-1]) < 0.01
    # The slider moves the prediction: the arm, held by the replay, goes to its new start.
    slider = page.locator(f"[id='{controls.percent._impl.uuid}']")
    box = slider.bounding_box(timeout=60_000)
    page.mouse.click(box["x"] + 0.5 * box["width"], box["y"] + box["height"] / 2)
    wait_until(lambda: 45 <= controls.percent.value <= 55, what="the slider near 50 %")
    later = wait_until(lambda: shown_at(controls.percent.value), timeout=120,
                       what="the inference at the slider")  # fmt: skip
    start = later.future.hand[0]

    def arm_there() -> bool:
        # The arm is set first, then the gizmo brought onto the hand (ArmController.set_q): a
        # reader between the two writes sees the hand moved and the gizmo not yet, so both
        # are waited for; a gizmo left behind never gets there.
        hand = studio.arm.hand_position()
        gizmo = np.asarray(studio.arm.gizmo.position, dtype=float)
        return np.linalg.norm(hand - start) < 0.01 and np.allclose(gizmo, hand, atol=1e-5)

    def where() -> str:
        hand = studio.arm.hand_position()
        off = np.linalg.norm(np.asarray(studio.arm.gizmo.position) - hand)
        return (f"the hand at the new prediction's start ({np.linalg.norm(hand - start):.3f} m "
                f"away) with the gizmo on it ({off:.3f} m away)")  # fmt: skip

    wait_until(arm_there, timeout=60, what=where)
