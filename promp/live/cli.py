"""``python -m promp.live``: the headless live predictor, for the robot's computer.

Reads a model (the JSON that :func:`promp.io.save_model` and the studio's Export model write),
observes the inputs' LSL streams, finds each movement's start, predicts as the movement
happens and publishes the predictions as LSL streams (:mod:`promp.live.outlets`; docs/live.md
lists their layouts). It prints a status line every ``--status-every`` seconds and a line per
event; Ctrl-C (or SIGTERM) ends it cleanly with a last line of JSON (the counts).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from pathlib import Path

import numpy as np

from promp.decision import WINDOW_S, CommitRule
from promp.live.options import DECIDE_THRESHOLD
from promp.live.predictor import REMAINDER_HZ
from promp.live.segmenter import MAX_MOVEMENT_S

__all__ = ["decide_rule", "EXAMPLE", "main", "parser", "processes"]

EXAMPLE = (
    "example: python -m promp.live --model model.json --in hand=MocapHand:0,1,2@mm "
    "--in head=type=HeadTracker:roll,pitch,yaw@deg --out icub --remainder hand --rate 50"
)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m promp.live",
        description="Predict a partner's movement live from LSL streams and publish the "
        "prediction as LSL streams (NAME-probabilities, NAME-timing, NAME-remainder, "
        "NAME-events; see docs/live.md).",
        epilog=EXAMPLE,
    )
    p.add_argument("--model", required=True, type=Path, metavar="FILE",
                   help="the model: a JSON file written by the studio's Export model or "
                   "promp.io.save_model")
    p.add_argument("--in", dest="inputs", action="append", default=None,
                   metavar="NAME=STREAM:CHANNEL,...[@UNIT]",
                   help="an observed modality of the model and where it comes from, repeated "
                   "for each: STREAM is a stream's name, type=TYPE or source_id=ID; CHANNELs "
                   "are channel labels or indices 0,1,...; @mm, @cm and @deg are converted "
                   "to metres and radians (the channels' own units are, when the stream says "
                   "them). E.g. hand=MocapHand:0,1,2@mm")
    p.add_argument("--out", default=None, metavar="NAME",
                   help="the outputs' name: the streams NAME-probabilities, NAME-timing, "
                   "NAME-events and, with --remainder, NAME-remainder (required, as --in is, "
                   "unless --replay)")
    p.add_argument("--remainder", default=None, metavar="MODALITY",
                   help="publish the predicted remainder of this modality of the model "
                   "(observed or not), e.g. hand")
    p.add_argument("--rate", type=float, default=REMAINDER_HZ, metavar="HZ",
                   help=f"the remainder's rate (default {REMAINDER_HZ:g} Hz): one chunk per "
                   "prediction, a row every 1/HZ s to the predicted end")
    p.add_argument("--start", choices=("still", "marker"), default="still",
                   help="how a movement's start and end are found: 'still' (default) by "
                   "stillness of the inputs in metres or radians, 'marker' by a marker stream "
                   "('start [CLASS]' ... 'end [CLASS]')")
    p.add_argument("--markers", default="", metavar="STREAM",
                   help="the marker stream for --start marker (name, type=TYPE or "
                   "source_id=ID)")
    p.add_argument("--alpha-method", choices=("ml", "model"), default="ml",
                   help="how the speed is estimated (promp.recognition; default ml)")
    p.add_argument("--processes", type=int, choices=(1, 2), default=None,
                   help="2: a helper process computes part of each update's recognition "
                   "(about half the latency, the same numbers; promp.live.helper); default: 2 "
                   "when this process may run on two cores or more")
    p.add_argument("--time-base", type=float, default=None, metavar="HZ",
                   help="put the inputs on a regular time base at this rate; default: the "
                   "slowest input's own samples (the others interpolated at them)")
    p.add_argument("--max-movement", type=float, default=MAX_MOVEMENT_S, metavar="S",
                   help=f"a movement is ended after this long (default {MAX_MOVEMENT_S:g} s)")
    p.add_argument("--decide", action="store_true",
                   help="commit to a primitive in each movement (promp.CommitRule): once the "
                   "leading primitive's probability has stayed at or above --decide-threshold "
                   "for --decide-window s of the movement, say it on NAME-events and in "
                   "NAME-timing's 'committed' channel")
    p.add_argument("--decide-threshold", type=float, default=None, metavar="P",
                   help=f"with --decide, the probability to reach, in (0, 1) (default "
                   f"{DECIDE_THRESHOLD:g})")
    p.add_argument("--decide-window", type=float, default=None, metavar="S",
                   help=f"with --decide, how long it must hold, s of the movement, at least 0 "
                   f"(default {WINDOW_S:g})")
    p.add_argument("--record", type=Path, default=None, metavar="DIR",
                   help="also record each movement as a CSV demonstration in DIR/<class>/ "
                   "(the class its start marker names, else 'live'); journals in "
                   "DIR/.journals keep what a kill would lose, recovered at the next start")
    _file_arguments(p)
    p.add_argument("--wait", type=float, default=30.0, metavar="S",
                   help="how long to wait at the start for every input's stream (default 30 s;"
                   " then it stops, listing the streams found)")
    p.add_argument("--lsl-config", type=Path, default=None, metavar="FILE",
                   help="an LSL configuration file (sets LSLAPICFG; e.g. the loopback-only "
                   "tests/lsl_loopback.cfg)")
    p.add_argument("--status-every", type=float, default=1.0, metavar="S",
                   help="seconds between status lines (default 1; 0: none)")
    return p


def _file_arguments(p: argparse.ArgumentParser) -> None:
    """The files a session is kept in: viewer files, and a session file and its replay."""
    p.add_argument("--rerun", default=None, metavar="FILE.rrd",
                   help="also keep the session as a Rerun recording (a new file; the 'rerun' "
                   "extra): every movement's rows, each prediction's probabilities, phase, "
                   "time left and remainder, and the events, on LSL time; open it with: "
                   "rerun FILE.rrd")
    p.add_argument("--mcap", default=None, metavar="FILE.mcap",
                   help="the same as MCAP with Foxglove's schemas, for Foxglove, PlotJuggler "
                   "and ROS 2 tools (a new file; the 'mcap' extra)")
    p.add_argument("--session", default=None, metavar="FILE.mcap",
                   help="record the session to replay it bit for bit (a new MCAP file, made "
                   "from its journal FOLDER/.sessions/NAME.journal when the session ends; a "
                   "journal a kill left in that folder is recovered into FOLDER/recovered/)")
    p.add_argument("--replay", default=None, metavar="FILE.mcap",
                   help="replay a --session file through the predictor of --model at its "
                   "timing, and check its predictions against the recorded ones (no stream "
                   "is read or published; --rerun/--mcap keep the replay)")
    p.add_argument("--fast", action="store_true",
                   help="with --replay: as fast as it goes, not at the recorded timing")


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if args.replay is not None:
        return _replay(args)
    if not args.inputs or args.out is None:
        return _fail("--in and --out are required (unless --replay)")
    if args.lsl_config is not None:
        if not args.lsl_config.is_file():
            return _fail(f"--lsl-config: {args.lsl_config} is not a file")
        os.environ["LSLAPICFG"] = str(args.lsl_config.resolve())
    try:
        from promp.live.lsl import LslTransport
    except ImportError as exc:
        return _fail(str(exc))
    from promp.io import load_model
    from promp.live.outlets import PredictionOutlets, outlet_specs
    from promp.live.pipeline import build
    from promp.live.session import LiveOptions, LiveSession, live_columns

    try:
        rule = decide_rule(args.decide, args.decide_threshold, args.decide_window)
        model = load_model(args.model)
        options = LiveOptions(start=args.start, markers=args.markers,
                              alpha_method=args.alpha_method, remainder=args.remainder,
                              remainder_rate=args.rate, rate=args.time_base,
                              max_movement_s=args.max_movement, decide=rule,
                              helper=processes(args.processes) == 2)  # fmt: skip
        transport = LslTransport()
        specs = outlet_specs(model, args.out, args.remainder)
        build(model, args.inputs, options)  # every refusal, before anything is opened
        columns = live_columns(model, args.inputs)
        viewers = _viewer_sinks(model, args)
        start = transport.clock()
        if args.session is not None:
            viewers.append(_session_sink(model, args, options, start))
        recorder = _recorder(args.record, columns) if args.record else None
    except ValueError as exc:
        return _fail(str(exc))
    session = LiveSession(model, args.inputs, transport, options,
                          outlets=PredictionOutlets(specs, transport.outlet), recorder=recorder,
                          sinks=viewers, now=start)  # fmt: skip
    for sink in viewers:
        print(f"keeping the session as a {sink.name}: {sink.path}", flush=True)
    # Ctrl-C and a service manager's stop end it cleanly, even when started with SIGINT
    # ignored (a background job of a shell script inherits that)
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    session.start()
    started = time.monotonic()
    try:
        if not _wait_for_inputs(session, args.wait):
            return _fail(_missing_message(session), session)
        for stream in session.snapshot().found:
            print(f"found {stream.summary()}", flush=True)
        _report(session, args.status_every, started)
    except KeyboardInterrupt:
        pass
    session.close()
    snap = session.snapshot()
    movements = snap.ended[-1].number if snap.ended else 0
    summary = {"predictions": snap.predictions, "movements": movements,
               "seconds": round(time.monotonic() - started, 3),
               "received": {k: v[0] for k, v in snap.counts.items()},
               "left_out": {k: v[1] for k, v in snap.counts.items()}}  # fmt: skip
    if session.compute_s:
        ms = np.array(session.compute_s) * 1000.0
        summary["infer_ms_p50"] = round(float(np.percentile(ms, 50)), 2)
        summary["infer_ms_p99"] = round(float(np.percentile(ms, 99)), 2)
    print(json.dumps(summary), flush=True)
    return 0


def decide_rule(decide: bool, threshold: float | None, window: float | None
                ) -> CommitRule | None:  # fmt: skip
    """The commit rule of ``--decide`` (None without it), its defaults filled in.

    Raises
    ------
    ValueError
        A threshold outside (0, 1), a window that is negative or not finite, or either without
        ``--decide``.
    """
    if not decide:
        if threshold is not None or window is not None:
            raise ValueError("--decide-threshold and --decide-window need --decide")
        return None
    threshold = DECIDE_THRESHOLD if threshold is None else float(threshold)
    if not 0.0 < threshold < 1.0:  # the rule takes 1, but a posterior may never reach it
        raise ValueError(f"--decide-threshold is a probability in (0, 1), got {threshold:g}")
    try:
        return CommitRule(threshold, WINDOW_S if window is None else window)
    except ValueError as exc:
        raise ValueError(f"--decide-window: {exc}") from None


def processes(asked: int | None) -> int:
    """The processes an update is computed in: ``asked``, or 2 when this process may run on
    two cores or more (1 on one core: a helper would only take turns with it)."""
    if asked is not None:
        return asked
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # (not Linux)
        cores = os.cpu_count() or 1
    return 2 if cores >= 2 else 1


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _fail(message: str, session=None) -> int:
    if session is not None:
        session.close()
    print(f"error: {message}", file=sys.stderr, flush=True)
    return 2


def _recorder(folder: Path, columns: tuple[str, ...]):
    from promp.datasets import write_csv_demo
    from promp.live.recorder import Recorder, free_path, recover

    for path, demo in recover(folder / ".journals"):
        if isinstance(demo, str):
            print(f"a journal left by a kill cannot be read: {demo}", flush=True)
            continue
        target = free_path(folder / "recovered" / f"{demo.name}.csv")
        write_csv_demo(target, demo)
        path.unlink()
        print(f"recovered {demo.n_samples} samples of an interrupted recording: {target}",
              flush=True)  # fmt: skip
    prefix = time.strftime("live-%Y%m%d-%H%M%S")
    return Recorder(folder / ".journals", columns, prefix, output=folder)


def _viewer_sinks(model, args) -> list:
    """The ``--rerun`` and ``--mcap`` sinks (:mod:`promp.live.viewer_sink`), both checked
    before either file is made.

    Raises
    ------
    ValueError
        A file that exists or has another suffix, a missing extra.
    """
    from promp.live.options import live_inputs
    from promp.live.viewer_sink import ViewerSink
    from promp.viewers.formats import writer_for
    from promp.viewers.new_file import check_new

    asked = [(path, suffix) for path, suffix in ((args.rerun, ".rrd"), (args.mcap, ".mcap"))
             if path is not None]  # fmt: skip
    for path, suffix in asked:
        check_new(path, suffix)
        writer_for(suffix)
    inputs = live_inputs(model, args.inputs)
    return [ViewerSink(path, model, inputs) for path, _ in asked]


def _session_sink(model, args, options, start: float):
    """``--session``: the journals a kill left in its folder recovered, then its sink."""
    from promp.live.session_file import SessionSink, recover_sessions
    from promp.viewers.new_file import check_new

    path = check_new(args.session, ".mcap")
    for journal, got in recover_sessions(path.parent):
        if isinstance(got, str):
            print(f"a session journal left by a kill cannot be read: {journal}: {got}",
                  flush=True)  # fmt: skip
        else:
            print(f"recovered an interrupted session: {got}", flush=True)
    return SessionSink(path, model, args.inputs, options, start)


def _replay(args) -> int:
    """``--replay FILE --model M``: the summary as the last line (JSON); 0 when every
    prediction is the recorded one, 1 when one differs, 2 when it cannot be replayed."""
    from promp.io import load_model
    from promp.live.options import live_inputs
    from promp.live.session_file import read_session, replay_session

    try:
        model = load_model(args.model)
        header = read_session(args.replay).header
        inputs = live_inputs(model, header["inputs"])
        args.inputs = header["inputs"]
        viewers = _viewer_sinks(model, args)
    except ValueError as exc:
        return _fail(str(exc))

    def deliver(output) -> None:
        for sink in viewers:
            part = sink.view(output)
            if part is not None:
                sink.take(part)

    started = time.monotonic()
    try:
        replayed = replay_session(model, args.replay, paced=not args.fast, on_output=deliver)
    except ValueError as exc:
        return _fail(str(exc))
    finally:
        for sink in viewers:
            sink.close()
    for event in replayed.events:
        print(f"{event.time:.3f} {event.text}", flush=True)
    summary = {"steps": replayed.steps, "predictions": len(replayed.predictions),
               "recorded_predictions": len(replayed.recorded), "equal": replayed.equal,
               "difference": replayed.difference, "inputs": [i.name for i in inputs],
               "seconds": round(time.monotonic() - started, 3)}  # fmt: skip
    print(json.dumps(summary), flush=True)
    return 0 if replayed.equal else 1


def _wait_for_inputs(session, wait: float) -> bool:
    from promp.live.status import Condition

    deadline = time.monotonic() + wait
    while True:  # a last look at the deadline: a stream found during the last wait counts
        statuses = session.snapshot().statuses
        if all(s.condition is not Condition.WAITING for s in statuses):
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.05)


def _missing_message(session) -> str:
    snap = session.snapshot()
    waiting = [f"{s.stream} ({s.detail})" for s in snap.statuses if not s.healthy]
    found = "; ".join(d.summary() for d in snap.found) or "none"
    return f"no usable stream for {', '.join(waiting)} after --wait; streams found: {found}"


def _report(session, every: float, started: float) -> None:
    from promp.live.status_line import status_line

    shown, last_line, count = 0, 0.0, (0, time.monotonic())
    while True:
        time.sleep(0.05)
        snap = session.snapshot()
        new = snap.events[len(snap.events) - min(snap.n_events - shown, len(snap.events)):]
        for event in new:
            print(f"{event.time:.3f} {event.text}", flush=True)
        shown = snap.n_events
        now = time.monotonic()
        if every > 0 and now - last_line >= every:
            rate = (snap.predictions - count[0]) / max(now - count[1], 1e-9)
            print(status_line(snap, rate), flush=True)
            last_line, count = now, (snap.predictions, now)
