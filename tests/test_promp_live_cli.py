"""The headless live command, ``python -m promp.live``: every option documented, bad input
refused with a message, and a run end to end on the loopback: a replayed movement predicted,
published, recorded, and Ctrl-C ending it cleanly with its counts."""

from __future__ import annotations

import io
import json
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from promp.datasets import read_csv_demo
from promp.io import save_model
from promp.live.cli import EXAMPLE, main, parser
from tests.conftest import PATIENCE_S, REPO
from tests.live_fakes import flt_dataset, hand_model, held, instances_made

pylsl = pytest.importorskip("pylsl")

from tests import lsl_push  # noqa: E402
from tests.lsl_push import hand_outlet, push_when_due  # noqa: E402


def test_help_documents_every_option(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    for action in parser()._actions:
        assert action.help, action.dest
        for option in action.option_strings:
            assert option in text
    assert "NAME-probabilities" in text and "docs/live.md" in text
    # the command's name, its example, and what each option takes
    assert text.startswith("usage: python -m promp.live ") and " ".join(EXAMPLE.split()) in text
    assert "--model FILE" in text and "--in NAME=STREAM:CHANNEL,...[@UNIT]" in text


@pytest.mark.parametrize(("argv", "expected"), [
    (["--in", "hand=S:0,1,2"], "model.json: cannot read"),
    (["--in", "tail=S:0,1,2"], "unknown modality 'tail'"),
    (["--in", "hand=S:0,1"], "maps 2 channel(s)"),
    (["--in", "hand=S:0,1,2@deg"], "is in 'deg'"),
    (["--in", "hand=0,1,2"], "names its stream"),
    (["--in", "hand=S:0,1,2", "--start", "marker"], "--markers STREAM"),
    (["--in", "hand=S:0,1,2", "--remainder", "tail"], "unknown modality 'tail'"),
    (["--in", "hand=S:0,1,2", "--rate", "0"], "positive number of Hz"),
])  # fmt: skip
def test_bad_input_is_refused_with_a_message(tmp_path, capsys, argv, expected) -> None:
    model = tmp_path / "model.json"
    if "model.json: cannot read" not in expected:
        save_model(model, hand_model())
    code = main(["--model", str(model), "--out", "robot", "--wait", "0", *argv])
    assert code == 2
    assert expected in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "expected"), [
    (["--decide", "--decide-threshold", "0"], "--decide-threshold is a probability in (0, 1)"),
    (["--decide", "--decide-threshold", "1"], "--decide-threshold is a probability in (0, 1)"),
    (["--decide", "--decide-threshold", "1.5"], "--decide-threshold is a probability in (0, 1)"),
    (["--decide", "--decide-threshold", "nan"], "--decide-threshold is a probability in (0, 1)"),
    (["--decide", "--decide-window", "-0.1"], "--decide-window: the window is seconds"),
    (["--decide", "--decide-window", "inf"], "--decide-window: the window is seconds"),
    (["--decide-threshold", "0.8"], "need --decide"),
    (["--decide-window", "0.2"], "need --decide"),
])  # fmt: skip
def test_a_commit_rule_outside_its_range_is_refused_before_anything_starts(
        tmp_path, capsys, argv, expected) -> None:  # fmt: skip
    """Refused before the model is read (it does not exist here) and before any stream."""
    code = main(["--model", str(tmp_path / "none.json"), "--in", "hand=S:0,1,2", "--out",
                 "robot", "--wait", "0", *argv])  # fmt: skip
    assert code == 2
    err = capsys.readouterr().err
    assert expected in err and "cannot read" not in err


def test_decide_rule_defaults_to_the_rule_s_window() -> None:
    from promp.decision import WINDOW_S, CommitRule
    from promp.live.cli import decide_rule
    from promp.live.options import DECIDE_THRESHOLD

    assert decide_rule(False, None, None) is None
    assert decide_rule(True, None, None) == CommitRule(DECIDE_THRESHOLD, WINDOW_S)
    assert decide_rule(True, 0.7, 0.0) == CommitRule(0.7, 0.0)


