"""A dataset recorded in another frame, imported in a real browser: the preview says the hand
is out of the iCub's reach and names the columns the guess leaves out; placed in the iCub's
frame (a guessed, editable shift), its demonstrations are drawn within reach; kept in its own
frame, they are drawn where they are and the robot is hidden."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.io.hand_frame import HandFrame
from app.panels.data.import_frame import OWN, PLACE
from robots.icub.placement import IN_REACH, reach_share
from robots.icub.scenario import generate_scenario
from tests.browser import choose, click, notification, open_tab, upload_file
from tests.conftest import (
    PICTURE_DPR,
    PageSpec,
    StudioSpec,
    wait_until,
)
from tests.test_dataset_import import zip_of
from tests.test_hand_frame import FAR, far_csv
from tests.test_import_in_data_tab import importer

SCREENSHOT = Path("/tmp/placement.png")


STUDIO = StudioSpec(seed=2, n_demos=3)
# The Data tab, tall enough for the preview and the placement (at PICTURE_DPR: its picture is
# looked at).
PAGE = PageSpec(width=1400, height=1000, dpr=PICTURE_DPR, tab="Data")


def far_zip() -> bytes:
    """The scenario's demonstrations 2 m in front of the iCub, with a human hand and EMG."""
    scenario = generate_scenario(seed=5, n_demos=3)
    return zip_of({f"handover/{name}/take{i}.csv": far_csv(demo, 10 * k + i).encode()
                   for k, (name, demos) in enumerate(scenario.items())
                   for i, demo in enumerate(demos)})  # fmt: skip


def drawn_points(studio) -> np.ndarray:
    return studio.scene.paths(inference=False)


def upload_far(page, studio, filename: str):
    """Upload the far dataset; once the preview says it is out of reach, the store, the
    import section and its frame choice."""
    section = importer(studio)
    upload_file(page, section.upload_button, filename, far_zip())
    page.get_by_text("within the iCub's reach: it was recorded in another frame").wait_for()
    # The choice in sight (a mouse picks it): the panel may have scrolled away from it.
    page.locator(f"[id='{section.frame.choice._impl.uuid}']").scroll_into_view_if_needed()
    return studio.session.store, section, section.frame


@pytest.mark.browser
def test_a_hand_out_of_reach_is_placed_in_the_icubs_frame(page, studio) -> None:
    store, section, frame = upload_far(page, studio, "handover.zip")
    page.get_by_text("hx, hy, hz, e0..e7").wait_for()  # the guess's columns left out
    assert "The hand's path is 0 % within the iCub's reach" in frame.message.content
    choose(page, frame.choice, PLACE)
    x = page.locator(f"[id='{frame.xyz[0]._impl.uuid}']")
    x.wait_for()
    guessed = float(frame.xyz[0].value)
    assert guessed == pytest.approx(-FAR[0] * 100, abs=10)  # about 2 m back
    # The user edits the shift: 3 cm further back along x; the preview gives the new share.
    x.fill(f"{guessed - 3:.1f}")
    wait_until(lambda: frame.good.translation[0] == pytest.approx((guessed - 3) / 100),
               timeout=60, what="the edited placement")  # fmt: skip
    page.get_by_text(f"x {guessed - 3:.1f} cm").wait_for()
    assert "% within reach" in frame.message.content
    page.locator(f"[id='{frame.xyz[2]._impl.uuid}']").scroll_into_view_if_needed()
    page.screenshot(path=str(SCREENSHOT))
    # A shift of 50 m (a typing mistake) is refused, and the fields keep the placement.
    frame.xyz[1].value = 5000.0  # what typing in the field does
    text = notification(page, "Cannot place the hand", "at most 1000 cm")
    assert "The placement was not changed" in text
    assert frame.xyz[1].value == pytest.approx(frame.good.translation[1] * 100)
    assert abs(frame.good.translation[1]) < 1.0
    placement = frame.good
    click(page, "Create workspace")
    assert "6 demonstrations of 2 primitives" in notification(page, "Workspace created")
    wait_until(lambda: store.state.workspace.root.name == "handover", what="the new workspace")
    # kept with the workspace (studio.json), recorded elsewhere
    assert store.state.frame == HandFrame(placement, imported=True)
    # The demonstrations drawn in 3D are within the iCub's reach, with the robot shown.
    wait_until(lambda: drawn_points(studio).shape[0] > 0
               and store.state.demos is studio.scene.drawn_from[1], timeout=120,
               what="the placed demonstrations drawn")  # fmt: skip
    assert reach_share(drawn_points(studio)) >= IN_REACH
    assert studio.arm.robot.shown and studio.arm.robot.root.visible


@pytest.mark.browser
def test_a_hand_in_its_own_frame_is_drawn_where_it_is_without_the_robot(page, studio) -> None:
    store, section, frame = upload_far(page, studio, "baxter.zip")
    choose(page, frame.choice, OWN)
    page.get_by_text("Shown in its own frame").wait_for()
    assert not frame.xyz[0].visible
    click(page, "Create workspace")
    notification(page, "Workspace created", "baxter")
    wait_until(lambda: store.state.frame.own, what="the workspace in its own frame")
    wait_until(lambda: not studio.arm.robot.root.visible, timeout=120, what="the robot hidden")
    robot = studio.arm.robot
    assert not any(node.visible for node in (*robot.props, *robot.scene))
    wait_until(lambda: store.state.demos is studio.scene.drawn_from[1], timeout=120,
               what="the demonstrations drawn")  # fmt: skip
    points = drawn_points(studio)
    assert reach_share(points) < 0.05  # where they were recorded: 2 m away
    assert np.median(points[:, 0]) > 1.0
    # The start view frames them, not the (hidden) robot.
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    wait_until(lambda: np.linalg.norm(np.asarray(studio.server.initial_camera.look_at) - centre)
               < 0.3, timeout=120, what="the start view on the demonstrations")  # fmt: skip
    # Recording is off: a take of the iCub's hand would not be in the data's frame.
    page.get_by_role("tab", name="Teach").scroll_into_view_if_needed()  # the panel scrolled
    open_tab(page, "Teach")
    page.get_by_text("its hand stays in the frame it was recorded in").wait_for()
