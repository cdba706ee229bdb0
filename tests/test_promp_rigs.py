"""Recordings straight from real rigs (``promp.rigs``): each format's own writer makes a small
session (``tests/rig_files.py``: a hand at 100 Hz, a head at 30 Hz from 5 ms later, markers for
three demonstrations of two classes), and the reader must give back the values, the times and
the cut exactly; bad files are refused with the file and the reason.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.datasets import FORMATS, parse_modalities, parse_modality, read_dataset
from promp.rigs import RIG_FORMATS, RigOptions
from promp.rigs.cutting import marker_spans
from promp.rigs.mapping import SourcedModality, column_names, parse_sourced, si_unit
from tests import rig_files as rf

if not os.environ.get("CI"):  # CI installs the extras (make test): a missing one fails there
    for library in ("rosbags", "pyxdf", "ezc3d"):
        pytest.importorskip(library)

ROS2 = "hand=/hand:pose.position.{x,y,z}; head=/head:pose.orientation.{roll,pitch,yaw}"
ROS1 = "hand=/tf:left_hand.translation.{x,y,z}; head=/tf:head.rotation.{roll,pitch,yaw}"
XDF = "hand=hand:x,y,z; head=head:roll,pitch,yaw"
YARP = "hand=left_arm:0,1,2@m; head=/partner/head:o:0,1,2@deg"
INDICES = ("hand_0", "hand_1", "hand_2", "head_0", "head_1", "head_2")  # YARP's fields


NAMED = ("x", "y", "z", "roll", "pitch", "yaw")


def check_session(read, atol: float, columns: tuple[str, ...] = NAMED) -> None:
    """The six demonstrations of :data:`rf.MARKERS`, on the head's 30 Hz clock, with the
    hand interpolated at the head's times by their timestamps."""
    assert {k: [d.name for d in v] for k, v in read.dataset.items()} == {
        "reach": ["session-1", "session-3", "session-5"],
        "wave": ["session-2", "session-4", "session-6"]}  # fmt: skip
    assert read.layout.columns == columns
    assert [(m.unit, m.kind) for m in read.layout.modalities] == [("m", "linear"), ("rad", "angle")]
    for k, (klass, start, end) in enumerate(rf.SPANS, start=1):
        name = f"session-{k}"
        demo = next(d for d in read.dataset[klass] if d.name == name)
        head_t = rf.head_times()
        inside = head_t[(head_t >= start) & (head_t <= end)]
        assert_allclose(demo.times, inside, atol=atol, rtol=0)  # the slowest stream's clock
        assert_allclose(demo.select(columns[:3]), rf.hand_at(demo.times), atol=atol)
        assert_allclose(demo.select(columns[3:]), rf.head_at(demo.times), atol=atol)
        assert read.files[(klass, name)].endswith(f"[{start:.3f}-{end:.3f} s]")


# ------------------------------------------------------------------------------ mapping


def test_the_mapping_syntax() -> None:
    m = parse_sourced("hand=/tf:left_hand.translation.{x,y,z}")
    assert (m.stream, m.fields, m.stated_unit) == (
        "/tf", ("left_hand.translation.x", "left_hand.translation.y", "left_hand.translation.z"),
        "")  # fmt: skip
    assert m.spec() == "hand=/tf:left_hand.translation.{x,y,z}"
    vicon = parse_sourced("hand=Subject1:LHAND:x,y,z@mm")  # the stream is before the last ':'
    assert (vicon.stream, vicon.fields, vicon.stated_unit) == ("Subject1:LHAND", ("x", "y", "z"),
                                                               "mm")  # fmt: skip
    assert parse_sourced("arm=left_arm:0,1,2@deg").spec() == "arm=left_arm:0,1,2@deg"
    assert parse_sourced("hand=x,y,z@m").stream == ""
    assert parse_sourced("hand=/tf:left_hand.x,y,z").fields == (  # the issue's own example
        "left_hand.x", "left_hand.y", "left_hand.z")  # fmt: skip
    assert parse_sourced("hand=/p:pose.position.x,y,z").spec() == "hand=/p:pose.position.{x,y,z}"
    assert parse_sourced("eeg=EEG:Fp1.ref,Fp2").fields == ("Fp1.ref", "Fp2")  # not axis names
    assert isinstance(parse_modality("hand=/pose:pose.position.x"), SourcedModality)
    assert not isinstance(parse_modality("hand=x,y,z"), SourcedModality)  # CSV stays as it was
    assert [m.name for m in parse_modalities("# a mapping file\nhand=/a:x # the hand\n\nhead=/b:y")
            ] == ["hand", "head"]  # fmt: skip
    for bad, why in [("hand=/a:{x,y", "unbalanced"), ("hand=/a:", "no field"),
                     ("1hand=/a:x", "invalid modality name"), ("hand=/a:x@", "unit"),
                     ("hand=/a:x,x", "twice"), ("/a:x", "NAME=")]:  # fmt: skip
        with pytest.raises(ValueError, match=why):
            parse_sourced(bad)
    assert si_unit("mm") == ("m", 1e-3) and si_unit("deg") == ("rad", np.pi / 180)
    assert si_unit("V") == ("V", 1.0)
    mods = [parse_sourced("hand=/a:p.x,p.y"), parse_sourced("elbow=/b:p.x,q"),
            parse_sourced("arm=c:0,1")]  # fmt: skip
    assert column_names(mods) == [("hand_x", "y"), ("elbow_x", "q"), ("arm_0", "arm_1")]


