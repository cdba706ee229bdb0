"""The robot takes over: the time from the sample that made the commit rule commit to the
arm's first commanded step, in the studio.

A studio (in this process, no page connected) serves a workspace of ``lab-records-flt``'s hand
(each class's demonstrations but its first two, the replayed ones); its Infer tab's Source is
*LSL streams (live)*, *Robot takes over* ticked, and its live source is started as *Start*
does with *Commit to a primitive* at the default threshold (0.9), movements by stillness. An
LSL outlet (loopback) replays the six held-out demonstrations in turn, each held still 1 s
before and after, at their own rate (100 Hz), in millimetres, every sample stamped with
``local_clock()`` when pushed, until ``--movements`` have been pushed.

Measured per movement that commits (one machine, one ``local_clock``): from the push of the
sample that made the rule commit (the committing prediction's latest observed sample,
:attr:`promp.live.commitment.Commitment.at`, matched to the pushed stamps) to the first call
of the arm's ``move_hand_to`` by the take-over (the Replay's ``move_hand``, wrapped here),
``latency_ms_p50`` and ``latency_ms_p99``, split into ``predicted_ms_*`` (from that push to
the committing prediction in the session's snapshot, when the source wakes the studio's
loop: :class:`app.live.session_outputs.CommitmentWake`) and ``loop_ms_*`` (from there to
the first step; ``in_frame_ms_*``: of which from the start of the frame that took the step);
how many movements committed and were taken over;
the load average.

Target on this 2-core machine: p99 <= 50 ms. Every LSL stream stays on the loopback
(``LSLAPICFG`` is ``tests/lsl_loopback.cfg``).

Run: ``.venv/bin/python bench/takeover.py [--movements 40]``. The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
os.environ.setdefault("LSLAPICFG", str(REPO / "tests" / "lsl_loopback.cfg"))
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402
import pylsl  # noqa: E402

DATA = REPO.parent / "shared" / "data" / "lab-records-flt"
HELD_OUT = 2  # each class's first demonstrations: replayed, not taught
REST_S = 1.0
READY_S = 900.0


def workspace(root: Path) -> dict:
    """A workspace of the set's hand without the held-out demonstrations; those, per class."""
    from app.io.dataset_import import read_folder
    from app.io.workspace import Workspace
    from promp.datasets import parse_modalities

    data, _ = read_folder(DATA, "records", parse_modalities("hand=x,y,z"))
    held = {name: demos[:HELD_OUT] for name, demos in data.demos.items()}
    data.demos = {name: demos[HELD_OUT:] for name, demos in data.demos.items()}
    data.settings = {"n_basis": 7, "width": 1.0, "noise_scale": 1.5}
    Workspace.create(root, data)
    return held


def wait(predicate, what: str, timeout: float = READY_S):
    deadline = time.monotonic() + timeout
    while not (value := predicate()):
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        time.sleep(0.05)
    return value


