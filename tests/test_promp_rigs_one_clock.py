"""Streams that start or stop apart, put on one clock (``promp.rigs.streams.common_span``): an
iCub's dataDumper folders as they come (the end effector's wrench port connected 37 ms after
the hand's state port) read with the mapping guessed, cut to the span both ports cover and
said in the read's notes; a port late by more than 10 % of the demonstration is refused naming
it; every rig format follows the same rule, and the live time base's stricter one is kept.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.datasets import parse_modalities, read_dataset
from promp.rigs import RigOptions
from promp.rigs.streams import CUT_SHARE, Stream, common_span, on_one_clock
from tests import rig_files as rf

WRENCH = "cartesianEndEffectorWrench"
GUESSED = f"{WRENCH}={WRENCH}:0,1,2,3,4,5; state=state:0,1,2,3,4,5,6"
TYPED = f"hand=state:0,1,2@m; wrench={WRENCH}:0,1,2,3,4,5"
TAKES = {"reach": 2, "wave": 2}
HAND = ("hand_0", "hand_1", "hand_2")  # YARP's fields are indices
TAKE_END = rf.ICUB_TAKE_S - 1 / rf.HAND_HZ  # the state's last sample, 8.99 s


def cut_notes(read) -> list[str]:
    return [note for note in read.notes if "cut to the span every stream covers" in note]


def test_an_icub_dump_as_it_comes_reads_with_the_guessed_mapping(tmp_path: Path) -> None:
    """Numbered port folders, no mapping given: one demonstration per take (none is cut by
    markers), each from the wrench's first sample, said once per take."""
    rf.write_icub_dump(tmp_path, TAKES)
    read = read_dataset(tmp_path, "yarp")
    assert read.mapping == GUESSED
    assert {k: [d.name for d in v] for k, v in read.dataset.items()} == {
        "reach": ["00000", "00001"], "wave": ["00000", "00001"]}  # fmt: skip
    for klass, demos in read.dataset.items():
        for demo in demos:
            # From the wrench's first sample (YARP's stamps: 1e-6 s on 1.7e9 s).
            assert demo.times[0] == pytest.approx(rf.WRENCH_DELAY, abs=1e-6)
            assert demo.times[-1] <= TAKE_END
            assert_allclose(demo.values[:, :6], rf.icub_wrench(demo.times, klass), atol=1e-5)
            # The state, interpolated at the wrench's times: exact but at the movements' kinks.
            assert_allclose(demo.values[:, 6:9], rf.icub_hand(demo.times, klass), atol=1e-3)
    said = cut_notes(read)
    assert len(said) == 4 and said[0] == (
        f"reach/00000: stream '{WRENCH}' starts at 0.037 s, 0.037 s into the recording "
        f"(0.000-8.990 s): cut to the span every stream covers, 0.037-8.987 s (0.4 % of the "
        "recording left out)"
    )
    assert any(note.startswith("One clock: 4 span(s) cut") for note in read.notes)
    assert read.findings == ()  # a cut within the share is no fault: learned from as cut


def test_the_dump_cut_at_its_still_periods_with_a_typed_mapping(tmp_path: Path) -> None:
    """Three movements a take, cut where the hand rests: the same twelve demonstrations with
    the hand alone (no cut: one port) and with the hand and the wrench (the takes cut)."""
    rf.write_icub_dump(tmp_path, TAKES)
    still = RigOptions(cut="still")
    hand = read_dataset(tmp_path, "yarp", parse_modalities("hand=state:0,1,2@m"), still)
    both = read_dataset(tmp_path, "yarp", parse_modalities(TYPED), still)
    names = {k: [d.name for d in v] for k, v in both.dataset.items()}
    assert names == {k: [d.name for d in v] for k, v in hand.dataset.items()}
    assert names["reach"] == ["00000-1", "00000-2", "00000-3", "00001-1", "00001-2", "00001-3"]
    assert not cut_notes(hand) and len(cut_notes(both)) == 4
    for (klass, name), source in both.files.items():
        k = int(name[-1]) - 1
        a, b = (float(v) for v in source.rpartition("[")[2][:-3].split("-"))
        move = rf.ICUB_MOVES[k]
        assert move[0] - 0.25 < a < move[0] and move[1] < b < move[1] + 0.25  # the margins
        demo = next(d for d in both.dataset[klass] if d.name == name)
        assert_allclose(demo.select(HAND), rf.icub_hand(demo.times, klass), atol=1e-3)
    assert [(m.name, m.unit) for m in both.layout.modalities] == [("hand", "m"), ("wrench", "")]


def test_a_marker_session_cuts_only_the_demonstration_the_late_port_misses(
    tmp_path: Path,
) -> None:
    rf.write_icub_session(tmp_path / "session")
    read = read_dataset(tmp_path, "yarp")
    assert list(read.files.values()) == [
        "session [0.000-2.500 s]", "session [3.500-6.000 s]", "session [6.500-8.600 s]"]
    assert cut_notes(read) == [
        f"session [0.000-2.500 s]: stream '{WRENCH}' starts at 0.037 s, 0.037 s into the "
        "demonstration (0.000-2.500 s): cut to the span every stream covers, 0.037-2.500 s "
        "(1.5 % of the demonstration left out)"
    ]
    first, second = read.dataset["reach"][0], read.dataset["wave"][0]
    assert first.times[0] == pytest.approx(rf.WRENCH_DELAY, abs=1e-6) and second.times[0] >= 3.5