def test_markers_cut_sessions_and_bad_markers_are_named() -> None:
    assert marker_spans(rf.MARKERS, None, "s") == list(rf.SPANS)
    assert marker_spans([(1, "start"), (2, "end")], "reach", "s") == [("reach", 1, 2)]
    assert marker_spans([(1, "BEGIN:a"), (2, "stop/a")], None, "s") == [("a", 1, 2)]
    for markers, why in [
        ([(1, "start a"), (2, "oops"), (3, "end a")], "unknown marker 'oops' at 2.000 s"),
        ([(1, "end a")], "ends no demonstration"),
        ([(1, "start a"), (2, "start b")], "inside the one started"),
        ([(1, "start a"), (2, "end b")], "ends the demonstration of 'a'"),
        ([(1, "start a")], "never ended"),
        ([(1, "start"), (2, "end")], "names no class"),
        ([], "no 'start CLASS'"),
    ]:
        with pytest.raises(ValueError, match=why):
            marker_spans(markers, None, "session.xdf: marker stream 'events'")


def test_the_formats_are_registered_everywhere() -> None:
    from app.cli import build_parser as studio_parser
    from promp.evaluate.cli import build_parser

    assert set(RIG_FORMATS) == {"yarp", "rosbag", "xdf", "c3d"} <= set(FORMATS)
    for parser in (build_parser(), studio_parser()):
        action = next(a for a in parser._actions if a.dest == "format")
        assert tuple(action.choices) == FORMATS


# ------------------------------------------------------------------------------ formats


def test_a_ros2_mcap_bag(tmp_path: Path) -> None:
    rf.write_ros2_bag(tmp_path / "session")
    check_session(read_dataset(tmp_path, "rosbag", parse_modalities(ROS2)), atol=1e-9)
    # The bare .mcap file reads the same (a bag folder's storage file, or one on its own).
    mcap = next((tmp_path / "session").glob("*.mcap"))
    read = read_dataset(mcap, "rosbag", parse_modalities(ROS2))
    assert read.files[("wave", f"{mcap.stem}-2")] == f"{mcap.name} [2.200-3.600 s]"
    # Guessed: every topic's field groups, named after them, and shown in the syntax.
    guessed = read_dataset(tmp_path, "rosbag")
    assert guessed.mapping.startswith("hand_position=/hand:pose.position.{x,y,z}; "
                                      "hand_orientation=/hand:pose.orientation.{roll,pitch,yaw}")
    assert any("/hand (pose.position.x" in note for note in guessed.notes)


def test_a_ros1_bag_with_tf(tmp_path: Path) -> None:
    rf.write_ros1_bag(tmp_path / "session.bag")
    check_session(read_dataset(tmp_path, "rosbag", parse_modalities(ROS1)), atol=1e-9)
    short = "hand=/tf:left_hand.x,y,z; head=/tf:head.roll,pitch,yaw"  # translation, rotation
    check_session(read_dataset(tmp_path, "rosbag", parse_modalities(short)), atol=1e-9)
    guessed = read_dataset(tmp_path, "rosbag").mapping
    assert "left_hand_translation=/tf:left_hand.translation.{x,y,z}" in guessed
    assert "head_rotation=/tf:head.rotation.{roll,pitch,yaw}" in guessed


def test_an_xdf_file_with_a_marker_stream(tmp_path: Path) -> None:
    rf.write_xdf(tmp_path / "session.xdf")  # the hand in mm and the head in degrees
    read = read_dataset(tmp_path / "session.xdf", "xdf")  # a session file on its own, guessed
    assert read.mapping == XDF
    check_session(read, atol=1e-9)