def test_the_command_predicts_publishes_records_and_stops_cleanly(tmp_path) -> None:
    model = hand_model()
    save_model(tmp_path / "model.json", model)
    name, out = f"CliHand-{os.getpid()}", f"cli-{os.getpid()}"
    outlet = hand_outlet(name)
    command = [sys.executable, "-m", "promp.live", "--model", str(tmp_path / "model.json"),
               "--in", f"hand={name}:0,1,2@mm", "--out", out, "--remainder", "hand",
               "--record", str(tmp_path / "takes"), "--status-every", "0.2",
               "--lsl-config", str(REPO / "tests" / "lsl_loopback.cfg")]  # fmt: skip
    process = subprocess.Popen(command, cwd=tmp_path, stdout=subprocess.PIPE, text=True,
                               env={**os.environ, "PYTHONPATH": str(REPO)})  # fmt: skip
    try:
        found = pylsl.resolve_byprop("name", f"{out}-timing", 1, PATIENCE_S)
        assert found, "the command's outlets did not appear"
        timing = lsl_push.inlet(found[0], PATIENCE_S)
        assert outlet.wait_for_consumers(PATIENCE_S)
        demo = held(flt_dataset()["front"][0], 0.6, 0.9)
        values = demo.select(["x", "y", "z"]) * 1000.0
        stamps = pylsl.local_clock() + 0.05 + demo.times
        push_when_due(outlet, values, stamps, stamps)
        lines = []
        while not any("movement 1 ended" in line for line in lines):
            line = process.stdout.readline()
            assert line, "the command ended early"
            lines.append(line)
        rows, _ = timing.pull_chunk(timeout=1.0, max_samples=10000)
        process.send_signal(signal.SIGINT)
        rest, _ = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0
    summary = json.loads(rest.strip().splitlines()[-1])
    assert summary["received"][name] == demo.n_samples and summary["movements"] == 1
    assert summary["predictions"] == len(rows) >= 2  # a second's count is the machine's load
    assert any("movement 1 (" in line and "predictions/s" in line for line in lines)
    seqs = [int(r[0]) for r in rows]
    assert seqs == list(range(1, len(rows) + 1))
    (take,) = (tmp_path / "takes" / "live").glob("*.csv")
    recorded = read_csv_demo(take)
    assert recorded.columns == ("x", "y", "z") and recorded.n_samples > 50
    assert int(rows[-1][14]) == recorded.n_samples  # the last prediction: the take's rows
    assert np.all(np.isin(np.round(recorded.values[:, 0] * 1000.0, 9),
                          np.round(values[:, 0], 9)))  # fmt: skip
    assert list((tmp_path / "takes" / ".journals").glob("*")) == []


class Flushed(io.StringIO):
    """The command's stdout or stderr: notes each write and each flush (None)."""

    def __init__(self):
        super().__init__()
        self.calls: list = []

    def write(self, text: str) -> int:
        self.calls.append(text)
        return super().write(text)

    def flush(self) -> None:
        self.calls.append(None)

    def lines(self) -> list[str]:
        """The lines written, each checked to have been flushed as it ended."""
        ends = [i for i, c in enumerate(self.calls) if c is not None and c.endswith("\n")]
        assert all(i + 1 < len(self.calls) and self.calls[i + 1] is None for i in ends), \
            "a line was not flushed as it was printed"  # fmt: skip
        return self.getvalue().strip().splitlines()


class FakeTime:
    """The command's ``time``: ``monotonic`` a clock only ``sleep`` advances (by the seconds
    asked and a little more, so that no sum of them is round), a real sleep of 1 ms so that
    the session's threads run; the rest is the real module's."""

    def __init__(self):
        self.now = 5000.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds + 0.000123
        time.sleep(0.001)

    def __getattr__(self, name):
        return getattr(time, name)


