"""The studio's loop while a take is recorded, saved, scored and learned from: the gaps between
its frames.

The studio runs as ``make run`` starts it (its loop at 60 Hz, every panel built, the Infer tab
showing a held-out test demonstration) on a temporary workspace filled with the default
scenario (2 x 20 simulated demonstrations: a take of a primitive is scored against its 20
others, 21 fits, and the workspace refitted from 41). Each take is what a user does: Record
(no countdown), the hand dragged along a demonstration for two seconds (the gizmo's latest
pose handed to the arm at 50 Hz, as the browser's drag does; the loop solves the IK), Stop;
the studio then saves the take (a worker), the learner scores its typicality, refits the
workspace and fits the Infer tab's held-out model again (its worker), and every frame meanwhile
shows the latest state (the Teach tab in use: the Infer tab leaves its new view for when it is
shown). The loop's frame start times (:attr:`app.live.frame_loop.FrameLoop.frame_starts`) are
collected from Record until all of that is done and drawn; the gaps between consecutive frames
are what the user sees as the hand, the IK and the scene freezing (a 60 Hz loop: 16.7 ms).
Target: no gap over 50 ms.

Run: ``.venv/bin/python bench/frames.py [--takes 3]``. The last line is one JSON object with
the max and the p99 gap.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from app.io.net import free_port  # noqa: E402
from app.live.take_controller import Phase  # noqa: E402
from app.panels.infer import InferPanel  # noqa: E402
from app.panels.teach import TeachPanel  # noqa: E402
from app.studio import Studio  # noqa: E402

TARGET_MS = 50.0
DRAG_S = 2.0


def wait(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        time.sleep(0.005)


def settled(studio: Studio, infer: InferPanel) -> bool:
    """The take's consequences all learned: scored, refitted, the Infer tab's held-out model
    of the current workspace fitted (and a view shown)."""
    snapshot = studio.session.snapshot()
    version = snapshot.store.learn_version
    return (
        not snapshot.scoring
        and not snapshot.refitting
        and any(key[0] == version for key in snapshot.learner.held_out)
        and infer.view is not None
        and infer.view.result is not None
    )


def one_take(studio: Studio, teach: TeachPanel, infer: InferPanel, k: int) -> list[float]:
    """Record, drag, stop; the frame start times from Record until everything is shown."""
    demo = studio.session.store.state.demos["curved"][k % 20]
    hand = demo.select(("x", "y", "z"))
    studio.loop.call(lambda: studio.arm.move_hand_to(hand[0]))  # before the take
    wait(lambda: np.linalg.norm(studio.arm.hand_position() - hand[0]) < 0.01, 30.0, "the start")
    wxyz = np.array(studio.arm.gizmo.wxyz)
    started_at = time.perf_counter()
    teach.record.press()
    wait(lambda: teach.record.takes.phase is Phase.RECORDING, 10.0, "the recording")
    start = time.monotonic()
    while (t := time.monotonic() - start) < DRAG_S:  # the user's drag of the gizmo, at 50 Hz
        s = min(t / DRAG_S, 1.0) * demo.duration
        studio.arm.aim([np.interp(s, demo.times, hand[:, j]) for j in range(3)], wxyz)
        time.sleep(0.02)
    teach.record.press()  # Stop
    wait(lambda: teach.record.takes.phase is Phase.IDLE, 30.0, "the save")
    wait(lambda: settled(studio, infer), 120.0, "the score, the refit and the Infer tab")
    time.sleep(0.5)  # the frames that show it
    return [t for t in list(studio.loop.frame_starts) if t >= started_at]


def main(takes: int = 3) -> None:
    gaps: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        studio = Studio.start("127.0.0.1", free_port(), Path(tmp) / "workspace")
        try:
            teach = next(p for p in studio.panels if isinstance(p, TeachPanel))
            infer = next(p for p in studio.panels if isinstance(p, InferPanel))
            teach.record.controls.countdown.value = 0.0
            teach.record.controls.trim.value = False
            teach.record.controls.back_to_start.value = False
            studio.session.wait_for_model()
            wait(lambda: settled(studio, infer), 120.0, "the first views")
            n_frames = 0
            for k in range(takes):
                starts = one_take(studio, teach, infer, k)
                n_frames += len(starts)
                take_gaps = 1e3 * np.diff(starts)
                gaps.extend(take_gaps.tolist())
                n_demos = len(studio.session.store.state.demos["curved"])
                print(f"take {k + 1}: {len(starts)} frames, max gap {take_gaps.max():.1f} ms, "
                      f"p99 {np.percentile(take_gaps, 99):.1f} ms ({n_demos} curved demos)")
        finally:
            studio.stop()
    result = {
        "takes": takes,
        "frames": n_frames,
        "gap_ms_median": round(statistics.median(gaps), 2),
        "gap_ms_p99": round(float(np.percentile(gaps, 99)), 2),
        "gap_ms_max": round(max(gaps), 2),
        "gaps_over_target": int(sum(g > TARGET_MS for g in gaps)),
        "target_ms": TARGET_MS,
        "load_average_1min": round(os.getloadavg()[0], 2),
        "cpus": os.cpu_count(),
    }
    print(
        f"frame gaps while recording, saving, scoring and refitting ({takes} takes, "
        f"{n_frames} frames): median {result['gap_ms_median']:.1f} ms, p99 "
        f"{result['gap_ms_p99']:.1f} ms, max {result['gap_ms_max']:.1f} ms (target: none over "
        f"{TARGET_MS:.0f} ms); machine load {result['load_average_1min']}"
    )
    print(json.dumps(result))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--takes", type=int, default=3, help="takes recorded, saved and refit")
    main(parser.parse_args().takes)
