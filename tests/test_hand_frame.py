"""Data recorded elsewhere, brought in: the modalities' field takes one per line (or ``;`` or
spaces), the preview names the columns no modality uses, and a hand placed in the iCub's frame
at import is kept with the workspace (``studio.json``), loaded back, and undone on export: the
exported CSVs are the recorded ones. A partner's position (a human's hand) has a placement of
its own, beside the partner, guessed from its name and chosen by the user. Old workspaces (no
``frame``) open as before; a bad placement is refused with a message."""

from __future__ import annotations

import io
import json
import math
import zipfile

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.core.store import Store
from app.core.store_state import workspace_data
from app.io.dataset_import import compact_columns, placed, read_folder
from app.io.exchange import read_workspace_zip, workspace_zip
from app.io.hand_frame import (
    ICUB_FRAME,
    HandFrame,
    guessed_partner,
    hand_points,
    imported_frame,
    placement_from_fields,
    points_of,
)
from app.io.workspace import Workspace
from app.io.workspace_index import check_index, layout_listing
from app.panels.data.import_inputs import one_per_line, preview_text
from promp.data import Layout, Modality
from promp.datasets import demo_from_csv, parse_modalities
from robots.icub.layout import HAND
from robots.icub.placement import (
    IN_REACH,
    PARTNER_ORIGIN,
    Placement,
    guess_placement,
    reach_share,
)
from robots.icub.scenario import generate_scenario
from tests.imported_sets import HANDOVER_MODALITIES, handover_set

FAR = np.array([2.0, 0.0, 0.0])  # m: the dataset's hand is 2 m in front of the iCub's root
EXTRA = ("hx", "hy", "hz", *(f"e{i}" for i in range(8)))


def far_csv(demo, seed: int) -> str:
    """One scenario demonstration 2 m away, with a human hand (hx..hz) and 8 EMG channels."""
    rng = np.random.default_rng(seed)
    hand = demo.select(("x", "y", "z")) + FAR
    extra = rng.normal(size=(demo.n_samples, len(EXTRA)))
    rows = np.column_stack([demo.times - demo.times[0], hand, extra])
    header = ",".join(("t", "x", "y", "z", *EXTRA))
    return header + "\n" + "\n".join(",".join(f"{v:.9f}" for v in row) for row in rows) + "\n"


def far_dataset(folder, n_demos: int = 3):
    """A CSV dataset of the scenario's two primitives, 2 m away; returns {path: text}."""
    files = {}
    for k, (primitive, demos) in enumerate(generate_scenario(seed=5, n_demos=n_demos).items()):
        for i, demo in enumerate(demos):
            text = far_csv(demo, 10 * k + i)
            path = folder / primitive / f"take{i}.csv"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
            files[f"{primitive}/take{i}"] = text
    return files


# ------------------------------------------------------------------------- the modalities' text


@pytest.mark.parametrize(
    "text",
    [
        "hand=x,y,z; emg=e0,e1,e2",
        "hand=x,y,z\nemg=e0,e1,e2",
        "hand=x,y,z emg=e0,e1,e2",  # failed: "missing column(s) ['hz emg=e0', ...]"
        "  hand = x, y, z \n\n emg=e0, e1, e2  # the EMG\n",
        "hand=x,y,z;\nemg=e0,e1,e2;",
    ],
)
def test_modalities_one_per_line_or_separated_by_semicolons_or_spaces(text) -> None:
    modalities = parse_modalities(text)
    assert [(m.name, m.columns) for m in modalities] == [
        ("hand", ("x", "y", "z")),
        ("emg", ("e0", "e1", "e2")),
    ]
    assert len(one_per_line(text).splitlines()) == 2


def test_a_stream_name_with_spaces_is_not_split() -> None:
    (hand, head) = parse_modalities("hand=Hand Pose:pose.{x,y,z}@mm head=head:roll,pitch,yaw")
    assert hand.stream == "Hand Pose" and hand.fields == ("pose.x", "pose.y", "pose.z")
    assert head.stream == "head"