def test_the_command_in_this_process_predicts_records_and_sums_up(tmp_path, monkeypatch,
                                                                  capsys) -> None:  # fmt: skip
    """The command itself (its waits, its report, its summary) over the fake network: a
    movement between the markers ``start right`` and ``end right``, then Ctrl-C. The command's
    clock is a fake one: each status line's rate is the predictions since the last over the
    seconds since, and the summary's seconds those of that clock."""
    import threading

    import promp.live.cli
    import promp.live.session
    from promp.live import lsl
    from tests.conftest import wait_until
    from tests.live_fakes import FakeStream, FakeTransport, synthetic_model
    from tests.synthetic import make_dataset

    class Opening(FakeTransport):
        opened: set = set()

        def open(self, description):
            self.opened.add(description.uid)
            return super().open(description)

    transport = Opening()
    hand = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    cue = transport.add(FakeStream("Cues", ("label",), rate=0.0, type="Markers", markers=True))
    monkeypatch.setattr(lsl, "LslTransport", lambda: transport)
    save_model(tmp_path / "model.json", synthetic_model())
    demo = make_dataset(seed=11, n_demos=1)["right"][0]
    values = demo.select(["x", "y", "z"])
    record = tmp_path / "takes"
    (record / ".journals").mkdir(parents=True)
    (record / ".journals" / "old.journal").write_text("not a journal")  # said, left alone
    from promp.live.journal import Journal

    killed = Journal(record / ".journals" / "live-1.journal", ("x", "y", "z"), "take-9", "", 0.0)
    killed.append(demo.times[:7], values[:7])  # a recording a kill interrupted
    killed.close()

    from promp.live import status_line as status_line_module

    clock = FakeTime()
    monkeypatch.setattr(promp.live.cli, "time", clock)
    made = instances_made(monkeypatch, promp.live.session, "LiveSession")
    lines_made: list = []  # the command's status lines: its report loop is running
    rates: list = []  # each line's (predictions, rate, the command's clock)
    real_line = status_line_module.status_line

    def line(snap, rate):
        lines_made.append(snap)
        rates.append((snap.predictions, rate, clock.now))
        return real_line(snap, rate)

    monkeypatch.setattr(status_line_module, "status_line", line)

    def feed() -> None:
        wait_until(lambda: lines_made, what="the command's first status line")
        assert len(transport.opened) == 2
        times = transport.now + 0.1 + demo.times - demo.times[0]
        rest = times[-1] + 0.02 * np.arange(1, 26)  # half a second still after the end
        half = times.size // 2  # two bursts: two predictions at least
        transport.now = times[half] + 0.01
        cue.push([times[0]], ["start right"])
        hand.push(times[:half], values[:half])
        wait_until(lambda: made[0].snapshot().predictions, what="a prediction of the start")
        transport.now = rest[-1] + 0.01
        hand.push(np.concatenate([times[half:], rest]),
                  np.vstack([values[half:]] + [values[-1:]] * 25))  # fmt: skip
        cue.push([times[-1]], ["end right"])
        wait_until(lambda: list(record.glob("right/*.csv")), what="the recorded movement")
        seen = len(lines_made)
        wait_until(lambda: len(lines_made) >= seen + 2, what="two status lines after it")
        if running:  # Ctrl-C for the command, never for pytest once the command has ended
            os.kill(os.getpid(), signal.SIGINT)

    handlers = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    running = [True]
    feeder = threading.Thread(target=feed, daemon=True)
    feeder.start()
    out = Flushed()
    monkeypatch.setattr(sys, "stdout", out)
    began = clock.now
    try:
        code = main(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                     "--out", "robot", "--start", "marker", "--markers", "Cues",
                     "--record", str(record), "--status-every", "0.05", "--wait", "600"])
    finally:
        running.clear()
        signal.signal(signal.SIGINT, handlers[0])
        signal.signal(signal.SIGTERM, handlers[1])
    feeder.join(timeout=60.0)
    assert code == 0
    lines = out.lines()
    summary = json.loads(lines[-1])
    # the status lines: a rate of the predictions since the last line (0 when none)
    last_count, last_time = 0, began
    for count, rate, now in rates:
        assert now - last_time >= 0.05 and rate == (count - last_count) / (now - last_time)
        last_count, last_time = count, now
    assert any(r > 0 for _, r, _ in rates) and any(r == 0 for _, r, _ in rates)
    assert 0 < summary["seconds"] == round(summary["seconds"], 3) <= round(clock.now - began, 3)
    assert summary["seconds"] >= rates[-1][2] - rates[0][2]
    ms = np.array(made[0].compute_s) * 1000.0
    assert ms.size == summary["predictions"] >= 2
    assert summary["infer_ms_p50"] == round(float(np.percentile(ms, 50)), 2)
    assert summary["infer_ms_p99"] == round(float(np.percentile(ms, 99)), 2)
    assert summary["movements"] == 1
    assert summary["received"]["Hand"] == demo.n_samples + 25
    assert summary["left_out"]["Hand"] == 0
    pushed = transport.outlets["robot-probabilities"].pushed
    assert summary["predictions"] == len(pushed) >= 2
    assert 0 < summary["infer_ms_p50"] <= summary["infer_ms_p99"]
    assert sum(line.startswith("found ") for line in lines) == 2
    assert sum("predictions/s" in line for line in lines) == len(lines_made)
    # each event once, as the events outlet carried it (time to the millisecond, text)
    published = [f"{stamp:.3f} {row[0]}" for row, stamp in transport.outlets["robot-events"].pushed]
    printed = [line for line in lines if re.match(r"\d+\.\d{3} ", line)]
    assert len(printed) >= 3 and printed == published[:len(printed)]
    (take,) = record.glob("right/*.csv")
    assert abs(read_csv_demo(take).n_samples - demo.n_samples) <= 1  # the marked rows
    assert (record / ".journals" / "old.journal").exists()
    said = [line for line in lines if str(record / ".journals" / "old.journal") in line]
    assert len(said) == 1 and said[0] not in printed  # the unreadable journal, named once
    assert sum(str(record / "recovered" / "take-9.csv") in line for line in lines) == 1
    assert read_csv_demo(record / "recovered" / "take-9.csv").n_samples == 7
    assert not (record / ".journals" / "live-1.journal").exists()


