"""What reaches a browser while the studio's frames run late: viser's message windows received
per frame, with and without each part of the loop's fix (docs/reliability.md, fourteenth
session).

A viser server on 127.0.0.1 and the studio's :class:`app.live.frame_loop.FrameLoop`, whose
frame sets a GUI number inside a message group and takes ``--frame-ms`` (50: three periods at
60 Hz, as frames on a busy machine). A bare websocket client (no rendering) counts the
message windows it receives over ``--seconds``. Four variants, one after the other in this
run:

* ``atomic``: the group as the studio held it before (``server.atomic()``), no rest after a
  late frame (the loop's ``REST_SHARE`` and ``MIN_REST_S`` set to 0);
* ``atomic+rest``: the same with the loop's rest;
* ``flush``: the group flushed when it closes (:func:`one_message_group`), no rest;
* ``flush+rest``: the studio's loop now.

``--busy N`` runs N busy loops (processes) beside it, to measure a loaded machine.

Run: ``.venv/bin/python bench/frame_sends.py [--frame-ms 50] [--seconds 3] [--busy 2]``. The
last line is one JSON object: per variant ``frames`` and ``windows`` (received), and their
ratio.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import viser  # noqa: E402
from websockets.sync.client import connect  # noqa: E402

import app.live.frame_loop as frame_loop  # noqa: E402
from app.io.net import free_port  # noqa: E402

VARIANTS = ("atomic", "atomic+rest", "flush", "flush+rest")


def _spin() -> None:
    while True:
        pass


def measure(variant: str, frame_s: float, seconds: float) -> dict:
    """Frames run and windows received over ``seconds`` with ``variant``."""
    rest = (frame_loop.REST_SHARE, frame_loop.MIN_REST_S)
    if not variant.endswith("+rest"):
        frame_loop.REST_SHARE, frame_loop.MIN_REST_S = 0.0, 0.0
    port = free_port()
    server = viser.ViserServer(host="127.0.0.1", port=port, verbose=False)
    number = server.gui.add_number("frame", initial_value=0)

    def frame() -> None:
        group = (frame_loop.one_message_group(server) if variant.startswith("flush")
                 else server.atomic())  # fmt: skip
        with group:
            number.value = loop.frames_done + 1
            time.sleep(frame_s)

    loop = frame_loop.FrameLoop(frame, lambda exc: print(f"frame failed: {exc}"))
    try:
        with connect(f"ws://127.0.0.1:{port}", subprotocols=[f"viser-v{viser.__version__}"],
                     open_timeout=30) as client:  # fmt: skip
            loop.start()
            while loop.frames_done < 1:
                time.sleep(0.01)
            first, windows, end = loop.frames_done, 0, time.monotonic() + seconds
            while time.monotonic() < end:
                try:
                    client.recv(timeout=max(end - time.monotonic(), 0.001))
                except TimeoutError:
                    break
                windows += 1
            frames = loop.frames_done - first
    finally:
        loop.stop()
        server.stop()
        frame_loop.REST_SHARE, frame_loop.MIN_REST_S = rest
    return {"frames": frames, "windows": windows, "ratio": round(windows / max(frames, 1), 3)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frame-ms", type=float, default=50.0)
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--busy", type=int, default=0, help="busy loops beside the run")
    args = parser.parse_args(argv)
    spinners = [multiprocessing.Process(target=_spin, daemon=True) for _ in range(args.busy)]
    for p in spinners:
        p.start()
    try:
        result = {v: measure(v, args.frame_ms / 1000.0, args.seconds) for v in VARIANTS}
    finally:
        for p in spinners:
            p.terminate()
    result.update(frame_ms=args.frame_ms, seconds=args.seconds, busy=args.busy,
                  load_average=[round(x, 2) for x in os.getloadavg()])  # fmt: skip
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
