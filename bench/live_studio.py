"""The studio half of ``bench/live.py``: the same replay (lab-records-flt at 250 Hz x 15
channels, a marker stream) into the headless predictor, then into the studio's live source, in
one run; each one's figures under the same keys as ``bench/live.py``, prefixed ``headless_``
and ``studio_``.

The studio runs in its own process (``Studio.start`` on a workspace of the same set and the
same four modalities, its settings chosen from the data as the headless model's are; no page
is connected, so nothing is drawn) and starts its Live source as *LSL streams (live)* does, with
*Predictions out* on: the mapping of ``bench/live.py``, movements by the marker stream, the
hand's remainder at 50 Hz. Its published streams are read back as the headless predictor's
are: the latency is from a sample's push to the receipt of the first prediction the studio
publishes that includes it, and every prediction is compared with :func:`promp.evidence.infer`
of the model the studio learned (saved by the studio process for this purpose).

Run: ``nice -n 10 .venv/bin/python bench/live_studio.py [--seconds 60]``; the last line is one
JSON object. Every LSL stream stays on the loopback (``LSLAPICFG`` is
``tests/lsl_loopback.cfg``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import live  # noqa: E402  (bench/live.py: sets LSLAPICFG before pylsl loads)

from promp.io import load_model, save_model  # noqa: E402

OUT_STUDIO = f"bench-studio-{live.RUN}"
READY_S = 900.0  # the studio learns the workspace first (a loaded 2-core machine: minutes)


def serve(workspace: Path, model_out: Path) -> None:
    """The studio process: serve ``workspace``, start its live source on the bench's streams
    with its predictions published, until SIGINT; then its counts as JSON (last line)."""
    from app.io.net import free_port
    from app.live.lsl_source import LiveConfig
    from app.studio import Studio

    studio = Studio.start("127.0.0.1", free_port(), workspace)
    try:
        studio.live.watch()
        deadline = time.monotonic() + READY_S
        while studio.session.snapshot().model is None or not {live.MOCAP, live.MARKERS} \
                <= {s.name for s in studio.live.found()}:  # fmt: skip
            if time.monotonic() > deadline:
                raise RuntimeError("the studio's model or the bench's streams never came")
            time.sleep(0.1)
        model = studio.session.snapshot().model
        save_model(model_out, model)
        config = LiveConfig("\n".join(live.INPUTS), start="marker", markers=live.MARKERS,
                            publish=True, out=OUT_STUDIO, remainder="hand", rate=50.0)  # fmt: skip
        running = studio.live.start(model, config)
        print("live source started", flush=True)
        try:
            while True:
                time.sleep(5.0)
                print("; ".join(f"{s.stream}: {s.condition.value} ({s.detail})"
                                for s in running.session.snapshot().statuses), flush=True)
        except KeyboardInterrupt:
            pass
        snap = running.session.snapshot()
        print(json.dumps({"received": {k: v[0] for k, v in snap.counts.items()},
                          "left_out": {k: v[1] for k, v in snap.counts.items()}}), flush=True)
    finally:
        studio.stop()


@contextmanager
def studio(workspace: Path, model_out: Path, log: Path) -> Iterator[dict]:
    """The studio process on the bench's streams (as :func:`live.headless`): yields the dict
    its published predictions are collected into; its counts in ``collected['summary']``
    afterwards."""
    command = [sys.executable, __file__, "--serve", str(workspace), str(model_out)]
    with open(log, "w") as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, cwd=live.REPO)
    deadline = time.monotonic() + READY_S
    while "live source started" not in log.read_text():
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            raise RuntimeError(f"the studio did not start its live source; see {log}")
        time.sleep(0.2)
    with live.predicting(process, OUT_STUDIO, log) as collected:
        yield collected


def workspace_of(root: Path) -> Path:
    """A studio workspace of lab-records-flt's four modalities (the bench's layout)."""
    from app.io.dataset_import import read_folder
    from app.io.workspace import Workspace

    data, _ = read_folder(live.DATA, "records", live.LAYOUT.modalities)
    Workspace.create(root, data)
    return root


def half(source, plan, outlet, markers) -> tuple[live.Pushed, dict, float]:
    """Replay ``plan`` into the predictor ``source`` (a context manager yielding what it
    publishes): what was pushed, what came out, the replay's seconds."""
    with source as published:
        if not (outlet.wait_for_consumers(60.0) and markers.wait_for_consumers(60.0)):
            raise RuntimeError("the predictor did not connect to the bench's streams")
        time.sleep(0.5)
        began = time.monotonic()
        pushed = live.replay(plan, outlet, markers)
        replay_s = time.monotonic() - began
    return pushed, published, replay_s


def main(seconds: float = 60.0, check_every: int = 1) -> dict:
    dataset = live.load_records_dataset(live.DATA)
    model = live.fit(dataset, live.LAYOUT)
    plan = live.make_plan(dataset, seconds)
    result: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        save_model(tmp / "model.json", model)
        outlet, markers = live.bench_outlets()  # the same outlets for both halves
        halves = (
            ("headless", live.headless(tmp / "model.json", tmp / "predictor.log"), None),
            ("studio", studio(workspace_of(tmp / "ws"), tmp / "studio-model.json",
                              tmp / "studio.log"), tmp / "studio-model.json"),
        )  # fmt: skip
        for prefix, source, model_path in halves:
            try:
                pushed, published, replay_s = half(source, plan, outlet, markers)
            except RuntimeError:
                for log in (tmp / "predictor.log", tmp / "studio.log"):
                    if log.exists():
                        print(f"{log.name}:", *log.read_text().splitlines()[-15:], sep="\n")
                raise
            used = load_model(model_path) if model_path is not None else model
            figures = live.figures(used, plan, pushed, published,
                                   published.get("summary", {}), check_every)  # fmt: skip
            figures["replay_s"] = round(replay_s, 1)
            figures["load_average"] = [round(x, 2) for x in os.getloadavg()]
            result.update({f"{prefix}_{k}": v for k, v in figures.items()})
            print(f"{prefix}: {json.dumps(figures)}", flush=True)
    return result


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--serve":
        serve(Path(sys.argv[2]), Path(sys.argv[3]))
        sys.exit(0)
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0,
                        help="how long each replay lasts (default 60 s)")
    parser.add_argument("--check-every", type=int, default=1, metavar="K",
                        help="compare every K-th prediction with the offline engine (default "
                        "1: all)")
    args = parser.parse_args()
    print(json.dumps(main(args.seconds, args.check_every)))
