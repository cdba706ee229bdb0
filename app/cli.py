"""Command line of the studio: ``python -m app`` or ``icub-studio``."""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

from app.net import is_loopback, port_is_free

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8080
DEFAULT_WORKSPACE = Path("workspace")


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
        help="folder holding the demonstrations and models (plain files); created if missing",
    )
    parser.add_argument(
        "--robot", default="iCubNancy01", help="robot model from the icub-models package"
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


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


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
    shown_host = "127.0.0.1" if args.host in ("0.0.0.0", "::") else args.host
    print(f"iCub intention studio running at http://{shown_host}:{studio.port}", flush=True)
    # SIGTERM (service managers, tests) stops as cleanly as Ctrl+C.
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass
    finally:
        studio.stop()
