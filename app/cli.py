"""Command line of the studio: ``python -m app`` or ``icub-studio``."""

from __future__ import annotations

import argparse
import signal
import socket
import sys
import time
from pathlib import Path

from app.io.net import is_loopback, port_is_free
from promp.datasets import FORMATS
from promp.progress import clock
from promp.rigs import MAPPING_HELP, add_rig_arguments
from robots.icub.model import DEFAULT_ROBOT

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8080
# In a folder of workspaces of its own (git ignores it in a clone): the workspaces a Data-tab
# import creates go beside the one served, so they land there too, never among the code.
DEFAULT_WORKSPACE = Path("workspaces/default")
HAND_FRAMES = ("recorded", "place", "own")  # --hand-frame: see placed_as_asked


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="icub-studio",
        description=(
            "The iCub intention studio: teach an iCub multi-modal movement primitives (ProMPs) "
            "in the browser and watch it predict a partner's intention."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument(
        "--host",
        default=DEFAULT_HOST,
        help="address to bind. The default only accepts this machine; any other address "
        "exposes the studio, which has no authentication, to the network",
    )
    parser.add_argument("--port", type=int, default=DEFAULT_PORT, help="TCP port to serve on")
    parser.add_argument(
        "--workspace",
        type=Path,
        default=DEFAULT_WORKSPACE,
        help="the studio's folder of demonstrations (plain files): a studio workspace, or an "
        "absent or empty folder, which is created with the simulated experiment (or with "
        "--import-dataset). Any other folder is refused untouched",
    )
    parser.add_argument(
        "--import-dataset",
        type=Path,
        default=None,
        metavar="DATASET",
        help="create the (absent or empty) --workspace from this dataset folder (or session "
        "file: a ROS bag, .xdf or .c3d), then serve it; the dataset is only read",
    )
    parser.add_argument(
        "--format",
        choices=FORMATS,
        default=None,
        help="format of --import-dataset: csv (<primitive>/<demo>.csv), records (the "
        "13-column lab records), or a rig's recordings: yarp (dataDumper folders), rosbag "
        "(ROS 1/2 bags, MCAP), xdf (LabRecorder), c3d (motion capture); default: told by "
        "the files",
    )
    parser.add_argument(
        "--modality",
        action="append",
        default=[],
        metavar="NAME=COL,COL,...",
        help="with --import-dataset, a modality and its columns (repeatable), e.g. "
        "hand=x,y,z head=roll,pitch,yaw; default: guessed from the columns (hand = x,y,z, "
        "head = roll,pitch,yaw) or the streams, and printed as --modality options to edit and "
        f"pass back; {MAPPING_HELP}",
    )
    add_rig_arguments(parser)
    parser.add_argument(
        "--hand-frame",
        choices=HAND_FRAMES,
        default="recorded",
        help="with --import-dataset, where the hand goes: recorded (as it is, in the iCub's "
        "root frame), place (moved into the iCub's reach by a shift guessed from its extent, "
        "kept in studio.json and undone on export) or own (its own frame, drawn without the "
        "robot); a hand mostly out of reach is said so",
    )
    parser.add_argument(
        "--robot", default=DEFAULT_ROBOT, help="robot model from the icub-models package"
    )
    source = parser.add_mutually_exclusive_group()
    source.add_argument(
        "--camera",
        type=int,
        default=None,
        metavar="INDEX",
        help="take the partner's head pose from this webcam (default: a simulated partner)",
    )
    source.add_argument(
        "--video",
        type=Path,
        default=None,
        metavar="FILE",
        help="take the partner's head pose from this video file",
    )
    return parser


def prepare_workspace(args: argparse.Namespace) -> None:
    """Check the --workspace folder before anything starts, and create it from
    --import-dataset when given (printing what was imported).

    Raises
    ------
    ValueError
        The folder holds something other than a studio workspace (nothing is touched), or the
        import is refused (nothing is written).
    """
    from app.io.dataset_import import detect_format, read_folder
    from app.io.workspace import FolderKind, Workspace, inspect_folder
    from promp.datasets import (
        command_line_modalities,
        format_modalities,
        modality_options,
        refused_with_guess,
    )
    from promp.rigs import rig_options

    kind, message = inspect_folder(args.workspace)
    if args.import_dataset is None:
        given = args.format is not None or args.modality or args.mapping
        given = given or args.hand_frame != "recorded"
        if given or args.cut != "auto" or args.rate is not None or args.markers:
            raise ValueError(
                "--format, --modality, --mapping, --cut, --rate, --markers and --hand-frame go "
                "with --import-dataset"
            )
        if kind is FolderKind.FOREIGN:
            raise ValueError(message)
        return
    source = args.import_dataset
    if not source.exists():
        raise ValueError(f"--import-dataset {source}: no such folder or file")
    if kind is FolderKind.WORKSPACE:
        raise ValueError(
            f"--import-dataset creates a new workspace, but {args.workspace} already is one; "
            "choose an absent or empty --workspace folder"
        )
    if kind is FolderKind.FOREIGN:
        raise ValueError(f"--import-dataset needs an absent or empty --workspace: {message}")
    new, src = args.workspace.resolve(), source.resolve()
    if new == src or src in new.parents or new in src.parents:
        raise ValueError(
            "the new workspace and the dataset must be separate folders (the dataset is only "
            "read): choose a --workspace outside it"
        )
    modalities = command_line_modalities(args.modality, args.mapping)
    format = args.format or detect_format(source)
    files = [source] if source.is_file() else [p for p in source.rglob("*") if p.is_file()]
    stage(f"Reading {source} ({format}, {len(files)} files) and checking its demonstrations...")
    start = time.monotonic()
    try:
        data, summary = read_folder(source, format, modalities, rig_options(args))
    except ValueError as exc:  # the guess to edit, when the modalities were guessed
        raise exc if modalities else refused_with_guess(exc, source, format) from None
    stage(f"Read and checked {summary.n_demos} demonstrations of {len(summary.counts)} classes "
          f"in {clock(time.monotonic() - start)}.")  # fmt: skip
    data = placed_as_asked(data, args.hand_frame)
    stage(f"Writing the workspace {args.workspace} ({data.n_demos} demonstrations)...")
    Workspace.create(args.workspace, data)
    print(f"Created the workspace {args.workspace} from {source}: {summary.describe()}", flush=True)
    if summary.mapping:  # a rig's recordings: how they were read, and what they became
        lines = (f"Mapping: {summary.mapping}", *summary.notes,
                 *summary.demonstrations_lines(limit=50))  # fmt: skip
        print("\n".join(f"  {line}" for line in lines), flush=True)
    if not modalities:
        guess = modality_options(summary.mapping or format_modalities(summary.layout))
        print(f"  The modalities were guessed; to change them, edit and pass: {guess}",
              flush=True)  # fmt: skip
    headline, *details = summary.findings_lines(limit=50)
    print("\n  ".join([headline, *details]), flush=True)


def placed_as_asked(data, hand_frame: str):
    """``data`` with its hand where ``--hand-frame`` puts it (app.io.hand_frame), saying where
    and how much of its path the iCub reaches."""
    from app.io.dataset_import import placed
    from app.io.hand_frame import HandFrame, hand_points, placement_text, reach_sentence
    from robots.icub.placement import IN_REACH, guess_placement, reach_share

    points = hand_points(data.demos, data.layout)
    if not points.shape[0]:
        return placed(data, HandFrame())
    if hand_frame == "own":
        stage("The hand stays in its own frame: drawn where it is, without the robot.")
        return placed(data, HandFrame(own=True))
    if hand_frame == "place":
        frame = HandFrame(guess_placement(points))
        share = reach_share(frame.placement.apply(points))
        stage(
            f"Placed the hand in the iCub's frame ({placement_text(frame.placement)}): "
            f"{share * 100:.0f} % within reach; an export gives it back as recorded."
        )
        return placed(data, frame)
    share = reach_share(points)
    if share < IN_REACH:
        stage(f"{reach_sentence(share)} Import it with --hand-frame place (moved into reach) "
              "or --hand-frame own (without the robot).")  # fmt: skip
    return placed(data, HandFrame())


def stage(text: str) -> None:
    """One stage of a long start, on stdout at once (a log shows where it is)."""
    print(text, flush=True)


def report_first_fit(session, every_s: float = 5.0) -> None:
    """Wait for the workspace's first model, saying what is fitted and for how long (a line
    every ``every_s`` seconds), then how it went."""
    store = session.store.state
    n_demos = sum(len(d) for d in store.learned.values())
    stage(f"Fitting the model of {len(store.primitives)} primitives to {n_demos} "
          "demonstrations...")  # fmt: skip
    start = told = time.monotonic()
    while session.snapshot().refitting:
        time.sleep(0.1)
        if time.monotonic() - told >= every_s:
            told = time.monotonic()
            stage(f"  fitting: {clock(told - start)} elapsed")
    learner, took = session.learner.state, clock(time.monotonic() - start)
    if learner.model is None:
        stage(f"Not learned ({learner.error}) after {took}; the studio shows why.")
    else:
        stage(f"Fitted in {took}: {len(learner.model.names)} primitives from "
              f"{learner.n_demos} demonstrations.")  # fmt: skip


class StopSignals:
    """Waits for SIGINT (Ctrl+C) or SIGTERM (a service manager's stop); build it in the main
    thread.

    The kernel hands a signal sent to the process to any thread that does not block it: one of
    viser's, the studio's or the BLAS library's. Python then runs the handler only when the main
    thread next runs Python code, and a main thread asleep in ``time.sleep`` slept on through
    a SIGTERM (seen under load: the studio did not stop in 30 s). The C-level handler, though,
    writes the signal's number to the wakeup file descriptor at once, on whichever thread took
    the signal, and :meth:`wait` reads it.
    """

    def __init__(self) -> None:
        self._receiver, self._sender = socket.socketpair()
        self._sender.setblocking(False)
        signal.set_wakeup_fd(self._sender.fileno(), warn_on_full_buffer=False)
        for number in (signal.SIGINT, signal.SIGTERM):
            signal.signal(number, lambda signum, frame: None)  # the wakeup byte does the work

    def wait(self) -> int:
        """Block until a stop signal arrives; its number."""
        return self._receiver.recv(1)[0]


def main(argv: list[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    if not is_loopback(args.host):
        print(
            f"WARNING: binding {args.host}: anyone who can reach this address can use the studio "
            "and change the workspace (viser has no authentication). Use --host 127.0.0.1 to "
            "keep it on this machine.",
            file=sys.stderr,
        )
    if not 0 < args.port < 65536:
        sys.exit(f"error: --port must be between 1 and 65535, got {args.port}")
    if not port_is_free(args.host, args.port):
        sys.exit(
            f"error: port {args.port} on {args.host} is already in use; "
            "stop the other program or choose another --port"
        )

    try:
        prepare_workspace(args)
    except ValueError as exc:
        sys.exit(f"error: {exc}")

    if args.import_dataset is not None:
        stage("Starting the studio (the robot's model, the workspace)...")
    from app.studio import Studio  # heavy imports after the argument checks

    try:
        studio = Studio.start(
            host=args.host,
            port=args.port,
            workspace=args.workspace,
            robot=args.robot,
            camera=args.camera,
            video=args.video,
        )
    except ValueError as exc:
        sys.exit(f"error: {exc}")
    try:
        if args.import_dataset is not None:  # the stages of a long start, as they go
            report_first_fit(studio.session)
        stop = StopSignals()
        shown_host = "127.0.0.1" if args.host in ("0.0.0.0", "::") else args.host
        print(f"iCub intention studio running at http://{shown_host}:{studio.port}", flush=True)
        stop.wait()
    finally:
        studio.stop()
