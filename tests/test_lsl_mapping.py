"""The Live source's mapping (app.live.lsl_mapping): guessed from the streams found (by their
channels' labels, by their names, or a single stream in the layout's order), read and checked
against the model and the streams found, refused with a message that says what is wrong and
what is expected; the streams' table."""

from __future__ import annotations

import pytest

from app.live.lsl_mapping import guess_mapping, parse_mapping, safe_out_name, stream_table
from promp.data import Layout, Modality
from promp.live.transport import StreamDescription
from tests.live_fakes import hand_model

HAND_HEAD = Layout((
    Modality("hand", ("x", "y", "z"), unit="m"),
    Modality("head", ("roll", "pitch", "yaw"), unit="rad", kind="angle"),
))  # fmt: skip


def stream(name, labels, type="Mocap", source_id="", rate=100.0, units=None, markers=False):
    labels = tuple(labels)
    return StreamDescription(name, type, source_id, f"uid-{name}-{source_id}", "lab-pc", rate,
                             labels, tuple(units or ("",) * len(labels)),
                             "string" if markers else "double64")  # fmt: skip


def test_the_guess_prefers_channels_labelled_after_the_modality() -> None:
    found = [
        stream("Vicon", ("hand_x", "hand_y", "hand_z", "elbow_x", "elbow_y", "elbow_z")),
        stream("HeadTracker", ("roll", "pitch", "yaw"), type="Head"),
        stream("Events", ("",), markers=True, rate=0.0),
    ]
    assert guess_mapping(HAND_HEAD, found) == (
        "hand=Vicon:hand_x,hand_y,hand_z\nhead=HeadTracker:roll,pitch,yaw"
    )


def test_the_guess_takes_a_stream_named_after_the_modality_by_its_first_channels() -> None:
    found = [stream("MocapHand", ("", "", "", "")), stream("EMG", ("", ""))]
    assert guess_mapping(HAND_HEAD, found) == (
        "hand=MocapHand:0,1,2\n# head=STREAM:0,1,2  (no stream found for it)"
    )


def test_one_stream_of_the_layouts_channels_is_read_in_its_order() -> None:
    found = [stream("Rig", ("", "", "", "", "", ""))]
    assert guess_mapping(HAND_HEAD, found) == "hand=Rig:0,1,2\nhead=Rig:3,4,5"


def test_two_streams_of_one_name_are_told_apart_by_their_source() -> None:
    found = [stream("Hand", ("",) * 3, source_id="left"), stream("Hand", ("",) * 3,
                                                                source_id="right")]
    assert guess_mapping(HAND_HEAD, found).splitlines()[0] == "hand=source_id=left:0,1,2"


def test_a_mapping_is_read_one_modality_a_line_comments_left_out() -> None:
    model = hand_model()
    found = [stream("Vicon", ("hand_x", "hand_y", "hand_z"), units=("mm",) * 3)]
    check = parse_mapping("# the hand\nhand=Vicon:hand_x,hand_y,hand_z  # in mm\n", model, found)
    assert check.modalities == ("hand",) and check.waiting == ()
    assert check.specs() == ["hand=Vicon:hand_x,hand_y,hand_z"]
    later = parse_mapping("hand=type=Mocap:0,1,2@mm", model, [])
    assert later.waiting == ("type=Mocap",)  # not found yet: the session waits for it


@pytest.mark.parametrize("text, message", [
    ("", "map at least one of the model's modalities"),
    ("# nothing", "map at least one"),
    ("hand", r"'hand': a modality is NAME=STREAM:FIELD"),
    ("hand=0,1,2", "a live input names its stream"),
    ("hand=A:0,1,2\nhand=B:0,1,2", "modality 'hand' is mapped twice"),
    ("head=A:0,1,2", "the model has no modality 'head'; its modalities are \\['hand'\\]"),
    ("hand=A:0,1", "maps 2 channel\\(s\\).*has 3 columns"),
    ("hand=A:0,1,2@deg", "is in 'deg' \\('rad'\\), but the model's 'hand' is in 'm'"),
    ("hand=Vicon:hand_x,hand_y,wrist_z", "no field\\(s\\) \\['wrist_z'\\]; its fields are"),
    ("hand=Vicon:0,1,5", "no field\\(s\\) \\['5'\\]"),
    ("hand=Events:0,1,2", "is a marker stream"),
])  # fmt: skip
def test_a_wrong_mapping_is_refused_saying_what_is_expected(text, message) -> None:
    found = [stream("Vicon", ("hand_x", "hand_y", "hand_z")),
             stream("Events", ("",), markers=True, rate=0.0)]  # fmt: skip
    with pytest.raises(ValueError, match=message):
        parse_mapping(text, hand_model(), found)


def test_channels_named_by_label_wait_for_the_streams_labels() -> None:
    """LSL's resolver does not tell the labels (an inlet does): a mapping by labels of a
    stream whose labels are not known yet is left to the session to check."""
    found = [stream("Vicon", ("", "", ""))]
    assert parse_mapping("hand=Vicon:a,b,c", hand_model(), found).waiting == ()


def test_the_table_lists_each_stream_with_its_rate_and_channels() -> None:
    found = [stream("b", ("x", "y"), rate=250.0), stream("A", ("",) * 15),
             stream("Events", ("",), markers=True, rate=0.0)]  # fmt: skip
    assert stream_table(found) == [
        ("A", "Mocap", "100 Hz", "15", "lab-pc"),
        ("b", "Mocap", "250 Hz", "2 (x, y)", "lab-pc"),
        ("Events", "Mocap", "irregular", "markers", "lab-pc"),
    ]


@pytest.mark.parametrize("name", ["", "two words", "a/b", "x" * 61])
def test_an_output_name_is_one_word(name) -> None:
    with pytest.raises(ValueError, match="output streams' name"):
        safe_out_name(name)
    assert safe_out_name(" icub.left-1 ") == "icub.left-1"