def test_the_options_parse_to_their_types_and_defaults_and_three_are_required(capsys) -> None:
    from pathlib import Path

    from promp.live.predictor import REMAINDER_HZ
    from promp.live.segmenter import MAX_MOVEMENT_S

    needed = ["--model", "m.json", "--in", "hand=H:0,1,2", "--in", "head=G:0,1,2", "--out", "r"]
    args = parser().parse_args(needed)
    assert args.model == Path("m.json") and args.inputs == ["hand=H:0,1,2", "head=G:0,1,2"]
    assert (args.out, args.remainder, args.rate, args.start, args.markers) == (
        "r", None, REMAINDER_HZ, "still", "", )  # fmt: skip
    assert (args.alpha_method, args.time_base, args.max_movement, args.decide) == (
        "ml", None, MAX_MOVEMENT_S, False)  # fmt: skip
    assert (args.decide_threshold, args.decide_window, args.record, args.lsl_config) == (
        None, None, None, None)  # fmt: skip
    assert (args.wait, args.status_every) == (30.0, 1.0)  # the defaults --help states
    given = parser().parse_args(needed + [
        "--rate", "25", "--time-base", "100", "--max-movement", "4", "--decide",
        "--decide-threshold", "0.8", "--decide-window", "0.2", "--wait", "5",
        "--status-every", "0.5", "--record", "takes", "--lsl-config", "lsl.cfg",
        "--start", "marker", "--markers", "Cues", "--alpha-method", "model",
        "--remainder", "hand"])  # fmt: skip
    assert (given.rate, given.time_base, given.max_movement, given.decide_threshold,
            given.decide_window, given.wait, given.status_every) == (
        25.0, 100.0, 4.0, 0.8, 0.2, 5.0, 0.5)  # fmt: skip
    assert all(type(v) is float for v in (given.rate, given.time_base, given.max_movement,
                                          given.decide_threshold, given.decide_window,
                                          given.wait, given.status_every))  # fmt: skip
    assert given.record == Path("takes") and given.lsl_config == Path("lsl.cfg")
    assert (given.start, given.markers, given.alpha_method, given.remainder, given.decide) == (
        "marker", "Cues", "model", "hand", True)  # fmt: skip
    assert (given.session, given.replay, given.fast, given.rerun, given.mcap) == (
        None, None, False, None, None)  # fmt: skip
    with pytest.raises(SystemExit):  # the model, always
        parser().parse_args(needed[2:])
    for left_out in ("--in", "--out"):  # the inputs and the outputs, unless --replay
        i = needed.index(left_out)
        rest = needed[:i] + needed[i + 2:]
        if left_out == "--in":
            rest = [a for a in rest if not a.startswith(("hand=", "head=")) and a != "--in"]
        assert main(rest) == 2
        assert "--in and --out are required" in capsys.readouterr().err
    chosen = parser().parse_args(needed + ["--start", "still", "--alpha-method", "ml"])
    assert (chosen.start, chosen.alpha_method) == ("still", "ml")  # the defaults, given
    for bad in (["--start", "call"], ["--alpha-method", "mean"], ["--rate", "fast"]):
        with pytest.raises(SystemExit):
            parser().parse_args(needed + bad)


class Command:
    """``main`` in this process over the fake network ``transport``, its clock a fake one,
    each session it makes kept, ended (as by Ctrl-C) at its ``stop_after``-th status line (each
    line's rate and time kept); ``clock`` another fake clock."""

    def __init__(self, monkeypatch, transport, stop_after: int = 1, clock=None):
        import promp.live.cli
        import promp.live.session
        from promp.live import lsl
        from promp.live import status_line as status_line_module

        self.made, self.rates, self.times = [], [], []
        self.clock = FakeTime() if clock is None else clock
        monkeypatch.setattr(lsl, "LslTransport", lambda: transport)
        monkeypatch.setattr(promp.live.cli, "time", self.clock)
        made = self.made

        class Kept(promp.live.session.LiveSession):
            def __init__(self, *args, **kwargs):
                super().__init__(*args, **kwargs)
                made.append((args, kwargs, self))

        monkeypatch.setattr(promp.live.session, "LiveSession", Kept)

        def line(snap, rate):
            self.rates.append(rate)
            self.times.append(self.clock.now)
            if len(self.rates) >= stop_after:
                raise KeyboardInterrupt
            return "a status line"

        monkeypatch.setattr(status_line_module, "status_line", line)
        self.out, self.err = Flushed(), Flushed()
        monkeypatch.setattr(sys, "stdout", self.out)
        monkeypatch.setattr(sys, "stderr", self.err)

    def __call__(self, argv: list[str]) -> int:
        handlers = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
        try:
            code = main(argv)
            self.handlers = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
        finally:
            signal.signal(signal.SIGINT, handlers[0])
            signal.signal(signal.SIGTERM, handlers[1])
        return code