def test_the_guess_is_shown_one_modality_per_line() -> None:
    assert one_per_line("hand=x,y,z; head=roll,pitch,yaw") == "hand=x,y,z\nhead=roll,pitch,yaw"


def test_spaces_between_modalities_read_a_dataset(tmp_path) -> None:
    far_dataset(tmp_path)
    data, summary = read_folder(tmp_path, "csv", parse_modalities("hand=x,y,z emg=e0,e1,e2"))
    assert data.layout.names == ("hand", "emg")
    assert summary.unused == ("hx", "hy", "hz", "e3", "e4", "e5", "e6", "e7")


# ------------------------------------------------------------------------- the columns left out


def test_the_preview_lists_the_columns_the_guess_leaves_out(tmp_path) -> None:
    far_dataset(tmp_path)
    data, summary = read_folder(tmp_path, "csv")
    assert data.layout.names == ("hand",)
    assert summary.unused == EXTRA
    assert compact_columns(summary.unused) == "hx, hy, hz, e0..e7"

    class Upload:
        filename, ignored = "handover.zip", []

    assert "**Not used:** hx, hy, hz, e0..e7" in preview_text(Upload(), summary)


def test_compact_columns() -> None:
    assert compact_columns(["a1", "a2", "b", "x7", "x8", "x9", "x10", "t0"]) == (
        "a1, a2, b, x7..x10, t0"
    )
    assert compact_columns([]) == ""


# ------------------------------------------------------------------------- the placement


def test_a_placement_from_the_fields_is_checked() -> None:
    placement = placement_from_fields(90.0, -195.0, 3.5, 0.0)
    assert placement.yaw == pytest.approx(math.pi / 2)
    assert placement.translation == pytest.approx((-1.95, 0.035, 0.0))
    for fields, message in [
        ((float("nan"), 0.0, 0.0, 0.0), "finite numbers"),
        ((0.0, float("inf"), 0.0, 0.0), "finite numbers"),
        ((0.0, 5000.0, 0.0, 0.0), "at most 1000 cm"),
        ((720.0, 0.0, 0.0, 0.0), "at most 360°"),
    ]:
        with pytest.raises(ValueError, match=message):
            placement_from_fields(*fields)


def test_a_frame_travels_in_studio_json_and_bad_ones_are_refused() -> None:
    index = {"format": "icub-intention-studio/workspace", "version": 1, "primitives": []}
    assert check_index(index, "old").frame == ICUB_FRAME  # written before frames: the iCub's
    frame = HandFrame(Placement((-1.95, 0.04, 0.06), 0.3))
    assert check_index({**index, "frame": frame.to_json()}, "s").frame == frame
    assert check_index({**index, "frame": {"own": True}}, "s").frame == HandFrame(own=True)
    assert not HandFrame(own=True).robot_shown and ICUB_FRAME.robot_shown
    bad = [
        ({"placement": {"translation_m": [1e9, 0, 0], "yaw_rad": 0}}, "at most 1000 cm"),
        ({"placement": {"translation_m": ["nan", 0, 0], "yaw_rad": 0}}, "finite"),
        ({"placement": {"translation_m": [0, 0], "yaw_rad": 0}}, "finite"),
        ({"own": True, "placement": {}}, "'frame': a placement needs"),
        ({"own": True, "placement": {"translation_m": [0, 0, 0], "yaw_rad": 0}}, "not both"),
        ("elsewhere", "'frame' is"),
    ]
    for value, message in bad:
        with pytest.raises(ValueError, match=message):
            check_index({**index, "frame": value}, "studio.json")
    with pytest.raises(ValueError, match="not both"):
        HandFrame(Placement(), own=True)


def exported_csvs(content: bytes) -> dict[str, str]:
    with zipfile.ZipFile(io.BytesIO(content)) as archive:
        return {
            name[len("demos/") : -len(".csv")]: archive.read(name).decode()
            for name in archive.namelist()
            if name.startswith("demos/")
        }