def test_c3d_millimetres_analogs_events_and_a_chosen_rate(tmp_path: Path) -> None:
    rf.write_c3d(tmp_path / "session.c3d")
    mapping = parse_modalities("hand=Subject1:LHAND:x,y,z; emg=ANALOG:EMG1,Fz")
    read = read_dataset(tmp_path, "c3d", mapping, RigOptions(rate=40.0))
    assert [(m.name, m.unit) for m in read.layout.modalities] == [("hand", "m"), ("emg", "V|N")]
    wave = read.dataset["wave"][0]
    assert_allclose(wave.times, 2.2 + np.arange(57) / 40.0, atol=1e-9)  # 2.2 to 3.6 s at 40 Hz
    assert_allclose(wave.select(("x", "y", "z")), rf.hand_at(wave.times), atol=1e-9)
    assert_allclose(wave.select(("EMG1", "Fz")), np.column_stack(
        [0.001 * wave.times, 5.0 + wave.times]), atol=1e-6)  # analogs at 1000 Hz, float32
    # A marker hidden for three frames is interpolated; for a second it is a stream that stops.
    seen = np.ones(rf.hand_times().size, dtype=bool)
    seen[250:253] = False
    rf.write_c3d(tmp_path / "occluded.c3d", seen=seen)
    one = parse_modalities("hand=Subject1:LHAND:x,y,z; other=RHAND:x,y,z")
    demo = read_dataset(tmp_path / "occluded.c3d", "c3d", one, RigOptions(rate=100.0))
    assert_allclose(demo.dataset["wave"][0].select(("hand_x",)),
                    rf.hand_at(demo.dataset["wave"][0].times)[:, :1], atol=1e-9)  # fmt: skip
    seen[240:340] = False
    rf.write_c3d(tmp_path / "lost.c3d", seen=seen)
    with pytest.raises(ValueError, match=r"lost.c3d \[2.200-3.600 s\]: stream 'Subject1:LHAND' "
                                         r"stops at 2.390 s and resumes at 3.400 s"):  # fmt: skip
        read_dataset(tmp_path / "lost.c3d", "c3d", one, RigOptions(rate=100.0))


def test_yarp_logs_with_a_second_port_at_another_rate(tmp_path: Path) -> None:
    rf.write_yarp_session(tmp_path / "session")
    # The head port named by its YARP port (info.log), in degrees; the arm by its folder.
    check_session(read_dataset(tmp_path, "yarp", parse_modalities(YARP)), 1e-6, INDICES)
    # Two stamps per line (Stamp: tx+rx): the sender's is used.
    folder = tmp_path / "txrx" / "session"
    rf.write_yarp_session(folder)
    log = folder / "head" / "data.log"
    lines = [line.split(" ", 2) for line in log.read_text().splitlines()]
    log.write_text("".join(f"{k} {t} {float(t) + 0.004:.6f} {rest}\n" for k, t, rest in lines))
    (folder / "head" / "info.log").write_text("Type: Bottle;\nStamp: tx+rx;\n")
    read = read_dataset(tmp_path / "txrx", "yarp", parse_modalities(
        "hand=left_arm:0,1,2@m; head=head:0,1,2@deg"))  # fmt: skip
    check_session(read, 1e-6, INDICES)


def test_one_recording_per_demonstration_and_still_cuts(tmp_path: Path) -> None:
    """Class folders of whole recordings (no markers), and a long take cut where it rests."""
    for klass, k in (("reach", 1), ("reach", 2), ("wave", 1)):
        rf.write_xdf(tmp_path / "whole" / klass / f"take{k}.xdf", markers=())
    read = read_dataset(tmp_path / "whole", "xdf")
    assert {c: [d.name for d in v] for c, v in read.dataset.items()} == {
        "reach": ["take1", "take2"], "wave": ["take1"]}  # fmt: skip
    assert read.files[("reach", "take2")] == "reach/take2.xdf"
    demo = read.dataset["reach"][0]
    assert_allclose(demo.times, rf.head_times(), atol=1e-9)  # the head ends first: 5.972 s
    # A YARP take that rests between three movements: cut at its still periods.
    t = np.arange(0, 9.0, 0.01)
    moving = ((t > 1) & (t < 2)) | ((t > 4) & (t < 5.5)) | ((t > 7) & (t < 8))
    x = np.cumsum(np.where(moving, 0.2, 0.0)) * 0.01  # 20 cm/s while moving
    rows = np.column_stack([x, 0 * x, 0 * x]).tolist()
    rf.write_yarp_port(tmp_path / "still" / "reach" / "take" / "arm", "/arm:o", rf.YARP_START + t,
                       rows)  # fmt: skip
    read = read_dataset(tmp_path / "still", "yarp", parse_modalities("hand=arm:0,1,2@m"),
                        RigOptions(cut="still"))  # fmt: skip
    spans = [tuple(float(v) for v in f.rpartition("[")[2][:-3].split("-"))
             for f in read.files.values()]  # fmt: skip
    assert [d.name for d in read.dataset["reach"]] == ["take-1", "take-2", "take-3"]
    for (a, b), (start, end) in zip(spans, [(1, 2), (4, 5.5), (7, 8)], strict=True):
        assert start - 0.25 < a < start and end < b < end + 0.25  # the margin kept


