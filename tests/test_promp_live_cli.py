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
from promp.live.cli import main, parser
from tests.conftest import PATIENCE_S, REPO
from tests.live_fakes import flt_dataset, hand_model, held, instances_made

pylsl = pytest.importorskip("pylsl")

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
        timing = pylsl.StreamInlet(found[0])
        timing.open_stream(PATIENCE_S)
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
    for bad in (["--start", "call"], ["--alpha-method", "mean"], ["--rate", "fast"]):
        with pytest.raises(SystemExit):
            parser().parse_args(needed + bad)


class Command:
    """``main`` in this process over the fake network ``transport``, its clock a fake one,
    each session it makes kept, ended (as by Ctrl-C) at its ``stop_after``-th status line."""

    def __init__(self, monkeypatch, transport, stop_after: int = 1):
        import promp.live.cli
        import promp.live.session
        from promp.live import lsl
        from promp.live import status_line as status_line_module

        self.made, self.rates, self.clock = [], [], FakeTime()
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
                    "--status-every", "0.01", "--session", str(tmp_path / "s.mcap")])
    assert code == 0
    assert command.handlers == (promp.live.cli._interrupt, promp.live.cli._interrupt)
    assert os.environ["LSLAPICFG"] == str(config.resolve())
    ((args, kwargs, session),) = command.made
    assert args[3] == LiveOptions(start="still", markers="", alpha_method="model",
                                  remainder="head", remainder_rate=25.0, rate=100.0,
                                  max_movement_s=4.0, decide=CommitRule(0.8, 0.2))  # fmt: skip
    assert sorted(transport.outlets) == ["robot-events", "robot-probabilities",
                                         "robot-remainder", "robot-timing"]  # fmt: skip
    recorder = kwargs["recorder"]
    assert recorder.folder == tmp_path / "takes" / ".journals"
    assert re.fullmatch(r"live-\d{8}-\d{6}", recorder.prefix)
    header = read_session(tmp_path / "s.mcap").header
    assert header["start"] == session.state.newest["hand"]  # the session's own start
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