@pytest.mark.parametrize("cut", ["files", "still"])
def test_a_port_late_by_more_than_the_share_is_refused_naming_it(tmp_path: Path, cut) -> None:
    """15 % of the take late: refused, naming the port; 9 %: read, said."""
    options = RigOptions(cut=cut)
    rf.write_icub_dump(tmp_path / "late", TAKES, delay=0.15 * TAKE_END)
    with pytest.raises(ValueError, match=(
        rf"^reach/00000: stream '{WRENCH}' starts at 1.349 s, 1.349 s into the recording "
        r"\(0.000-8.990 s\): the span every stream covers would leave out 15.0 % of the "
        r"recording, over the 10 % that may be cut"
    )):  # fmt: skip
        read_dataset(tmp_path / "late", "yarp", None, options)
    rf.write_icub_dump(tmp_path / "within", TAKES, delay=0.09 * TAKE_END)
    read = read_dataset(tmp_path / "within", "yarp", None, options)
    assert len(cut_notes(read)) == 4 and "(9.0 % of the recording left out)" in cut_notes(read)[0]


def test_a_port_that_stops_early_is_cut_or_refused_the_same_way(tmp_path: Path) -> None:
    for folder, share in (("early", 0.05), ("stopped", 0.12)):
        rf.write_icub_dump(tmp_path / folder, TAKES, delay=0.0)
        for log in (tmp_path / folder).glob(f"*/{WRENCH}/*/data.log"):
            lines = log.read_text().splitlines()
            log.write_text("\n".join(lines[: round(len(lines) * (1 - share))]) + "\n")
    read = read_dataset(tmp_path / "early", "yarp")
    assert f"stream '{WRENCH}' stops at 8.540 s, mid-recording, 0.450 s before its end" in (
        cut_notes(read)[0])  # fmt: skip
    with pytest.raises(ValueError, match=rf"stream '{WRENCH}' stops at 7.910 s, mid-recording.*"
                                         r"leave out 12.0 % of the recording"):  # fmt: skip
        read_dataset(tmp_path / "stopped", "yarp")


@pytest.mark.skipif(not os.environ.get("CI") and not all(
    __import__("importlib").util.find_spec(m) for m in ("rosbags", "pyxdf")),
    reason="the rosbag and xdf extras")  # fmt: skip
def test_every_rig_format_cuts_a_late_stream(tmp_path: Path) -> None:
    """Not only YARP: an XDF file whose head stream starts late, a ROS 2 bag whose hand topic
    does, one recording per demonstration in class folders."""
    for k in (1, 2):
        rf.write_xdf(tmp_path / "xdf" / "reach" / f"take{k}.xdf", markers=(),
                     head_times_=0.5 + rf.head_times(rf.DURATION - 0.5))  # fmt: skip
        late = rf.hand_times()[rf.hand_times() >= 0.8]
        rf.write_ros2_bag(tmp_path / "ros" / "reach" / f"take{k}", markers=(),
                          hand=(late, rf.hand_at(late)))  # fmt: skip
    xdf = read_dataset(tmp_path / "xdf", "xdf")
    assert "stream 'head' starts at 0.505 s, 0.505 s into the recording" in cut_notes(xdf)[0]
    assert xdf.dataset["reach"][0].times[0] == pytest.approx(0.505)
    assert_allclose(xdf.dataset["reach"][0].select(("x", "y", "z")),
                    rf.hand_at(xdf.dataset["reach"][0].times), atol=1e-9)  # fmt: skip
    ros = read_dataset(tmp_path / "ros", "rosbag", parse_modalities(
        "hand=/hand:pose.position.{x,y,z}; head=/head:pose.orientation.{roll,pitch,yaw}"),
        RigOptions(cut="files"))  # the bags have an empty marker topic
    assert "stream '/hand' starts at 0.795 s, 0.795 s into the recording" in cut_notes(ros)[0]
    rf.write_xdf(tmp_path / "far" / "reach" / "take.xdf", markers=(),
                 head_times_=2.0 + rf.head_times(rf.DURATION - 2.0))  # fmt: skip
    with pytest.raises(ValueError, match=r"reach/take.xdf: stream 'head' starts at 2.005 s"):
        read_dataset(tmp_path / "far", "xdf")


def streams(late: float) -> list[Stream]:
    t = np.arange(0.0, 10.0, 0.01)
    later = t[t >= late]
    return [Stream("a", t, t[:, None], ("m",)), Stream("b", later, later[:, None], ("m",))]


def test_the_common_span_rule() -> None:
    # Within three steps of the slowest stream: cut, unsaid (a dumper's ports, one by one).
    quiet = common_span(streams(0.02), 0.0, 9.99, "s")
    assert not quiet.cut and quiet.lo == pytest.approx(0.02)
    said = common_span(streams(0.5), 0.0, 9.99, "s")
    assert said.cut and said.late == ("b", pytest.approx(0.5)) and said.share == pytest.approx(
        0.5 / 9.99)  # fmt: skip
    assert common_span(streams(0.99), 0.0, 9.99, "s").share < CUT_SHARE
    with pytest.raises(ValueError, match="stream 'b' starts at 1.010 s"):
        common_span(streams(1.01), 0.0, 9.99, "s")
    # The live time base's rule (on_one_clock): nothing beyond the tolerance is cut.
    with pytest.raises(ValueError, match=r"^s: stream 'b' starts at 0.500 s, 0.500 s into the "
                                         r"demonstration \(0.000-9.990 s\)$"):  # fmt: skip
        on_one_clock(streams(0.5), 0.0, 9.99, None, "s")
    times, _ = on_one_clock(streams(0.5), said.lo, said.hi, None, "s")
    assert times[0] == pytest.approx(0.5)