# ------------------------------------------------------------------------------ refusals


def refused(match: str, *args, **kwargs) -> None:
    with pytest.raises(ValueError, match=match):
        read_dataset(*args, **kwargs)


def test_bad_recordings_are_refused_with_the_file_and_the_reason(tmp_path: Path) -> None:
    # A stream that stops mid-demonstration (the head stops at 3 s, in the wave).
    rf.write_ros2_bag(tmp_path / "stops" / "session", head_duration=3.0)
    refused(r"session \[2.200-3.600 s\]: stream '/head' stops at 2.972 s, mid-demonstration",
            tmp_path / "stops", "rosbag", parse_modalities(ROS2))  # fmt: skip
    # A wrong topic: the bag's topics are listed.
    rf.write_ros2_bag(tmp_path / "topic" / "session")
    refused(r"session: no numeric stream '/nope' for modality 'hand'; its streams: /hand",
            tmp_path / "topic", "rosbag", parse_modalities("hand=/nope:pose.position.x"))
    refused(r"topic '/hand' \(geometry_msgs/msg/PoseStamped\) has no field\(s\) "
            r"\['pose.nope'\]", tmp_path / "topic", "rosbag",
            parse_modalities("hand=/hand:pose.nope"))  # fmt: skip
    # Times that go back.
    rf.write_yarp_session(tmp_path / "back" / "session")
    log = tmp_path / "back" / "session" / "left_arm" / "data.log"
    lines = log.read_text().splitlines()
    lines[100], lines[101] = lines[101], lines[100]
    log.write_text("\n".join(lines) + "\n")
    refused(r"session: stream 'left_arm': time stamps not monotonic: sample 101 at 1.000000 s "
            r"goes back from 1.010000 s", tmp_path / "back", "yarp", parse_modalities(YARP))
    # An unknown marker, a truncated file, no markers and no class, several marker streams.
    rf.write_xdf(tmp_path / "marker" / "session.xdf", markers=[*rf.MARKERS, (5.7, "oops")])
    refused(r"session.xdf: marker stream 'events': unknown marker 'oops' at 5.700 s",
            tmp_path / "marker", "xdf")  # fmt: skip
    xdf = tmp_path / "cut" / "session.xdf"
    rf.write_xdf(xdf)
    xdf.write_bytes(xdf.read_bytes()[:-30])
    refused(r"session.xdf: truncated: a chunk at byte \d+ declares", tmp_path / "cut", "xdf")
    rf.write_xdf(tmp_path / "plain" / "session.xdf", markers=())
    refused(r"session.xdf: a recording directly in the dataset folder is a session.*has none",
            tmp_path / "plain", "xdf")  # fmt: skip
    refused(r"no XDF files \(.xdf, .xdfz\) found", tmp_path / "topic", "xdf")
    rf.write_yarp_session(tmp_path / "two" / "session")
    rf.write_yarp_port(tmp_path / "two" / "session" / "cues", "/cues:o", [rf.YARP_START],
                       [["start reach"]])  # fmt: skip
    refused(r"several marker streams \['cues', 'events'\]: choose one",
            tmp_path / "two", "yarp", parse_modalities(YARP))  # fmt: skip
    two = read_dataset(tmp_path / "two", "yarp", parse_modalities(YARP),
                       RigOptions(markers="events"))  # fmt: skip
    assert len(two.files) == 6
    # The stream syntax is for recordings only.
    refused(r"NAME=STREAM:FIELD \(or @UNIT\) is for recordings", tmp_path, "csv",
            parse_modalities("hand=/a:x"))  # fmt: skip


