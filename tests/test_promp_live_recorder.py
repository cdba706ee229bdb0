"""The live recorder: a movement's samples journalled as they come, so that a kill (a real
SIGKILL of the recording process) loses nothing acknowledged; the finished demonstration
written atomically, never over another file."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from promp.data import Demonstration
from promp.datasets import demo_to_csv
from promp.live.journal import Journal, read_journal
from promp.live.recorder import Recorder, free_path, movement_of, recover
from promp.live.segmenter import Movement
from tests.conftest import REPO

RNG = np.random.default_rng(4)
TIMES = 5000.0 + np.cumsum(RNG.uniform(0.003, 0.005, 3000))
VALUES = RNG.normal(size=(3000, 3)) * np.array([1.0, 1e-7, 1e7])


def test_a_journal_reads_back_exactly_and_a_torn_last_line_is_left_out(tmp_path) -> None:
    journal = Journal(tmp_path / "a.journal", ("x", "y", "z"), "take-1", "top", TIMES[0])
    assert journal.append(TIMES[:10], VALUES[:10]) == 10
    assert journal.append(TIMES[10:25], VALUES[10:25]) == 25
    journal.close()
    demo, header = read_journal(tmp_path / "a.journal")
    assert header["label"] == "top" and demo.name == "take-1"
    assert_array_equal(demo.times, TIMES[:25] - TIMES[0])
    assert_array_equal(demo.values, VALUES[:25])
    with open(tmp_path / "a.journal", "a") as handle:
        handle.write("0.5,1.25,3")  # a row cut short: never acknowledged
    assert read_journal(tmp_path / "a.journal")[0].n_samples == 25
    with pytest.raises(ValueError, match="not a promp-live journal"):
        (tmp_path / "b.journal").write_text("t,x\n0,1\n1,2\n")
        read_journal(tmp_path / "b.journal")


def test_a_finished_movement_is_written_atomically_and_its_journal_removed(tmp_path) -> None:
    recorder = Recorder(tmp_path / "journals", ("x", "y", "z"), "session")
    movement = Movement(7, "left", TIMES[:200], VALUES[:200])
    recorder.append(Movement(7, "left", TIMES[:120], VALUES[:120]))
    assert recorder.acknowledged == 120
    target = tmp_path / "demos" / "left" / "session-007.csv"
    recorded = recorder.finish(movement, target)
    demo = recorded.demo
    assert recorded.path == target and recorded.journal is None and recorded.label == "left"
    assert target.read_text() == demo_to_csv(demo)
    assert_array_equal(demo.values, VALUES[:200])
    assert list((tmp_path / "journals").glob("*")) == []
    # with an output folder: never over an existing file
    out = Recorder(tmp_path / "journals", ("x", "y", "z"), "session", output=tmp_path / "demos")
    again = out.finish(movement)
    assert again.path == tmp_path / "demos" / "left" / "session-007-2.csv"
    assert again.path.read_text() == demo_to_csv(demo)
    assert target.read_text() == demo_to_csv(demo)


def test_a_journal_never_replaces_another_file(tmp_path) -> None:
    (tmp_path / "live-001.journal").write_text("someone else's")
    recorder = Recorder(tmp_path, ("x", "y", "z"))
    recorder.append(Movement(1, "", TIMES[:5], VALUES[:5]))
    assert (tmp_path / "live-001.journal").read_text() == "someone else's"
    assert recorder.journal_path(1).name == "live-001-1.journal"


RECORDING = textwrap.dedent("""
    import sys
    import numpy as np
    from promp.live.recorder import Recorder
    from promp.live.segmenter import Movement
    from tests.test_promp_live_recorder import TIMES, VALUES

    recorder = Recorder(sys.argv[1], ("x", "y", "z"))
    for n in range(3, TIMES.size, 7):  # the movement grows as samples come
        print(recorder.append(Movement(1, "top", TIMES[:n], VALUES[:n])), flush=True)
    input()  # never reached: killed first
