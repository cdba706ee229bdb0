"""Importing one's own recordings from the Data tab, in a real browser: bad imports are refused
with the workspace unchanged; a dataset replaces the workspace (the old one restorable from
"Recently deleted", byte for byte); the authors' lab recordings become a new workspace whose
122 demonstrations and 3 priors are drawn around the iCub's hand, and Infer scrubs one of them
while the arm replays the prediction through IK."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.io.workspace import Workspace
from tests.browser import (
    choose,
    click,
    notification,
    open_tab,
    press,
    screenshot,
    server_caught_up,
    settled_screenshot,
    upload_file,
)
from tests.conftest import (
    PageSpec,
    StudioSpec,
    open_page,
    start_studio,
    wait_until,
)
from tests.test_dataset_import import BAD_ZIPS, csv_demo, zip_folder, zip_of


def tree_hash(root: Path, trash: bool = True) -> str:
    digest = hashlib.sha256()
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        relative = path.relative_to(root)
        if trash or relative.parts[0] != "trash":
            digest.update(str(relative).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


# 2 primitives x 4 demonstrations of the simulated scenario; the Data tab.
STUDIO = StudioSpec(seed=2, n_demos=4)
PAGE = PageSpec(tab="Data",
                ready=lambda page, _: page.get_by_role("button", name="Upload dataset").wait_for())


def importer(studio):
    from app.panels.data import DataPanel

    return next(p for p in studio.panels if isinstance(p, DataPanel)).importer


GUI_REFUSALS = ["empty folder", "non-numeric", "one demonstration", "zip-slip", "not a zip"]


@pytest.mark.browser
def test_no_public_share_button(page) -> None:
    """viser's "Share" would publish the studio on a public URL, past the loopback default
    (its icon is there whenever the theme allows the button)."""
    page.get_by_role("tab", name="Teach").wait_for()
    assert page.locator(".tabler-icon-share").count() == 0


@pytest.mark.browser
def test_bad_imports_are_refused_and_change_nothing(page, studio) -> None:
    store, section = studio.session.store, importer(studio)
    before, version = tree_hash(studio.workspace), store.state.version
    for case in GUI_REFUSALS:
        content, reason = BAD_ZIPS[case]
        upload_file(page, section.upload_button, f"{case.replace(' ', '-')}.zip", content)
        text = notification(page, f"Cannot import {case.replace(' ', '-')}.zip", reason[-30:])
        assert reason.replace("bad.zip", f"{case.replace(' ', '-')}.zip") in text, text
    # Too large: refused as the upload starts, before anything is buffered.
    section.guard.max_bytes = 64 * 1024
    try:
        upload_file(page, section.upload_button, "huge.zip", b"\0" * (2 * 2**20))
        assert "2.0 MB, over the 64.0 KB limit" in notification(page, "Cannot import huge.zip")
    finally:
        section.guard.max_bytes = 200 * 2**20
    # A mapping that names a missing column: refused, and the preview says why.
    good = zip_of({f"{p}/d{i}.csv": csv_demo(10 * k + i) for k, p in enumerate("ab")
                   for i in range(3)})  # fmt: skip
    upload_file(page, section.upload_button, "mine.zip", good)
    page.get_by_text("2 primitives, 6 demonstrations").wait_for()
    assert section.inputs.modalities.value == "hand=x,y,z"  # guessed from the header
    section.inputs.modalities.value = "hand=x,y,w"
    assert "missing column(s) ['w']" in notification(page, "Cannot import mine.zip", "['w']")
    assert not section.actions.visible
    server_caught_up(studio, page.client)  # anything the refusals set off has run
    assert tree_hash(studio.workspace) == before and store.state.version == version


@pytest.mark.browser
def test_a_dataset_replaces_the_workspace_and_the_old_one_comes_back(page, studio) -> None:
    store, section = studio.session.store, importer(studio)
    before = tree_hash(studio.workspace, trash=False)
    names = store.state.names
    data = zip_of({f"{p}/take{i}.csv": csv_demo(10 * k + i) for k, p in enumerate(("up", "down"))
                   for i in range(3)})  # fmt: skip
    upload_file(page, section.upload_button, "takes.zip", data)
    page.get_by_text("2 primitives, 6 demonstrations: down (3), up (3)").wait_for()
    click(page, "Replace this workspace")
    page.get_by_text("Replace this workspace?").wait_for()
    press(page, page.get_by_role("button", name="Replace this workspace").last)
    notification(page, "Workspace replaced", "takes.zip: 6 demonstrations")
    wait_until(lambda: store.state.names == ("down", "up"), what="the imported primitives")
    assert store.state.layout.names == ("hand",)
    # The previous workspace waits in the trash: restore it from "Recently deleted".
    from app.panels.data import DataPanel

    trash = next(p for p in studio.panels if isinstance(p, DataPanel)).trash
    wait_until(lambda: trash.choice.options[0].endswith("replaced by the dataset takes.zip"),
               what="the trash entry listed")  # fmt: skip
    press(page, page.get_by_text("Recently deleted", exact=True))  # open the folder
    choose(page, trash.choice, trash.choice.options[0])
    click(page, "Restore")
    notification(page, "Restored")
    wait_until(lambda: store.state.names == names, what="the previous workspace back")
    assert tree_hash(studio.workspace, trash=False) == before
    assert store.state.layout.names == ("hand", "head")


@pytest.mark.browser
def test_the_lab_recordings_on_the_icub(browser, page, studio, heights_dir, artifacts) -> None:
    store, section = studio.session.store, importer(studio)
    old_root, old = studio.workspace, tree_hash(studio.workspace)
    upload_file(page, section.upload_button, "lab-records-heights.zip", zip_folder(heights_dir))
    page.get_by_text("122 demonstrations: bottom (40), middle (40), top (42)").wait_for()
    assert section.inputs.format.value == "records"
    click(page, "Create workspace")
    text = notification(page, "Workspace created")
    assert "122 demonstrations of 3 primitives" in text
    wait_until(lambda: store.state.workspace.root == old_root.parent / "lab-records-heights",
               what="the new workspace")  # fmt: skip
    assert tree_hash(old_root) == old  # the previous workspace is untouched
    view = studio.scene
    wait_until(lambda: len(view.workspace.lines) == 122 and len(view.workspace.tubes) == 3,
               what="lines and tubes")  # fmt: skip
    assert set(view.workspace.tubes) == {"bottom", "middle", "top"}
    assert not view.partner.head_frame.visible  # no head modality: no partner
    # The priors are around the iCub's hand: their means start within a few cm of it.
    hand = studio.arm.hand_position()
    for name in view.workspace.tubes:
        start = view.workspace.prior_tube(studio.session.snapshot().model, name).mean[0]
        assert np.linalg.norm(start - hand) < 0.08, (name, start, hand)

    open_tab(page, "Teach")
    page.get_by_text("40 demonstration(s) of bottom").wait_for()
    # A picture of the tab (the README's are docs/pictures.py's): a page of its own.
    shot, _ = open_page(browser, studio, dpr=1.0)
    try:
        shot.get_by_text("40 demonstration(s) of bottom").wait_for()
        shot.mouse.move(5, 450)
        settled_screenshot(shot, artifacts / "teach_lab_records.png")
    finally:
        shot.close()

    # Infer: a held-out recording, scrubbed, then replayed by the arm through IK.
    from app.panels.infer import InferPanel

    panel = next(p for p in studio.panels if isinstance(p, InferPanel))
    open_tab(page, "Infer")
    controls = panel.controls
    choose(page, controls.primitive, "top")
    choose(page, controls.demo, "person2_record3")
    controls.percent.value = 50

    def scrubbed():
        view = panel.view
        shown = view is not None and view.result is not None and view.state.percent == 50
        return view if shown and view.state.demo == "person2_record3" else None

    view = wait_until(scrubbed, timeout=120, what="the scrub step")
    result = view.result
    assert "learned without person2_record3" in view.model.note
    page.get_by_text(f"Recognised: {result.inference.primitive}").wait_for()  # right or wrong
    assert result.inference.remaining > 0.0  # something left to replay
    controls.session_mode.value = "faded"
    screenshot(page, artifacts / "infer_lab_records.png")
    click(page, "Play")
    wait_until(lambda: panel.playback.replay.finished, timeout=60, what="the end of the replay")
    # The path replayed is the scrubbed prediction (the latest scrub's, should the loop have
    # scrubbed again meanwhile), and the arm reached its end through IK.
    played = panel.playback.replay.positions
    assert_allclose(played, panel.view.result.future.hand)
    assert np.linalg.norm(studio.arm.hand_position() - played[-1]) < 0.005


def test_a_workspace_of_other_modalities_has_their_charts_and_no_recording(
    tmp_path, heights_dir
) -> None:
    """Forces beside the hand: charts per dimension in Teach and Infer, observable alone or
    together, and a Record that explains why it is off (no browser needed: the panels' state
    is the server's)."""
    from app.io.dataset_import import read_folder
    from app.panels.infer import InferPanel
    from app.panels.teach import TeachPanel
    from promp.datasets import parse_modalities

    data, _ = read_folder(
        heights_dir, "records", parse_modalities("hand=x,y,z; force=fx,fy,fz")
    )
    data.demos = {name: demos[:6] for name, demos in data.demos.items()}  # quicker
    Workspace.create(tmp_path / "ws", data)
    studio = start_studio(tmp_path / "ws")
    try:
        teach = next(p for p in studio.panels if isinstance(p, TeachPanel))
        infer = next(p for p in studio.panels if isinstance(p, InferPanel))
        assert [q.title for q in infer.charts.quantities] == [
            "hand x (cm)", "hand y (cm)", "hand z (cm)", "force fx (N)", "force fy (N)",
            "force fz (N)",
        ]  # fmt: skip
        assert len(teach.prior.plots) == 6 and len(infer.charts.handles) == 6
        assert tuple(infer.controls.observed.options) == ("hand + force", "hand", "force")
        wait_until(lambda: not teach.head.controls.folder.visible, what="no head source")
        wait_until(lambda: "Recording is off in this workspace"
                   in teach.record.controls.status.content, what="recording off")  # fmt: skip
        infer.controls.observed.value = "force"
        infer.controls.percent.value = 70
        result = wait_until(
            lambda: infer.view.result if infer.view is not None and infer.view.result is not None
            and infer.view.result.observation.modalities == ("force",) else None,
            timeout=120, what="an inference from the forces alone",
        )  # fmt: skip
        assert result.inference.prediction.mean.shape[1] == 6
        teach.record.press()  # what the Record button's callback does
        wait_until(lambda: teach.record.takes.outcome is not None
                   and "cannot record" in teach.record.takes.outcome.text,
                   what="the refusal")  # fmt: skip
        assert teach.record.take is None
    finally:
        studio.stop()


@pytest.mark.browser
def test_an_xdf_session_through_the_page(page, studio, tmp_path) -> None:
    """A rig's session file (LabRecorder's XDF: a hand in mm at 100 Hz, a head in degrees at
    30 Hz, a marker stream) uploaded in the page as it is: the format told by the file, the
    guessed mapping shown, every demonstration listed with its span before anything is written,
    a chosen rate re-read at once; then a new workspace of its hand and head."""
    pytest.importorskip("pyxdf")
    from tests import rig_files as rf

    store, section = studio.session.store, importer(studio)
    old_root, old = studio.workspace, tree_hash(studio.workspace)
    open_tab(page, "Data")  # the test before it ends in Infer
    upload_file(page, section.upload_button, "session.xdf",
                rf.write_xdf(tmp_path / "session.xdf").read_bytes())  # fmt: skip
    page.get_by_text("2 primitives, 6 demonstrations: reach (3), wave (3)").wait_for()
    inputs = section.inputs
    assert inputs.format.value == "xdf" and inputs.cut.visible and inputs.rate.visible
    assert inputs.modalities.value == "hand=hand:x,y,z\nhead=head:roll,pitch,yaw"  # one a line
    page.get_by_text("reach/session-1 ← session.xdf [0.500-1.800 s]").wait_for()
    page.get_by_text("wave/session-6 ← session.xdf [9.200-10.300 s]").wait_for()
    inputs.rate.value = 50.0  # what typing in the number field does
    page.get_by_text("time base: 50 Hz").wait_for()
    assert tree_hash(old_root) == old  # nothing written by the preview
    click(page, "Create workspace")
    assert "6 demonstrations of 2 primitives" in notification(page, "Workspace created")
    wait_until(lambda: store.state.workspace.root == old_root.parent / "session",
               what="the new workspace")  # fmt: skip
    assert store.state.layout.names == ("hand", "head")
    assert [m.unit for m in store.state.layout.modalities] == ["m", "rad"]
    assert tree_hash(old_root) == old


# An iCub's dataDumper folders as they come (tests/rig_files.py): numbered port folders, the
# wrench's port connected 37 ms after the hand's state port; and the same with it 15 % late.
DUMP_GUESS = ("cartesianEndEffectorWrench=cartesianEndEffectorWrench:0,1,2,3,4,5\n"
              "state=state:0,1,2,3,4,5,6")  # fmt: skip


def icub_dump_zip(folder: Path, delay: float) -> bytes:
    from tests import rig_files as rf

    return zip_folder(rf.write_icub_dump(folder, {"reach": 2, "wave": 2}, delay), prefix="dump/")


def test_the_preview_puts_the_guessed_mapping_to_edit(studio, tmp_path) -> None:
    """Without a browser (setting a handle's value runs its callbacks): a dump refused for a
    port too late still gets its guessed mapping in Modalities, and editing it (the late port
    left out) reads the dump; a dump as it comes is read with the guess, the cut said."""
    from tests import rig_files as rf

    section = importer(studio)
    # the workspace the test before made is scored in the background (its index written):
    # settled first, so that what is compared is what the previews would write
    wait_until(lambda: studio.session.learner.idle, what="the learner, idle")
    inputs, before = section.inputs, tree_hash(studio.workspace)
    assert section.receive(None, "late.zip", icub_dump_zip(tmp_path / "late", 1.5)) is None
    assert inputs.modalities.value == DUMP_GUESS and inputs.modalities.visible
    text = section.preview.content
    assert text.startswith("**Cannot import:** reach/00000: stream "
                           "'cartesianEndEffectorWrench' starts at 1.500 s")  # fmt: skip
    assert "The modalities guessed are in **Modalities**" in text
    assert not section.actions.visible
    inputs.modalities.value = "hand=state:0,1,2@m"  # what typing in the field does
    assert "2 primitives, 4 demonstrations: reach (2), wave (2)" in section.preview.content
    assert section.actions.visible and section.pending.data.layout.names == ("hand",)
    # As it comes: read with the guess, shown to edit, the 37 ms cut said.
    summary = section.receive(None, "dump.zip", icub_dump_zip(tmp_path / "dump",
                                                               rf.WRENCH_DELAY))  # fmt: skip
    assert summary is not None and summary.n_demos == 4
    assert inputs.modalities.value == DUMP_GUESS
    assert ("reach/00000: stream 'cartesianEndEffectorWrench' starts at 0.037 s, 0.037 s into "
            "the recording") in section.preview.content  # fmt: skip
    section._discard()
    assert tree_hash(studio.workspace) == before  # the previews wrote nothing


@pytest.mark.browser
def test_an_icub_dump_through_the_page(page, studio, tmp_path, artifacts) -> None:
    """The dump uploaded in the page: refused for a late port with the guess in the field,
    edited there, then read; a screenshot of each preview (artifacts/)."""
    section = importer(studio)
    open_tab(page, "Data")  # the test before it may end in another tab
    upload_file(page, section.upload_button, "late.zip", icub_dump_zip(tmp_path / "late", 1.5))
    notification(page, "Cannot import late.zip", "starts at 1.500 s")
    page.get_by_text("The modalities guessed are in").wait_for()
    field = page.locator("label", has_text="Modalities").first.locator(
        "xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]").locator("textarea")
    wait_until(lambda: field.input_value() == DUMP_GUESS, what="the guess in the page's field")
    page.get_by_text("The modalities guessed are in").scroll_into_view_if_needed()
    screenshot(page, artifacts / "import_dump_refused.png")
    field.fill("hand=state:0,1,2@m")
    page.get_by_text("2 primitives, 4 demonstrations: reach (2), wave (2)").wait_for()
    page.get_by_text("Demonstrations found:").scroll_into_view_if_needed()
    screenshot(page, artifacts / "import_dump_edited.png")
    wait_until(lambda: section.actions.visible, what="the import's buttons")
    # As it comes (the wrench 37 ms late): read with the guess, the cut said.
    from tests import rig_files as rf

    upload_file(page, section.upload_button, "dump.zip",
                icub_dump_zip(tmp_path / "dump", rf.WRENCH_DELAY))  # fmt: skip
    said = page.get_by_text("One clock: 4 span(s) cut")
    said.wait_for()
    wait_until(lambda: field.input_value() == DUMP_GUESS, what="the guess in the page's field")
    said.scroll_into_view_if_needed()
    screenshot(page, artifacts / "import_dump_as_it_comes.png")