def test_the_command_gives_its_options_to_the_session_and_sums_up_a_quiet_run(
        tmp_path, monkeypatch) -> None:  # fmt: skip
    """Every option reaches the session (the outlets, the recorder, the commit rule, the LSL
    configuration, the session file's start); a run that saw no movement sums up to nothing."""
    import promp.live.cli
    from promp.decision import CommitRule
    from promp.live.options import LiveOptions
    from promp.live.session_file import read_session
    from tests.live_fakes import FakeStream, FakeTransport, synthetic_model

    class Ticking(FakeTransport):
        def clock(self) -> float:  # every reading a later time: which one was used shows
            self.now += 0.001
            return self.now

    transport = Ticking()
    transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    save_model(tmp_path / "model.json", synthetic_model())
    config = tmp_path / "lsl.cfg"
    config.write_text("[ports]\n")
    monkeypatch.setenv("LSLAPICFG", "unchanged")
    command = Command(monkeypatch, transport, stop_after=3)
    code = command(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                    "--out", "robot", "--remainder", "head", "--rate", "25", "--time-base",
                    "100", "--max-movement", "4", "--decide", "--decide-threshold", "0.8",
                    "--decide-window", "0.2", "--alpha-method", "model", "--record",
                    str(tmp_path / "takes"), "--lsl-config", str(config), "--wait", "600",
                    "--status-every", "0.01", "--session", str(tmp_path / "s.mcap"),
                    "--processes", "2"])
    assert code == 0
    assert command.handlers == (promp.live.cli._interrupt, promp.live.cli._interrupt)
    assert os.environ["LSLAPICFG"] == str(config.resolve())
    ((args, kwargs, session),) = command.made
    assert args[3] == LiveOptions(start="still", markers="", alpha_method="model",
                                  remainder="head", remainder_rate=25.0, rate=100.0,
                                  max_movement_s=4.0, decide=CommitRule(0.8, 0.2),
                                  helper=True)  # fmt: skip
    assert sorted(transport.outlets) == ["robot-events", "robot-probabilities",
                                         "robot-remainder", "robot-timing"]  # fmt: skip
    recorder = kwargs["recorder"]
    assert recorder.folder == tmp_path / "takes" / ".journals"
    assert re.fullmatch(r"live-\d{8}-\d{6}", recorder.prefix)
    header = read_session(tmp_path / "s.mcap").header
    assert header["start"] == session.state.newest["hand"]  # the session's own start
    assert sum(str(tmp_path / "s.mcap") in line for line in command.out.lines()) == 1
    assert command.rates == [0.0, 0.0, 0.0]
    summary = json.loads(command.out.lines()[-1])
    assert summary["movements"] == summary["predictions"] == 0
    assert summary["received"] == summary["left_out"] == {"Hand": 0}
    assert "infer_ms_p50" not in summary and 0 < summary["seconds"] < 1.0
    with pytest.raises(KeyboardInterrupt):
        promp.live.cli._interrupt(signal.SIGTERM, None)


def test_the_command_names_the_streams_it_could_not_find_and_closes_its_session(
        tmp_path, monkeypatch) -> None:  # fmt: skip
    from tests.live_fakes import FakeStream, FakeTransport, synthetic_model

    transport = FakeTransport()
    others = [transport.add(FakeStream(n, ("a", "b", "c"), rate=50.0)) for n in ("Eyes", "Gaze")]
    save_model(tmp_path / "model.json", synthetic_model())
    command = Command(monkeypatch, transport)
    code = command(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                    "--in", "head=Tracker:0,1,2", "--out", "robot", "--wait", "2"])
    assert code == 2 and command.rates == []
    err = " ".join(command.err.lines())
    for name in ("Hand", "Tracker", *(s.description.summary() for s in others)):
        assert name in err
    assert command.clock.now >= 5002.0  # it waited --wait seconds on its clock
    ((_, _, session),) = command.made
    assert not any(t.is_alive() for t in session._threads._threads)  # closed
    none_found = Command(monkeypatch, FakeTransport())
    assert none_found(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                       "--out", "robot", "--wait", "0"]) == 2
    assert "Hand" in " ".join(none_found.err.lines())
    assert none_found.clock.now == 5000.0  # --wait 0: one look, no wait