def test_a_missing_library_names_the_extra(tmp_path: Path, monkeypatch) -> None:
    rf.write_xdf(tmp_path / "session.xdf")
    rf.write_c3d(tmp_path / "c3d" / "session.c3d")
    rf.write_ros1_bag(tmp_path / "ros" / "session.bag")
    for module, fmt, root, extra in [
        ("pyxdf", "xdf", tmp_path / "session.xdf", "xdf"),
        ("ezc3d", "c3d", tmp_path / "c3d", "c3d"),
        ("rosbags", "rosbag", tmp_path / "ros", "rosbag"),
    ]:
        with monkeypatch.context() as patch:
            patch.setitem(sys.modules, module, None)  # import raises ImportError
            for name in [n for n in sys.modules if n.startswith(f"{module}.")]:
                patch.setitem(sys.modules, name, None)
            refused(rf"pip install 'icub-intention-studio\[{extra}\]' \({module}\)", root, fmt)


# ------------------------------------------------------------------------------ entry points


def test_the_command_lines_read_recordings(tmp_path: Path, capsys) -> None:
    """The studio's --import-dataset and the evaluation read a session file by its mapping."""
    from app.cli import build_parser, prepare_workspace
    from app.io.workspace import Workspace
    from promp.evaluate.cli import main

    session = rf.write_ros2_bag(tmp_path / "session")
    mapping = tmp_path / "mapping.txt"
    mapping.write_text("# the iCub's hand and the partner's head\n" + ROS2.replace("; ", "\n"))
    args = build_parser().parse_args(["--workspace", str(tmp_path / "ws"), "--import-dataset",
                                      str(session), "--mapping", str(mapping)])  # fmt: skip
    prepare_workspace(args)
    out = capsys.readouterr().out
    assert "2 primitives, 6 demonstrations: reach (3), wave (3)" in out
    assert f"Mapping: {ROS2}" in out and "reach/session-3 ← session [4.000-5.500 s]" in out
    data = Workspace(tmp_path / "ws").load()
    assert data.layout.names == ("hand", "head") and len(data.demos["reach"]) == 3
    # The evaluation of the same bag: one held-out demonstration per class, fixed settings.
    code = main([str(session), "--format", "rosbag", "--mapping", str(mapping), "--percent",
                 "50", "--alpha", "ml", "--basis", "5", "--width", "1", "--shrinkage", "0.5",
                 "--noise-scale", "1", "--jobs", "1", "--include-flagged"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 0, err
    assert f"mapping: {ROS2}" in err


def test_every_format_through_the_data_tab_upload(tmp_path: Path) -> None:
    """What the Data tab does with an upload: a session file as it is (a bag, an XDF, a C3D), or
    a zip of a dump folder; the format told by the files, the mapping guessed and shown, every
    demonstration listed with its source before anything is written."""
    from app.io.dataset_import import extract_dataset_zip
    from tests.test_dataset_import import zip_folder

    uploads = {
        "session.bag": rf.write_ros1_bag(tmp_path / "session.bag").read_bytes(),
        "session.mcap": next(rf.write_ros2_bag(tmp_path / "ros2").glob("*.mcap")).read_bytes(),
        "session.xdf": rf.write_xdf(tmp_path / "session.xdf").read_bytes(),
        "session.c3d": rf.write_c3d(tmp_path / "session.c3d").read_bytes(),
        "session.zip": zip_folder(rf.write_yarp_session(tmp_path / "dump" / "session"),
                                  prefix="session/"),
    }  # fmt: skip
    expected = {"session.bag": "rosbag", "session.mcap": "rosbag", "session.xdf": "xdf",
                "session.c3d": "c3d", "session.zip": "yarp"}  # fmt: skip
    for name, content in uploads.items():
        upload = extract_dataset_zip(content, name)
        try:
            assert upload.format == expected[name]
            data, summary = upload.read()
            assert summary.counts == {"reach": 3, "wave": 3}, name
            assert summary.mapping and summary.notes
            source = "session" if name == "session.zip" else name
            first = summary.demonstrations_lines()[0]
            assert first == f"reach/session-1 ← {source} [0.500-1.800 s]"
            assert data.n_demos == 6
        finally:
            upload.close()
        assert not upload.tempdir.exists()
    with pytest.raises(ValueError, match="a dataset is uploaded as a .zip of its folder, or a "
                                         "session file"):  # fmt: skip
        extract_dataset_zip(b"data", "session.txt")