def main(movements: int = 40) -> dict:
    from app.io.net import free_port
    from app.live.lsl_source import LiveConfig
    from app.panels.infer import InferPanel
    from app.panels.infer.view_model import LSL
    from app.scene.look import INFER
    from app.studio import Studio
    from promp.live.status import Condition
    from tests.live_fakes import held
    from tests.lsl_push import hand_outlet, release_all

    name = f"BenchTakeOver-{os.getpid()}"
    with tempfile.TemporaryDirectory() as tmp:
        replayed = workspace(Path(tmp) / "ws")
        studio = Studio.start("127.0.0.1", free_port(), Path(tmp) / "ws")
        try:
            model = wait(lambda: studio.session.snapshot().model, "the studio's model")
            panel = next(p for p in studio.panels if isinstance(p, InferPanel))
            panel.controls.source.value = LSL
            studio.scene.use_panel(INFER)
            panel.lsl.controls.takeover.value = True
            out = hand_outlet(name)
            studio.live.watch()
            config = LiveConfig(f"hand={name}:hx,hy,hz", start="still",
                                commit=0.9)  # fmt: skip
            running = studio.live.start(model, config)
            wait(lambda: running.session.snapshot().statuses[0].condition is Condition.OK,
                 "the session to find the stream")  # fmt: skip
            replay = panel.playback.replay
            move, firsts, in_frame = replay.move_hand, {}, []

            def timed(target):
                now = pylsl.local_clock()
                started = panel.takeover.state.started
                if started is not None and started.movement not in firsts:
                    firsts[started.movement] = (now, started)
                    in_frame.append(1e3 * (time.perf_counter() - studio.loop.frame_starts[-1]))
                return move(target)

            replay.move_hand = timed
            wake, ready = studio.live.on_commitment.call, []

            def noted():  # the committing prediction is in the session's snapshot
                ready.append(pylsl.local_clock())
                wake()

            studio.live.on_commitment.call = noted
            takes = [d for k in range(HELD_OUT) for demos in replayed.values()
                     for d in demos[k:k + 1]]  # fmt: skip
            stamps, pushes = [], []
            began = time.monotonic()
            for k in range(movements):
                demo = held(takes[k % len(takes)], REST_S, REST_S)
                xyz_mm = demo.select(["x", "y", "z"]) * 1000.0
                due = pylsl.local_clock() + 0.02 + (demo.times - demo.times[0])
                for row, at in zip(xyz_mm, due, strict=True):
                    time.sleep(max(0.0, at - pylsl.local_clock()))
                    stamp = pylsl.local_clock()
                    out.push_sample(row.tolist(), stamp)
                    stamps.append(stamp)
                    pushes.append(pylsl.local_clock())
            wait(lambda: running.session.snapshot().movement is None, "the last movement's end",
                 timeout=60.0)  # fmt: skip
            replay_s = time.monotonic() - began
            ended = len(running.session.snapshot().ended)
        finally:
            studio.stop()
            release_all()  # the hand's outlet, destroyed now (promp.live.lsl's docstring)
    stamps_a, pushes_a = np.array(stamps), np.array(pushes)
    latencies, parts, unmatched = [], [], 0
    for (first, started), shown in zip(firsts.values(), ready, strict=False):
        at = started.commitment.at
        i = int(np.argmin(np.abs(stamps_a - at)))
        if abs(stamps_a[i] - at) > 1e-3:  # not a pushed sample's stamp (re-anchored clock)
            unmatched += 1
            continue
        latencies.append(1e3 * (first - pushes_a[i]))
        parts.append((1e3 * (shown - pushes_a[i]), 1e3 * (first - shown)))
    lat, parts = np.array(latencies), np.array(parts).reshape(-1, 2)

    def p(values, q):
        return round(float(np.percentile(values, q)), 1) if values.size else None

    return {
        "movements_pushed": movements,
        "movements_ended": ended,
        "taken_over": len(firsts),
        "unmatched": unmatched,
        "latency_ms_p50": round(float(np.percentile(lat, 50)), 1) if lat.size else None,
        "latency_ms_p99": round(float(np.percentile(lat, 99)), 1) if lat.size else None,
        "latency_ms_max": round(float(lat.max()), 1) if lat.size else None,
        "predicted_ms_p50": p(parts[:, 0], 50), "predicted_ms_p99": p(parts[:, 0], 99),
        "loop_ms_p50": p(parts[:, 1], 50), "loop_ms_p99": p(parts[:, 1], 99),
        "in_frame_ms_p50": p(np.array(in_frame), 50), "in_frame_ms_p99": p(np.array(in_frame), 99),
        "replay_s": round(replay_s, 1),
        "load_average": [round(x, 2) for x in os.getloadavg()],
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--movements", type=int, default=40,
                        help="how many movements are replayed (default 40)")
    args = parser.parse_args()
    print(json.dumps(main(args.movements)))