class Counting(FakeTime):
    """The command's ``time`` for a replay: ``monotonic`` a clock each reading of which is
    1.23456 s after the last (a replay's seconds are its two readings' difference)."""

    def monotonic(self) -> float:
        self.now += 1.23456
        return self.now


@pytest.fixture(scope="module")
def session_file(tmp_path_factory):
    """One unseen movement (Begin / End) recorded to a session file by a session on the fake
    network; its model's file beside it; the predictions and events the session gave."""
    from promp.io import load_model
    from promp.live.options import LiveOptions
    from promp.live.session_file import SessionSink
    from tests.live_fakes import FakeTransport, Tap, begun_and_ended, synthetic_model

    folder = tmp_path_factory.mktemp("replayed")
    save_model(folder / "model.json", synthetic_model())
    model = load_model(folder / "model.json")  # as the command loads it
    transport, options = FakeTransport(), LiveOptions(start="call", remainder="hand")
    start = transport.clock()
    tap = Tap()
    sink = SessionSink(folder / "session.mcap", model, ["hand=Hand:0,1,2"], options, start)
    begun_and_ended(model, options, ("right",), transport=transport, sinks=[sink, tap],
                    now=start).session.close()  # fmt: skip
    return folder, [p for o in tap.outputs for p in o.predictions], \
        [e for o in tap.outputs for e in o.events]  # fmt: skip


def replaying(monkeypatch) -> list[dict]:
    """The calls of the command to the replay (its keywords), each made with no real wait."""
    from promp.live import session_file

    calls, real = [], session_file.replay_session

    def spy(model, path, **kwargs):
        calls.append(kwargs)
        return real(model, path, **kwargs, sleep=lambda seconds: None)

    monkeypatch.setattr(session_file, "replay_session", spy)
    return calls


def test_the_command_replays_a_session_file_into_viewer_files_and_sums_it_up(
        session_file, tmp_path, monkeypatch) -> None:  # fmt: skip
    """``--replay FILE --model M --fast --rerun --mcap``: exit 0, every recorded prediction
    given again, each event printed as recorded, the replay kept in both viewer files, and
    the summary's counts and seconds (the command's clock)."""
    import promp.live.cli
    from tests.live_fakes import synthetic_model
    from tests.viewer_readers import json_series, read_mcap, read_rrd

    pytest.importorskip("rerun")
    pytest.importorskip("foxglove")
    folder, predictions, events = session_file
    calls = replaying(monkeypatch)
    monkeypatch.setattr(promp.live.cli, "time", Counting())
    out = Flushed()
    monkeypatch.setattr(sys, "stdout", out)
    rrd, mcap = tmp_path / "kept.rrd", tmp_path / "kept.mcap"
    assert main(["--replay", str(folder / "session.mcap"), "--model", str(folder / "model.json"),
                 "--fast", "--rerun", str(rrd), "--mcap", str(mcap)]) == 0  # fmt: skip
    assert [set(c) for c in calls] == [{"paced", "on_output"}] and calls[0]["paced"] is False
    lines = out.lines()
    summary = json.loads(lines[-1])
    assert len(predictions) >= 2 and events
    assert summary == {"steps": summary["steps"], "predictions": len(predictions),
                       "recorded_predictions": len(predictions), "equal": True,
                       "difference": "", "inputs": ["hand"], "seconds": 1.235}  # fmt: skip
    assert summary["steps"] > len(predictions)
    assert lines[:-1] == [f"{e.time:.3f} {e.text}" for e in events]
    messages, _ = read_mcap(mcap)
    name = synthetic_model().primitives[0].name
    _, p0 = json_series(messages, f"/predictions/probability/{name}", "lsl_time")
    np.testing.assert_array_equal(p0, [p.probabilities[0] for p in predictions])
    assert sorted(m.message.message for m in messages if m.topic == "/events") == \
        sorted(e.text for e in events)  # fmt: skip
    assert len(read_rrd(rrd)[f"predictions/probability/{name}"].rows) == len(predictions)


def test_the_command_replays_at_the_recorded_timing_unless_fast(session_file, monkeypatch,
                                                                capsys) -> None:  # fmt: skip
    folder, _, _ = session_file
    calls = replaying(monkeypatch)
    assert main(["--replay", str(folder / "session.mcap"), "--model",
                 str(folder / "model.json")]) == 0  # fmt: skip
    assert calls[0]["paced"] is True
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["equal"] is True


