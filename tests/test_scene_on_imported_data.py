"""The 3D view on data recorded elsewhere, in a real browser: two synthetic sets with the
layouts of real ones (tests/imported_sets.py), imported from the Data tab into the simulated
scenario's studio.

- An iCub's hand in its root frame, three primitives whose paths cross the simulated bin: the
  simulated scene (table, object, bins) is hidden once imported (shown for the scenario), and
  *Simulated scene* shows it again; *Frame paths* frames the demonstrations, not a take's
  tracking glitch 1.5 m away; the camera buttons leave no tooltip over the panel.
- A handover: a human's hand in the partner's frame, 8 EMG channels, another robot's hand in
  its base's frame: the human's hand is placed beside the partner (its own placement), not in
  the robot's legs as the robot's placement put it; a tube a metre wide is drawn as an
  outline, its width said beside it; the user moves the human's hand to the robot's frame and
  back in the 3D view's *Positions* folder.

Screenshots of both sets in Teach and Infer go to artifacts/ (``imported_*.png``)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from app.io.dataset_import import read_folder
from app.io.hand_frame import points_of
from app.scene.camera import FRAME, PANEL_PX, TOP
from app.scene.scene_controls import PARTNERS, ROBOTS
from app.ui.display import observed_label
from promp.datasets import parse_modalities
from promp.units import amount
from robots.icub.placement import PARTNER_ORIGIN, Placement
from robots.icub.scene import DEFAULT_SCENE
from tests.browser import (
    camera_pixels,
    camera_reports,
    choose,
    click,
    notification,
    open_tab,
    press,
    set_camera,
    settled_screenshot,
    upload_file,
)
from tests.conftest import PICTURE_DPR, PageSpec, StudioSpec, wait_until
from tests.imported_sets import GLITCHED, HANDOVER_MODALITIES, handover_set, icub_set
from tests.test_dataset_import import zip_folder
from tests.test_import_in_data_tab import importer

WIDTH, HEIGHT = 1600, 1000
STUDIO = StudioSpec(seed=2, n_demos=4)  # the simulated scenario: recorded in the scene
PAGE = PageSpec(width=WIDTH, height=HEIGHT, dpr=PICTURE_DPR, tab="Data",
                ready=lambda page, _: page.get_by_role("button", name="Upload dataset")
                .wait_for())  # fmt: skip


def panel(studio, name: str):
    from app.panels.infer import InferPanel
    from app.panels.teach import TeachPanel

    kind = {"teach": TeachPanel, "infer": InferPanel}[name]
    return next(p for p in studio.panels if isinstance(p, kind))


def scene_nodes_shown(studio) -> list[bool]:
    return [node.visible for node in studio.arm.robot.scene]


def import_set(page, studio, name: str, folder: Path, modalities: str | None = None) -> None:
    """Upload ``folder`` as ``name``.zip in the Data tab (``modalities`` typed in) and create
    a workspace of it; wait until it is learned and drawn."""
    store, section = studio.session.store, importer(studio)
    open_tab(page, "Data")
    upload_file(page, section.upload_button, f"{name}.zip", zip_folder(folder))
    wait_until(lambda: "Modalities:" in section.preview.content, timeout=300,
               what="the preview")  # fmt: skip
    if modalities is not None:
        section.inputs.modalities.value = modalities
        names = [m.name for m in parse_modalities(modalities)]
        wait_until(lambda: all(f"{n} = " in section.preview.content for n in names),
                   timeout=300, what="the preview of the modalities typed")  # fmt: skip
    click(page, "Create workspace")
    notification(page, "Workspace created", name)
    wait_until(lambda: store.state.workspace.root.name == name, timeout=120,
               what=f"the workspace {name}")  # fmt: skip
    wait_until(lambda: studio.session.snapshot().model is not None
               and studio.session.snapshot().model.names == store.state.names
               and store.state.demos is studio.scene.drawn_from[1]
               and len(studio.scene.workspace.tubes) == len(store.state.names),
               timeout=300, what="the imported set learned and drawn")  # fmt: skip


def frame_paths(page, client, view: str = FRAME) -> None:
    """Press ``view``'s button (*Frame paths*) and wait until the browser reports its camera
    moved (from 30 cm further back than it was, where no view leaves it)."""
    position, look_at = np.array(client.camera.position), np.array(client.camera.look_at)
    back = (position - look_at) / np.linalg.norm(position - look_at)
    set_camera(client, position + 0.3 * back, look_at)
    reports = camera_reports(client)
    start, before = len(reports.poses), np.array(client.camera.position)
    press(page, page.get_by_role("button", name=view, exact=True))
    wait_until(lambda: any(np.linalg.norm(p[1] - before) > 1e-3 for p in reports.poses[start:]),
               timeout=120, what=f"the camera moved by {view}")  # fmt: skip


def filling_the_picture(page, client, points) -> bool:
    """Every point inside the canvas beside the panel, spanning 40 % of it one way or the
    other (the camera reported by the browser)."""
    pixels = camera_pixels(page, client, points)
    free = WIDTH - PANEL_PX
    inside = bool(np.all(np.isfinite(pixels)) and np.all(pixels[:, 0] > 0)
                  and np.all(pixels[:, 0] < free) and np.all(pixels[:, 1] > 0)
                  and np.all(pixels[:, 1] < HEIGHT))  # fmt: skip
    span = np.ptp(pixels, axis=0)
    return inside and (span[0] > 0.4 * free or span[1] > 0.4 * HEIGHT)


def infer_at(page, studio, primitive: str, demo: str, percent: int) -> object:
    """Show ``demo`` of ``primitive`` at ``percent`` observed through every modality in
    Infer; its view."""
    infer = panel(studio, "infer")
    open_tab(page, "Infer")
    names = studio.session.store.state.layout.names
    choose(page, infer.controls.observed, observed_label(names))
    choose(page, infer.controls.primitive, primitive)
    choose(page, infer.controls.demo, demo)
    infer.controls.percent.value = percent

    def shown():
        view = infer.view
        return (view is not None and view.result is not None and view.state.demo == demo
                and view.state.percent == percent and studio.scene.look.inference
                and studio.scene.inference.drawn.result is view.result)  # fmt: skip

    wait_until(shown, timeout=300, what=f"{demo} inferred at {percent} %")
    return infer.view


def screenshot_to(page, path: Path, from_above: bool = False) -> None:
    """A screenshot (``from_above``: the Top view's direction, then Frame paths)."""
    if from_above:
        frame_paths(page, page.client, TOP)
        frame_paths(page, page.client)
    page.mouse.move(5, 600)  # no tooltip over the picture
    settled_screenshot(page, path, timeout=300)


def test_the_scene_is_shown_for_the_studios_recordings_and_hidden_for_data_from_elsewhere(
    tmp_path,
) -> None:
    """The default, per workspace, then the user's choice for that workspace only."""
    from app.core.store import Store
    from app.core.view_state import View, scene_shown
    from app.io.hand_frame import HandFrame
    from app.io.workspace import Workspace
    from app.studio import default_workspace

    data = default_workspace()
    own = Store.open(tmp_path / "own", default=lambda: data).state
    Workspace.create(tmp_path / "elsewhere", replace(data, frame=HandFrame(imported=True)))
    elsewhere = Store.open(tmp_path / "elsewhere").state
    view = View()
    assert scene_shown(view.state, own) and not scene_shown(view.state, elsewhere)
    view.show_scene(False, own)
    assert not scene_shown(view.state, own) and not scene_shown(view.state, elsewhere)
    view.show_scene(True, elsewhere)
    assert scene_shown(view.state, elsewhere) and scene_shown(view.state, own)  # its default
    placed = HandFrame(Placement((0.1, 0.0, 0.0)))  # placed or kept in its own frame: elsewhere
    assert not placed.in_scene and not HandFrame(own=True).in_scene and HandFrame().in_scene


@pytest.mark.browser
def test_an_icub_set_is_drawn_without_the_simulated_scene(page, studio, tmp_path,
                                                           artifacts) -> None:  # fmt: skip
    client = page.client
    controls = studio.camera.controls
    # The simulated scenario was recorded in the scene: it is drawn.
    wait_until(lambda: all(scene_nodes_shown(studio)) and controls.checkbox.value, timeout=60,
               what="the simulated scene shown with the scenario")  # fmt: skip
    source = icub_set(tmp_path / "icub-source", glitch=True)
    import_set(page, studio, "icub", source)
    store = studio.session.store
    assert not store.state.frame.in_scene and store.state.frame.robot_shown
    # Its paths cross where the simulated bin stands: the bin is not drawn, the robot is.
    lines = studio.scene.workspace.lines
    bin_box = DEFAULT_SCENE.bins[0].box
    assert any(bin_box.contains(p) for line in lines.values() for p in line.points)
    wait_until(lambda: not any(scene_nodes_shown(studio)) and not controls.checkbox.value,
               timeout=60, what="the simulated scene hidden")  # fmt: skip
    assert studio.arm.robot.root.visible
    # Shown again by the user, for this workspace; and hidden again.
    box = page.locator(f"[id='{controls.checkbox._impl.uuid}']")
    press(page, box)
    wait_until(lambda: all(scene_nodes_shown(studio)), timeout=60, what="the scene shown")
    press(page, box)
    wait_until(lambda: not any(scene_nodes_shown(studio)), timeout=60, what="the scene hidden")
    # Frame paths frames the demonstrations, not the glitching take's jump 1.5 m away.
    open_tab(page, "Teach")
    primitive, take, _ = GLITCHED
    data = np.concatenate([line.points for key, line in lines.items()
                           if key != (primitive, f"take{take:02d}")])  # fmt: skip
    frame_paths(page, client)
    wait_until(lambda: filling_the_picture(page, client, data), timeout=120,
               what=lambda: "the demonstrations filling the picture: pixels from "
               f"{np.nanmin(camera_pixels(page, client, data), axis=0)} to "
               f"{np.nanmax(camera_pixels(page, client, data), axis=0)}")  # fmt: skip
    # The pointer rests on the button pressed: no tooltip over the panel.
    assert page.locator(".mantine-Tooltip-tooltip").count() == 0
    assert studio.camera.buttons.hint is None
    screenshot_to(page, artifacts / "imported_icub_teach.png")
    infer_at(page, studio, "base_to_left_goal", "take03", 40)
    panel(studio, "infer").controls.session_mode.value = "faded"  # the inference stands out
    wait_until(lambda: studio.scene.look.priors == "faded", timeout=60, what="priors faded")
    screenshot_to(page, artifacts / "imported_icub_infer.png", from_above=True)
    panel(studio, "infer").controls.session_mode.value = "shown"


@pytest.mark.browser
def test_a_handover_partners_hand_is_drawn_beside_the_partner(page, studio, tmp_path,
                                                               artifacts) -> None:  # fmt: skip
    client = page.client
    source = handover_set(tmp_path / "handover-source")
    import_set(page, studio, "handover", source, HANDOVER_MODALITIES)
    store = studio.session.store
    frame = store.state.frame
    assert frame.placement is not None  # the robot's hand: out of the iCub's reach, placed
    assert frame.partner_names == ("human",)  # guessed from its name
    controls = studio.camera.controls
    wait_until(lambda: tuple(controls.frames) == ("human",)
               and controls.frames["human"].value == PARTNERS and controls.folder.visible,
               timeout=60, what="the Positions folder: human in the partner's frame")  # fmt: skip
    wait_until(lambda: not any(scene_nodes_shown(studio)), timeout=60, what="no simulated scene")
    # Teach: a prior tube a metre wide is an outline, its width said beside it.
    open_tab(page, "Teach")
    layer = studio.scene.workspace
    wide = [w for w in layer.widths.values() if w.too_wide]
    assert wide and max(w.width for w in wide) > 0.8, layer.widths
    for w in wide:
        wait_until(lambda w=w: layer.outlines[w.name].visible and not layer.tubes[w.name].visible,
                   timeout=60, what=f"{w.name}'s tube as an outline")  # fmt: skip
    teach = panel(studio, "teach")
    wait_until(lambda: "Drawn as" in teach.prior.tube_note.content, timeout=60,
               what="the width said beside the tubes")  # fmt: skip
    for w in wide:
        assert f"{w.name}'s" in teach.prior.tube_note.content
        assert f"{amount(w.width, 'm')} wide" in teach.prior.tube_note.content
    screenshot_to(page, artifacts / "imported_handover_teach.png", from_above=True)
    # Infer: the human's hand beside the partner, never in the robot.
    view = infer_at(page, studio, "handover_high", "take02", 20)
    human = studio.scene.inference.others["human"]
    region = next(v for v in view.result.positions if v.modality == "human").region
    # observed, predicted, true, its end: shown by the scene's look, later in the frame that
    # drew them (a busy-core run read them between the two)
    wait_until(lambda: all(node.visible for node in human.paths), timeout=60,
               what=lambda: f"the human's paths shown: {[n.visible for n in human.paths]}")
    points = np.concatenate([human.future.points, human.observed.points, human.truth.points,
                             np.atleast_2d(human.end.position), region.mean])  # fmt: skip
    reach = np.linalg.norm(points - np.array(PARTNER_ORIGIN), axis=1)
    assert reach.max() < 0.9, reach.max()  # within a person's reach of the partner's shoulders
    assert np.all(points[:, 0] < -0.3), points[:, 0].max()  # in front of the robot, not in it
    screenshot_to(page, artifacts / "imported_handover_infer.png", from_above=True)
    # Seen through the EMG alone, the hands' tubes are as wide as the priors': too wide for a
    # band, they are outlines, their widths said in the line about the tube.
    infer = panel(studio, "infer")
    choose(page, infer.controls.observed, "emg")
    wait_until(lambda: infer.view.state.observed == "emg"
               and studio.scene.inference.drawn.result is infer.view.result, timeout=300,
               what="the inference through the EMG drawn")  # fmt: skip
    drawn = studio.scene.inference.drawn
    outlined = [w for w in drawn.widths if w.too_wide]
    assert outlined and max(w.width for w in outlined) > 0.8, drawn.widths
    nodes = {"hand": (studio.scene.inference.tube, studio.scene.inference.outline),
             "human": (human.tube, human.outline)}  # fmt: skip
    for w in outlined:  # shown by the scene's look, later in the frame that drew them
        tube, outline = nodes[w.name]
        wait_until(lambda t=tube, o=outline: o.visible and not t.visible, timeout=60,
                   what=f"{w.name}'s posterior tube as an outline")  # fmt: skip
    note = infer.shaping.tube_note.handle
    wait_until(lambda: all(f"{w.name}'s" in note.content and amount(w.width, "m") in note.content
                           for w in outlined), timeout=60,
               what=lambda: f"the widths in the tube's line: {note.content}")  # fmt: skip
    # Frame paths frames the data drawn (both hands' paths), not the metre-wide tubes.
    frame_paths(page, client)
    hand = studio.scene.inference
    data = np.concatenate([points, hand.future.points, hand.observed_line.points])
    wait_until(lambda: filling_the_picture(page, client, data), timeout=120,
               what=lambda: "the paths filling the picture: pixels from "
               f"{np.nanmin(camera_pixels(page, client, data), axis=0)} to "
               f"{np.nanmax(camera_pixels(page, client, data), axis=0)}")  # fmt: skip
    # The user says the human's hand was recorded in the robot's frame, then the partner's.
    recorded, _ = read_folder(source, "csv", parse_modalities(HANDOVER_MODALITIES))
    as_recorded = points_of(recorded.demos, recorded.layout, "human")
    choose(page, controls.frames["human"], ROBOTS)
    notification(page, "human: robot's frame", "Recently deleted")
    wait_until(lambda: store.state.frame.partner_names == (), timeout=120,
               what="the human in the robot's frame")  # fmt: skip
    moved = points_of(store.state.demos, store.state.layout, "human")
    np.testing.assert_allclose(moved, frame.placement.apply(as_recorded), atol=1e-6)
    choose(page, controls.frames["human"], PARTNERS)
    wait_until(lambda: store.state.frame.partner_names == ("human",), timeout=120,
               what="the human beside the partner again")  # fmt: skip
    # placed again from the data as the workspace holds it (its files' digits)
    again = dict(store.state.frame.partner)["human"]
    assert again.yaw == pytest.approx(dict(frame.partner)["human"].yaw, abs=1e-6)
    np.testing.assert_allclose(points_of(store.state.demos, store.state.layout, "human"),
                               again.apply(as_recorded), atol=1e-6)