def test_a_placed_workspace_keeps_its_placement_and_exports_the_data_as_recorded(
    tmp_path,
) -> None:
    originals = far_dataset(tmp_path / "handover")
    data, _ = read_folder(tmp_path / "handover", "csv")
    points = hand_points(data.demos, data.layout)
    assert reach_share(points) < IN_REACH  # recorded 2 m away
    imported = placed(data, HandFrame(guess_placement(points)))
    frame = imported.frame
    assert frame == HandFrame(guess_placement(points), imported=True) and not frame.in_scene
    workspace = Workspace.create(tmp_path / "ws", imported)
    # studio.json keeps the placement; the demonstrations are in the iCub's frame, in reach.
    index = json.loads((tmp_path / "ws" / "studio.json").read_text())
    assert index["frame"] == frame.to_json()
    loaded = workspace.load()
    assert loaded.frame == frame
    assert reach_share(hand_points(loaded.demos, loaded.layout)) >= IN_REACH
    # A change of the index (a new primitive) keeps the frame.
    store = Store(workspace, loaded)
    store.create_primitive("wave")
    assert json.loads((tmp_path / "ws" / "studio.json").read_text())["frame"] == frame.to_json()
    assert store.state.frame == frame
    # Export (what Export workspace writes): the data back in its own frame, the CSVs equal to
    # the recorded ones.
    content = workspace_zip(workspace_data(store.state))
    exported = exported_csvs(content)
    assert sorted(exported) == sorted(originals)
    for key, text in originals.items():
        original, back = demo_from_csv(text), demo_from_csv(exported[key])
        assert back.columns == ("x", "y", "z")
        assert_allclose(back.times, original.times, atol=1e-9, rtol=0)
        assert_allclose(back.values, original.select(("x", "y", "z")), atol=1e-9, rtol=0)
    # The exported archive says the placement, and reading it places the hand again.
    upload = read_workspace_zip(content)
    assert upload.data.frame == frame
    for name, demos in loaded.demos.items():
        for demo, again in zip(demos, upload.data.demos[name], strict=True):
            assert_allclose(again.values, demo.values, atol=1e-9, rtol=0)


def test_every_position_in_space_is_placed_with_the_hand_and_back(tmp_path) -> None:
    """A marker (hx, hy, hz: three columns ending in x, y, z) was recorded in the same frame
    as the robot's hand: placed, it moves with the hand; the EMG stays as it was; exported,
    both go back to the frame they were recorded in."""
    far_dataset(tmp_path / "handover")
    modalities = parse_modalities("hand=x,y,z; marker=hx,hy,hz; emg=e0,e1")
    data, _ = read_folder(tmp_path / "handover", "csv", modalities)
    frame = HandFrame(guess_placement(hand_points(data.demos, data.layout)))
    moved = frame.placed(data.demos, data.layout)
    for name, demos in data.demos.items():
        for demo, there in zip(demos, moved[name], strict=True):
            for columns in (("x", "y", "z"), ("hx", "hy", "hz")):
                assert_allclose(there.select(columns), frame.placement.apply(demo.select(columns)))
            assert_allclose(there.select(("e0", "e1")), demo.select(("e0", "e1")))
    back = frame.as_recorded(moved, data.layout)
    for name, demos in data.demos.items():
        for demo, again in zip(demos, back[name], strict=True):
            assert_allclose(again.values, demo.values, atol=1e-12)


def test_a_workspace_in_its_own_frame_is_stored_and_exported_as_it_is(tmp_path) -> None:
    originals = far_dataset(tmp_path / "handover")
    data, _ = read_folder(tmp_path / "handover", "csv")
    workspace = Workspace.create(tmp_path / "ws", placed(data, HandFrame(own=True)))
    loaded = workspace.load()
    assert loaded.frame == HandFrame(own=True, imported=True) and not loaded.frame.robot_shown
    exported = exported_csvs(workspace_zip(loaded))
    for key, text in originals.items():
        original, back = demo_from_csv(text), demo_from_csv(exported[key])
        assert_allclose(back.values, original.select(("x", "y", "z")), atol=1e-9, rtol=0)