def test_a_replay_that_differs_exits_1_and_one_that_cannot_be_made_2(
        session_file, tmp_path, capsys) -> None:  # fmt: skip
    from tests.live_fakes import one_ulp_changed

    folder, predictions, _ = session_file
    model = str(folder / "model.json")
    changed = tmp_path / "changed.mcap"
    one_ulp_changed(folder / "session.mcap", changed)
    assert main(["--replay", str(changed), "--model", model, "--fast"]) == 1
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["equal"] is False and "phase" in summary["difference"]
    assert summary["predictions"] == summary["recorded_predictions"] == len(predictions)
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file")
    assert main(["--replay", str(junk), "--model", model, "--fast"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and str(junk) in captured.err
    other = tmp_path / "other.json"  # refused by the replay itself: the file's own model's hash
    changed_model = json.loads((folder / "model.json").read_text())
    changed_model["primitives"][0]["mean"][0] += 1e-3
    other.write_text(json.dumps(changed_model))
    assert main(["--replay", str(folder / "session.mcap"), "--model", str(other)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and str(folder / "session.mcap") in captured.err


def test_the_command_recovers_the_session_journals_a_kill_left_and_names_each(
        tmp_path, monkeypatch) -> None:  # fmt: skip
    """``--session FOLDER/NEW.mcap``: a journal a kill left in FOLDER/.sessions is made into
    FOLDER/recovered/, one that cannot be read is left; a line names each."""
    from promp.live.options import LiveOptions
    from promp.live.session_file import SessionSink, read_session
    from tests.live_fakes import FakeStream, FakeTransport, synthetic_model

    save_model(tmp_path / "model.json", synthetic_model())
    killed = SessionSink(tmp_path / "old.mcap", synthetic_model(), ["hand=Hand:0,1,2"],
                         LiveOptions(), 3.0)  # never closed: its journal is left  # fmt: skip
    bad = killed.journal.with_name("bad.journal")
    bad.write_text("not a journal")
    transport = FakeTransport()
    transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    command = Command(monkeypatch, transport)
    assert command(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                    "--out", "robot", "--wait", "600", "--session",
                    str(tmp_path / "new.mcap")]) == 0  # fmt: skip
    recovered = tmp_path / "recovered" / "old.mcap"
    assert read_session(recovered).header["start"] == 3.0 and bad.exists()
    lines = command.out.lines()
    assert sum(str(recovered) in line for line in lines) == 1
    assert sum(str(bad) in line for line in lines) == 1
    assert not killed.journal.exists() and (tmp_path / "new.mcap").exists()


def test_a_viewer_file_of_another_suffix_is_refused_before_a_session_starts(
        tmp_path, monkeypatch) -> None:  # fmt: skip
    from tests.live_fakes import FakeTransport, synthetic_model

    save_model(tmp_path / "model.json", synthetic_model())
    for option, name in (("--mcap", "kept.rrd"), ("--rerun", "kept.mcap"),
                         ("--session", "kept.rrd")):  # fmt: skip
        command = Command(monkeypatch, FakeTransport())
        assert command(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                        "--out", "robot", "--wait", "600", option,
                        str(tmp_path / name)]) == 2  # fmt: skip
        assert command.made == [] and str(tmp_path / name) in " ".join(command.err.lines())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]


class Stepping(FakeTime):
    """A fake clock whose every sleep is 1/16 s (binary: sums of it are exact); Ctrl-C for
    the command at a sleep once ``until()`` is true."""

    def __init__(self, until=lambda: False):
        super().__init__()
        self.until = until

    def sleep(self, seconds: float) -> None:
        if self.until():
            raise KeyboardInterrupt
        self.now += 0.0625
        time.sleep(0.001)


@pytest.mark.parametrize("every", [0.125, 0.0])
def test_a_status_line_comes_every_status_every_seconds_and_none_with_0(
        tmp_path, monkeypatch, every) -> None:  # fmt: skip
    """The status lines of ``--status-every S`` are S apart on the command's clock (the run
    ended at the 12th), none at 0 (the run ended 2 s after its streams were found)."""
    from tests.live_fakes import FakeStream, FakeTransport, synthetic_model

    save_model(tmp_path / "model.json", synthetic_model())
    transport = FakeTransport()
    transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    found: list = []

    def two_seconds_after_found() -> bool:
        if not found and command.made and command.made[0][2].snapshot().found:
            found.append(clock.now)
        return bool(found) and clock.now >= found[0] + 2.0

    clock = Stepping(two_seconds_after_found)
    command = Command(monkeypatch, transport, stop_after=12, clock=clock)
    assert command(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                    "--out", "robot", "--wait", "600", "--status-every", str(every)]) == 0
    assert json.loads(command.out.lines()[-1])["predictions"] == 0
    if every == 0:
        assert found and command.times == []
    else:
        assert len(command.times) == 12 and set(np.diff(command.times)) == {every}


