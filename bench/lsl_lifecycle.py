"""liblsl's crash when an outlet of a process dies while another thread of the same process
opens an inlet (sccn/liblsl#220), with and without :data:`promp.live.lsl.LIFECYCLE`.

Each round runs one child process for ``--seconds``: a thread opens an inlet on every stream
it finds (open, info, clock offset, close: what the studio's scan does to describe a stream),
while the main thread makes outlets, pushes a few samples and destroys them at random moments
(what a test's sender or a session's stop does). ``raw`` uses pylsl directly and lets
``del`` destroy; ``guarded`` opens :class:`promp.live.lsl.LslInlet` (the studio's) and makes
and destroys the outlets with :func:`promp.live.lsl.new_outlet` and
:func:`~promp.live.lsl.release`. Rounds alternate the
two; ``--busy`` keeps that many cores busy meanwhile (the crash needs a loaded machine).

    .venv/bin/python bench/lsl_lifecycle.py --rounds 4 --seconds 60 --busy 2

The last line is JSON: the rounds per mode and how many died of a signal.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))  # this tree's promp, whichever is installed
CONFIG = REPO / "tests" / "lsl_loopback.cfg"
TYPE = "LifecycleBench"


def child(mode: str, seconds: float) -> None:
    """One round: the opener thread against the outlets' churn (see the module docstring)."""
    import faulthandler

    faulthandler.enable()
    import pylsl

    from promp.live.lsl import OPEN_TIMEOUT_S, LslInlet, new_outlet, release

    guarded = mode == "guarded"
    stop = threading.Event()
    opened = [0]

    def opener() -> None:
        resolver = pylsl.ContinuousResolver(prop="type", value=TYPE, forget_after=2.0)
        while not stop.is_set():
            for info in resolver.results():
                try:
                    if guarded:  # the studio's own inlet
                        LslInlet(info).close()
                    else:  # the same calls, unguarded, closed as it was closed before
                        inlet = pylsl.StreamInlet(info, max_buflen=360, recover=False)
                        inlet.open_stream(OPEN_TIMEOUT_S)
                        inlet.info(OPEN_TIMEOUT_S)
                        inlet.time_correction(OPEN_TIMEOUT_S)
                        inlet.close_stream()
                        del inlet
                except Exception:  # noqa: BLE001 (gone while opened: the race's other side)
                    continue
                opened[0] += 1

    thread = threading.Thread(target=opener, daemon=True)
    thread.start()
    end, made = time.monotonic() + seconds, 0
    while time.monotonic() < end:
        info = pylsl.StreamInfo(f"L{made % 3}", TYPE, 3, 100, pylsl.cf_double64, f"l{made % 3}")
        outlet = new_outlet(info) if guarded else pylsl.StreamOutlet(info)
        time.sleep(random.uniform(0.0, 0.3))
        for _ in range(random.randint(0, 20)):
            outlet.push_sample([1.0, 2.0, 3.0])
        if guarded:
            release(outlet)
        del outlet
        made += 1
    stop.set()
    thread.join(5.0)
    print(json.dumps({"outlets": made, "inlets_opened": opened[0]}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=4, help="rounds per mode")
    parser.add_argument("--seconds", type=float, default=60.0, help="length of a round")
    parser.add_argument("--busy", type=int, default=2, help="cores kept busy meanwhile")
    parser.add_argument("--child", choices=("raw", "guarded"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.seconds)
        return
    env = dict(os.environ, LSLAPICFG=str(CONFIG))
    spin = "while True: pass"
    busy = [subprocess.Popen([sys.executable, "-c", spin]) for _ in range(args.busy)]
    results: dict[str, list[int]] = {"raw": [], "guarded": []}
    try:
        for r in range(args.rounds):
            for mode in ("raw", "guarded") if r % 2 == 0 else ("guarded", "raw"):
                run = subprocess.run(
                    [sys.executable, __file__, "--child", mode, "--seconds", str(args.seconds)],
                    env=env, capture_output=True, text=True,
                    timeout=args.seconds * 3 + 60,
                )  # fmt: skip
                results[mode].append(run.returncode)
                tail = run.stdout.strip().splitlines()[-1:] or ["(no output)"]
                print(f"round {r + 1} {mode}: exit {run.returncode} {tail[0]}", flush=True)
    finally:
        for p in busy:
            p.kill()
    print(json.dumps({mode: {"rounds": len(codes), "crashed": sum(c < 0 for c in codes),
                             "failed": sum(c > 0 for c in codes)}
                      for mode, codes in results.items()}))  # fmt: skip


if __name__ == "__main__":
    main()
