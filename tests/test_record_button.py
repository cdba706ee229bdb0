"""The Record button where the studio cannot record, in a real browser: disabled (greyed,
not clickable) with the reason beside it, in a workspace whose modalities the studio cannot
record and in one whose hand stays in its own frame; enabled again in a workspace of the
iCub's hand and head. Space (or any press) there is refused with the same words
(:func:`app.live.take_controller.workspace_refusal`)."""

from __future__ import annotations

import numpy as np
import pytest

from app.io.hand_frame import HandFrame
from app.io.workspace import Workspace, WorkspaceData
from app.io.workspace_index import PALETTE, PrimitiveEntry
from app.live.take_controller import OWN_FRAME_REFUSAL, workspace_refusal
from promp.data import Demonstration, Layout, Modality
from tests.browser import close_notifications, notification, open_tab, screenshot
from tests.conftest import open_page, scenario_workspace, start_studio, wait_until
from tests.synthetic import make_dataset

HAND = Modality("hand", ("x", "y", "z"), unit="m", kind="linear")
EMG = Modality("emg", ("e0", "e1"), unit="V")
HAND_AND_EMG = Layout((HAND, EMG))


def hand_and_emg() -> WorkspaceData:
    """Two primitives of a hand and two EMG channels: a workspace the studio cannot record."""
    dataset = make_dataset(seed=5, n_demos=3)
    demos = {
        name: [Demonstration(d.times, d.values[:, :5], (*HAND.columns, *EMG.columns), d.name)
               for d in items]
        for name, items in dataset.items()
    }  # fmt: skip
    return WorkspaceData(
        primitives=[PrimitiveEntry(n, PALETTE[i]) for i, n in enumerate(demos)],
        demos=demos, layout=HAND_AND_EMG,
    )  # fmt: skip


def teach_panel(studio):
    from app.panels.teach import TeachPanel

    return next(p for p in studio.panels if isinstance(p, TeachPanel))


def record_button(page):
    return page.get_by_role("button", name="Record", exact=True)


def background(locator) -> tuple[int, ...]:
    """The button's drawn background colour, (r, g, b)."""
    css = locator.evaluate("b => getComputedStyle(b).backgroundColor")
    return tuple(int(float(v)) for v in css[css.index("(") + 1 : css.index(")")].split(",")[:3])


def test_the_refusal_is_one_text_for_the_button_and_a_press() -> None:
    from robots.icub.layout import STUDIO_LAYOUT

    assert workspace_refusal("reach", STUDIO_LAYOUT) is None
    assert workspace_refusal("reach", STUDIO_LAYOUT, own_frame=True) == OWN_FRAME_REFUSAL
    emg = workspace_refusal("reach", HAND_AND_EMG)
    assert emg.startswith("Recording is off in this workspace: its demonstrations also hold "
                          "emg, which the studio cannot record")  # fmt: skip
    assert workspace_refusal(None, STUDIO_LAYOUT).startswith("Create a primitive first")


@pytest.mark.browser
def test_record_looks_disabled_with_its_reason_where_it_cannot_record(
    browser, tmp_path, artifacts
) -> None:
    Workspace.create(tmp_path / "emg", hand_and_emg())
    studio = start_studio(tmp_path / "emg")
    page, _ = open_page(browser, studio)
    try:
        open_tab(page, "Teach")
        teach = teach_panel(studio)
        button = record_button(page)
        reason = workspace_refusal("left", HAND_AND_EMG)
        wait_until(lambda: button.is_disabled(), timeout=120, what="Record disabled")
        status = page.get_by_text("Recording is off in this workspace: its demonstrations "
                                  "also hold emg, which the studio cannot record")  # fmt: skip
        status.wait_for(timeout=120_000)
        assert status.inner_text().strip() == reason
        # Beside the button: the line just above it in the Record folder.
        above, below = status.bounding_box(), button.bounding_box()
        assert 0 <= below["y"] - (above["y"] + above["height"]) < 40
        off = background(button)
        assert max(off) - min(off) < 30  # grey, not the red of a live Record button
        assert button.evaluate("b => getComputedStyle(b).cursor") == "not-allowed"
        page.mouse.move(5, 450)
        screenshot(page, artifacts / "record_disabled.png")
        # A press all the same (Space) is refused with the same words, and records nothing.
        teach.record.press()
        said = notification(page, "Cannot record", reason[:60])
        assert reason in said  # the same words as beside the button
        assert teach.record.takes.outcome.text == reason and teach.record.take is None
        close_notifications(page)

        # A hand in its own frame: disabled, with that reason.
        own = hand_and_emg()
        own.layout = Layout((HAND,))
        own.demos = {k: [Demonstration(d.times, d.values[:, :3], HAND.columns, d.name)
                         for d in v] for k, v in own.demos.items()}  # fmt: skip
        own.frame = HandFrame(own=True)
        studio.session.store.switch(tmp_path / "own", own)
        page.get_by_text("its hand stays in the frame it was recorded in").wait_for(
            timeout=120_000)  # fmt: skip
        assert button.is_disabled()

        # The iCub's hand and head: Record is live again, red, and the reason gone.
        scenario_workspace(tmp_path / "icub", seed=1, n_demos=3)
        studio.session.store.switch(tmp_path / "icub-live", Workspace(tmp_path / "icub").load())
        wait_until(lambda: not button.is_disabled(), timeout=120, what="Record enabled")
        page.get_by_text("Ready to record into").wait_for(timeout=120_000)
        assert page.get_by_text("Recording is off in this workspace").count() == 0
        on = background(button)
        assert on[0] > on[1] + 60 and on[0] > on[2] + 60  # red
        assert button.evaluate("b => getComputedStyle(b).cursor") != "not-allowed"
    finally:
        page.close()
        studio.stop()


def test_a_workspace_that_can_record_has_record_enabled_without_a_browser(tmp_path) -> None:
    """The button's state is the server's: disabled only where nothing can be recorded."""
    scenario_workspace(tmp_path / "ws", seed=1, n_demos=3)
    studio = start_studio(tmp_path / "ws")
    try:
        teach = teach_panel(studio)
        wait_until(lambda: "Ready to record into" in teach.record.controls.status.content,
                   timeout=60, what="the idle line")  # fmt: skip
        assert not teach.record.controls.button.disabled
        store = studio.session.store
        store.switch(tmp_path / "emg", hand_and_emg())
        wait_until(lambda: teach.record.controls.button.disabled, timeout=60,
                   what="Record disabled")  # fmt: skip
        assert teach.record.controls.button.hint == workspace_refusal("left", HAND_AND_EMG)
        assert np.all([p.name in ("left", "right") for p in store.state.primitives])
    finally:
        studio.stop()