""")


def test_a_kill_during_a_recording_loses_nothing_acknowledged(tmp_path) -> None:
    process = subprocess.Popen(
        [sys.executable, "-c", RECORDING, str(tmp_path)], cwd=REPO, stdout=subprocess.PIPE,
        stdin=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(REPO)},
    )  # fmt: skip
    acknowledged = 0
    while acknowledged < 1000:
        line = process.stdout.readline()
        assert line, "the recording process ended early"
        acknowledged = int(line)
    os.kill(process.pid, signal.SIGKILL)
    process.wait(timeout=30)
    assert process.returncode == -signal.SIGKILL
    ((path, demo),) = recover(tmp_path)
    assert demo.n_samples >= acknowledged
    n = demo.n_samples
    assert_array_equal(demo.times, TIMES[:n] - TIMES[0])
    assert_array_equal(demo.values, VALUES[:n])


def test_journals_left_behind_are_recovered_oldest_first_and_a_bad_one_says_why(tmp_path) -> None:
    for number, n in ((2, 30), (1, 12)):
        journal = Journal(tmp_path / f"b-{number}.journal", ("x", "y", "z"), f"take-{number}",
                          "", TIMES[0])  # fmt: skip
        journal.append(TIMES[:n], VALUES[:n])
        journal.close()
    (tmp_path / "a-0.journal").write_text("t,x\n0,1\n")  # not a journal
    for age, name in enumerate(("b-2.journal", "b-1.journal", "a-0.journal")):  # oldest first
        os.utime(tmp_path / name, (1e9 + age, 1e9 + age))
    found = recover(tmp_path)
    assert [path.name for path, _ in found] == ["b-2.journal", "b-1.journal", "a-0.journal"]
    assert [d.n_samples for _, d in found[:2]] == [30, 12]
    path, reason = found[2]
    with pytest.raises(ValueError) as refused:
        read_journal(path)
    assert reason == str(refused.value)
    assert recover(tmp_path / "absent") == []


def test_a_free_path_counts_past_every_existing_file(tmp_path) -> None:
    target = tmp_path / "take.csv"
    assert free_path(target) == target
    target.write_text("")
    (tmp_path / "take-2.csv").write_text("")
    assert free_path(target) == tmp_path / "take-3.csv"


def test_a_demonstration_as_a_movement_keeps_its_rows() -> None:
    demo = Demonstration(TIMES[:40] - TIMES[0], VALUES[:40], ("x", "y", "z"), "d")
    movement = movement_of(demo, 4, "left")
    assert (movement.number, movement.label, len(movement)) == (4, "left", 40)
    assert_array_equal(movement.times, demo.times)
    assert_array_equal(movement.values, demo.values)
    assert movement_of(demo, 1).label == ""


def test_releasing_a_movement_removes_its_journal_and_leaves_the_one_under_way(tmp_path) -> None:
    recorder = Recorder(tmp_path, ("x", "y", "z"))
    recorder.release(5)  # no journal of movement 5: nothing to do
    recorder.append(Movement(1, "", TIMES[:10], VALUES[:10]))
    journal = recorder.journal_path(1)
    recorder.release(2)  # another movement's: movement 1's journal stays open, where it was
    assert journal.exists()
    assert recorder.append(Movement(1, "", TIMES[:30], VALUES[:30])) == 30
    assert read_journal(journal)[0].n_samples == 30
    recorder.release(1)
    assert not journal.exists() and list(tmp_path.iterdir()) == []
    assert recorder.acknowledged == 0  # its journal closed
    assert recorder.append(Movement(2, "", TIMES[:4], VALUES[:4])) == 4  # a new journal


def test_a_recorder_s_prefix_names_and_its_folders() -> None:
    for bad in ("", "a" * 41, "two words", "take/1", "täke"):
        with pytest.raises(ValueError):
            Recorder("j", ("x",), bad)
    recorder = Recorder("j", ["x", "y"], "a_B-9" + "c" * 35, output="out")
    assert recorder.columns == ("x", "y") and recorder.output == Path("out")
    assert recorder.folder == Path("j") and Recorder("j", ("x",)).output is None
    plain = Recorder("j", ("x",))
    assert plain.prefix == "live" and plain.acknowledged == 0
    assert (plain.name_of(7), plain.name_of(1234)) == ("live-007", "live-1234")
    assert plain.journal_path(7) == Path("j") / "live-007.journal"


def test_each_movement_has_a_journal_of_its_own_never_over_a_file(tmp_path) -> None:
    recorder = Recorder(tmp_path, ("x", "y", "z"), "t")
    assert recorder.append(Movement(1, "", TIMES[:0], VALUES[:0])) == 0
    assert list(tmp_path.iterdir()) == []  # no rows: no journal
    for name in ("t-001.journal", "t-001-1.journal"):
        (tmp_path / name).write_text("another's")
    assert recorder.append(Movement(1, "top", TIMES[:6], VALUES[:6])) == 6
    first = recorder.journal_path(1)
    assert first.name == "t-001-2.journal" and recorder.acknowledged == 6
    assert recorder.append(Movement(1, "top", TIMES[:9], VALUES[:9])) == 9  # the new rows
    assert recorder.append(Movement(2, "left", TIMES[9:12], VALUES[9:12])) == 3
    assert recorder.journal_path(2).name == "t-002.journal"  # the stamp was movement 1's
    demo, header = read_journal(first)  # closed when movement 2 began: whole
    assert demo.n_samples == 9 and header["label"] == "top" and header["start"] == TIMES[0]
    assert demo.name == "t-001" and demo.columns == ("x", "y", "z")
    recorder.close()
    recorder.close()
    demo, header = read_journal(tmp_path / "t-002.journal")
    assert demo.n_samples == 3 and header["label"] == "left" and header["start"] == TIMES[9]
    assert recorder.acknowledged == 0
    assert (tmp_path / "t-001.journal").read_text() == "another's"


def test_finishing_a_movement_too_short_or_kept_in_its_journal(tmp_path) -> None:
    recorder = Recorder(tmp_path / "j", ("x", "y", "z"))
    assert recorder.finish(Movement(1, "", TIMES[:0], VALUES[:0])) is None
    recorder.append(Movement(2, "", TIMES[:1], VALUES[:1]))
    assert recorder.journal_path(2).exists()
    assert recorder.finish(Movement(2, "", TIMES[:1], VALUES[:1])) is None
    assert list((tmp_path / "j").iterdir()) == []  # one row: its journal removed
    two = recorder.finish(Movement(6, "", TIMES[:2], VALUES[:2]))  # two rows: a demonstration
    assert two.demo.n_samples == 2 and two.journal.exists()
    kept = recorder.finish(Movement(3, "", TIMES[5:9], VALUES[5:9]))  # no path, no output
    assert (kept.number, kept.label, kept.path) == (3, "", None)
    assert kept.journal == recorder.journal_path(3) and kept.journal.exists()
    assert kept.demo.name == "live-003" and kept.demo.columns == ("x", "y", "z")
    assert_array_equal(kept.demo.times, TIMES[5:9] - TIMES[5])
    assert_array_equal(kept.demo.values, VALUES[5:9])
    assert read_journal(kept.journal)[0].n_samples == 4  # closed: whole
    unlabelled = Recorder(tmp_path / "j", ("x", "y", "z"), output=str(tmp_path / "out"))
    done = unlabelled.finish(Movement(4, "", TIMES[:3], VALUES[:3]))
    assert done.path == tmp_path / "out" / "live" / "live-004.csv" and done.path.exists()
    assert done.journal is None and not unlabelled.journal_path(4).exists()
    given = unlabelled.finish(Movement(5, "top", TIMES[:3], VALUES[:3]), str(tmp_path / "g.csv"))
    assert given.path == tmp_path / "g.csv" and given.path.exists()
    assert not (tmp_path / "out" / "top").exists()


def test_the_recorder_sink_finishes_each_ended_movement_then_journals_the_one_going_on(
        tmp_path) -> None:  # fmt: skip
    from promp.live.recorder import RecorderSink
    from promp.live.segmenter import Boundary
    from promp.live.sinks import Output

    recorder = Recorder(tmp_path, ("x", "y", "z"))
    sink = RecorderSink(recorder)
    assert sink.name == "recorder" and sink.lossless
    assert sink.view(Output(1.0, boundaries=(Boundary("start", 1, 1.0),))) is None
    going = Movement(3, "", TIMES[:5], VALUES[:5])
    ended = [Movement(1, "a", TIMES[:4], VALUES[:4]), Movement(2, "", TIMES[:1], VALUES[:1])]
    ends = (Boundary("start", 3, 2.0),
            *(Boundary("end", m.number, 2.0, "ended", m) for m in ended))  # fmt: skip
    part = sink.view(Output(2.0, events=("e",), boundaries=ends, predictions=("p",),
                            movement=going))  # fmt: skip
    assert (part.time, part.boundaries, part.movement) == (2.0, ends[1:], going)
    assert part.events == () and part.predictions == ()
    only = sink.view(Output(3.0, boundaries=ends[1:]))
    assert only.movement is None and only.boundaries == ends[1:]
    kept = sink.take(part)
    assert [r.number for r in kept] == [1]  # movement 2, one row: nothing to keep
    assert recorder.acknowledged == 5 and recorder.journal_path(3).exists()
    sink.close()
    assert recorder.acknowledged == 0 and read_journal(recorder.journal_path(3))[0].n_samples == 5
    assert sink.take(Output(4.0)) == []