def test_the_missing_streams_and_those_found_are_listed_apart() -> None:
    from types import SimpleNamespace as Fake

    from promp.live.cli import _missing_message

    def message(found: list[str]) -> str:
        statuses = [Fake(stream="Hand", detail="not found", healthy=False),
                    Fake(stream="Head", detail="refused", healthy=False),
                    Fake(stream="Eyes", detail="ok", healthy=True)]  # fmt: skip
        snap = Fake(statuses=statuses, found=[Fake(summary=lambda n=n: n) for n in found])
        return _missing_message(Fake(snapshot=lambda: snap))

    text = message(["'Eyes' (3 ch)", "'Gaze' (2 ch)"])
    assert "Hand (not found), Head (refused) " in text and "Eyes (ok)" not in text
    assert text.endswith(" 'Eyes' (3 ch); 'Gaze' (2 ch)")
    assert message([]).endswith(" none")


def test_streams_found_by_the_end_of_the_wait_count(tmp_path, monkeypatch) -> None:
    """``--wait 0`` with every input's stream found as the wait begins: the run goes on (the
    wait looks once more at its end; it said them missing before), its first status line at
    the report's first turn."""
    import promp.live.session
    from promp.live.status import Condition
    from tests.conftest import wait_until
    from tests.live_fakes import FakeStream, FakeTransport, synthetic_model

    save_model(tmp_path / "model.json", synthetic_model())
    transport = FakeTransport()
    transport.add(FakeStream("Hand", ("x", "y", "z"), rate=50.0))
    clock = FakeTime()
    clock.now = 0.0  # the command's clock at 0 as it starts: its first status line at once
    command = Command(monkeypatch, transport, clock=clock)
    start = promp.live.session.LiveSession.start  # the command's (kept) sessions

    def start_and_find(session) -> None:
        start(session)
        wait_until(lambda: all(s.condition is not Condition.WAITING
                               for s in session.snapshot().statuses),
                   what="the stream found")  # fmt: skip

    monkeypatch.setattr(promp.live.session.LiveSession, "start", start_and_find)
    assert command(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                    "--out", "robot", "--wait", "0", "--status-every", "0.05"]) == 0
    assert command.rates == [0.0] and command.err.lines() == []
    assert command.times == [0.05 + 0.000123]  # the report's first sleep, no wait before
    assert json.loads(command.out.lines()[-1])["seconds"] == 0.05  # 0.050123 s, to the ms


def test_an_lsl_configuration_that_is_not_a_file_is_refused_before_anything(
        tmp_path, monkeypatch) -> None:  # fmt: skip
    from tests.live_fakes import FakeTransport, synthetic_model

    save_model(tmp_path / "model.json", synthetic_model())
    monkeypatch.setenv("LSLAPICFG", "unchanged")
    for missing in (tmp_path / "none.cfg", tmp_path):  # nothing there, a folder
        command = Command(monkeypatch, FakeTransport())
        assert command(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                        "--out", "robot", "--lsl-config", str(missing)]) == 2
        assert command.made == [] and str(missing) in " ".join(command.err.lines())
        assert os.environ["LSLAPICFG"] == "unchanged"


def test_where_the_lsl_transport_cannot_be_imported_its_reason_is_said(
        tmp_path, monkeypatch) -> None:  # fmt: skip
    """(liblsl missing: :mod:`promp.live.lsl` raises ImportError saying what to do.)"""
    import types

    from tests.live_fakes import synthetic_model

    class Unloadable(types.ModuleType):
        def __getattr__(self, name):
            if name.startswith("__"):  # the import system's questions
                raise AttributeError(name)
            raise ImportError(f"no liblsl here, asked for {name}")

    save_model(tmp_path / "model.json", synthetic_model())
    monkeypatch.setitem(sys.modules, "promp.live.lsl", Unloadable("promp.live.lsl"))
    err = Flushed()
    monkeypatch.setattr(sys, "stderr", err)
    assert main(["--model", str(tmp_path / "model.json"), "--in", "hand=Hand:0,1,2",
                 "--out", "robot"]) == 2
    assert "no liblsl here, asked for LslTransport" in " ".join(err.lines())