def test_an_old_workspace_opens_and_exports_as_before(tmp_path) -> None:
    dataset = generate_scenario(seed=3, n_demos=2)
    from app.io.workspace import WorkspaceData
    from app.io.workspace_index import PALETTE, PrimitiveEntry

    data = WorkspaceData([PrimitiveEntry(n, PALETTE[i]) for i, n in enumerate(dataset)], dataset)
    workspace = Workspace.create(tmp_path / "ws", data)
    assert "frame" not in json.loads((tmp_path / "ws" / "studio.json").read_text())
    loaded = workspace.load()
    assert loaded.frame == ICUB_FRAME
    exported = exported_csvs(workspace_zip(loaded))
    name = next(iter(dataset))
    demo = dataset[name][0]
    back = demo_from_csv(exported[f"{name}/{demo.name}"])
    assert_allclose(back.values, demo.select(back.columns), atol=0, rtol=0)


def test_a_workspace_in_its_own_frame_records_no_take() -> None:
    from app.live.take_controller import OWN_FRAME_REFUSAL, refusal
    from robots.icub.layout import STUDIO_LAYOUT

    assert refusal("reach", STUDIO_LAYOUT, None, 50.0) is None
    assert refusal("reach", STUDIO_LAYOUT, None, 50.0, own_frame=True) == OWN_FRAME_REFUSAL
    assert "not be in that frame" in OWN_FRAME_REFUSAL


def test_the_command_line_says_a_hand_is_out_of_reach_and_places_it(tmp_path, capsys) -> None:
    from app.cli import build_parser, prepare_workspace

    originals = far_dataset(tmp_path / "handover")

    def imported(name: str, *flags: str):
        argv = ["--workspace", str(tmp_path / name), "--import-dataset",
                str(tmp_path / "handover"), *flags]  # fmt: skip
        prepare_workspace(build_parser().parse_args(argv))
        return capsys.readouterr().out, Workspace(tmp_path / name).load()

    out, data = imported("as-recorded")
    assert "The hand's path is 0 % within the iCub's reach" in out and "--hand-frame place" in out
    assert data.frame == HandFrame(imported=True) and not data.frame.in_scene
    out, data = imported("placed", "--hand-frame", "place")
    assert "Placed the hand in the iCub's frame (yaw 0°, x -19" in out
    assert reach_share(hand_points(data.demos, data.layout)) >= IN_REACH
    back = demo_from_csv(exported_csvs(workspace_zip(data))["curved/take0"])
    assert_allclose(back.values, demo_from_csv(originals["curved/take0"]).select(("x", "y", "z")),
                    atol=1e-9)  # fmt: skip
    out, data = imported("own", "--hand-frame", "own")
    assert "its own frame" in out and data.frame == HandFrame(own=True, imported=True)
    with pytest.raises(ValueError, match="--hand-frame go with --import-dataset"):
        prepare_workspace(build_parser().parse_args(["--workspace", str(tmp_path / "ws"),
                                                     "--hand-frame", "own"]))  # fmt: skip


# ------------------------------------------------------------------------- the partner's positions


def handover(tmp_path):
    """The handover set (tests/imported_sets.py) read with its three modalities, as recorded."""
    data, _ = read_folder(handover_set(tmp_path / "handover"), "csv",
                          parse_modalities(HANDOVER_MODALITIES))  # fmt: skip
    return data


@pytest.mark.parametrize(
    ("names", "partner"),
    [
        (("human", "marker", "emg"), ("human",)),
        (("partner_hand", "robot_tool"), ("partner_hand",)),
        (("Subject1", "object"), ("Subject1",)),
        (("humanWrist", "userElbow", "box"), ("humanWrist", "userElbow")),
        (("tracker", "wand"), ()),  # a lab's names that say no person: the user says it
    ],
)
def test_the_import_guesses_the_partners_positions_from_their_names(names, partner) -> None:
    layout = Layout((HAND, *(Modality(n, (f"{n}_x", f"{n}_y", f"{n}_z")) for n in names),
                     Modality("human_force", ("fx", "fy", "fz"), unit="N")))  # fmt: skip
    assert guessed_partner(layout) == partner  # a force is no position, the hand the robot's


def test_a_partners_hand_is_placed_beside_the_partner_not_with_the_robots(tmp_path) -> None:
    """The handover set: a human's hand in the partner's frame, the robot's hand in its base's.
    Placed with the robot's placement (as every position was) the human's hand was drawn at the
    iCub's waist, in its legs; it has its own placement, at the partner, undone on export."""
    data = handover(tmp_path)
    robot = guess_placement(hand_points(data.demos, data.layout))
    imported = placed(data, HandFrame(robot))
    frame = imported.frame
    assert frame.partner_names == ("human",) and frame.placement == robot and frame.imported
    human = points_of(imported.demos, data.layout, "human")
    # within a person's reach of the partner's shoulders (an arm and the shoulder's own play)
    assert np.max(np.linalg.norm(human - np.array(PARTNER_ORIGIN), axis=1)) < 0.9
    assert np.all(human[:, 0] < -0.3)  # in front of the robot (it faces -x), never in it
    assert_allclose(hand_points(imported.demos, data.layout),
                    robot.apply(hand_points(data.demos, data.layout)))  # fmt: skip
    emg = [f"emg{i}" for i in range(8)]
    assert_allclose(points_of(imported.demos, data.layout, "emg"),
                    np.concatenate([d.select(emg) for v in data.demos.values() for d in v]))
    # Kept in studio.json, read back, and undone on export: the data as recorded.
    workspace = Workspace.create(tmp_path / "ws", imported)
    index = json.loads((tmp_path / "ws" / "studio.json").read_text())
    assert set(index["frame"]["partner"]) == {"human"} and index["frame"]["imported"] is True
    loaded = workspace.load()
    assert loaded.frame == frame
    back = read_workspace_zip(workspace_zip(loaded)).data
    assert back.frame == frame
    recorded = frame.as_recorded(loaded.demos, loaded.layout)
    for name, demos in data.demos.items():
        for demo, again in zip(demos, recorded[name], strict=True):
            assert_allclose(again.values, demo.values, atol=1e-9)


def test_the_user_says_which_positions_are_the_partners(tmp_path) -> None:
    data = handover(tmp_path)
    frame = imported_frame(HandFrame(Placement((0.1, 0.0, -0.5))), data.demos, data.layout)
    assert frame.partner_names == ("human",)
    # The robot's frame: moved with the hand, as a marker would be.
    robots = frame.with_partner("human", False, data.demos, data.layout)
    assert robots.partner == () and robots.placement == frame.placement
    moved = robots.placed(data.demos, data.layout)
    assert_allclose(points_of(moved, data.layout, "human"),
                    frame.placement.apply(points_of(data.demos, data.layout, "human")))
    assert robots.with_partner("human", True, data.demos, data.layout) == frame
    for name, message in (("hand", "other than the robot's hand"), ("emg", "not a position"),
                          ("nobody", "not a position")):  # fmt: skip
        with pytest.raises(ValueError, match=message):
            frame.with_partner(name, True, data.demos, data.layout)
    with pytest.raises(ValueError, match="own frame"):
        HandFrame(own=True).with_partner("human", True, data.demos, data.layout)
    # Kept as it is said, checked against the layout when read.
    index = {"format": "icub-intention-studio/workspace", "version": 1, "primitives": [],
             "layout": layout_listing(data.layout)}  # fmt: skip
    assert check_index({**index, "frame": frame.to_json()}, "s").frame == frame
    placement = Placement(PARTNER_ORIGIN).to_json()
    for partner, message in (({"emg": placement}, "not positions"),
                             ({"hand": placement}, "other modalities than the robot's hand"),
                             ({"human": {"yaw_rad": 0}}, "a placement needs"),
                             (["human"], "'frame' is")):  # fmt: skip
        with pytest.raises(ValueError, match=message):
            check_index({**index, "frame": {"imported": True, "partner": partner}}, "s")
    with pytest.raises(ValueError, match="keeps every position as recorded"):
        HandFrame(own=True, partner=(("human", Placement(PARTNER_ORIGIN)),))
