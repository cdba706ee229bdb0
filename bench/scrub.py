"""Server-side time of one scrub step of the Infer tab, in the running studio.

A scrub step is what the studio's loop does after the observation slider moved: recognise the
primitive and alpha, condition, predict the prior and the posterior, then redraw: the posterior
tube's vertices, the predicted path and its end point, the probability bars, the status, and
the six per-dimension uPlot charts. The studio runs as ``make run`` starts it (its loop thread at
60 Hz, every panel built) on a temporary workspace filled with the default scenario (2 x 20
simulated demonstrations). The slider is set from Python to each percentage of a sweep, 5 to
100 % and back in steps of 5, and the time the panel itself measured for that step (from the
start of the recomputation to the last GUI update queued) is collected; the held-out fit, done
once per test demonstration and cached, is not part of a scrub step and is reported apart.
Then the same sweep on the live stream (the buffer filled with a demonstration's samples).

With ``--browser``, a headless Chromium is connected while measuring, so every update is also
serialised and sent to a real client.

With ``--load``, the studio is measured busy, as a lab uses it: two clients scrub the Infer
tab's slider at once (``--clients``, ``--rate`` updates a second each, ``--seconds`` long)
while a recording runs in Teach (the recorder sampling at 50 Hz, the hand moved through the IK
along a demonstration, as a drag does). Every scrub step computed meanwhile is collected; the
target is p90 <= 33 ms (two frames at 60 Hz). The clients are bare viser websocket clients,
each in its own process: they send the slider's value exactly as the page does and receive
every update, but draw nothing. (Chromium pages were tried first: with software WebGL on the
same two cores, a page's key-press timer fired twice in 8 s, so they measured the pages, not
the studio.)

With ``--baseline COMMIT``, the plain run (no browser, no load) of this script on this tree's
code and on ``COMMIT``'s (a temporary ``git worktree``; each side its own studio in its own
process, the sides alternated ABBA for ``--rounds``): each side's medians and the ratio of this
tree's median step to the baseline's, measured in one run. Both sides are given the basis,
width and noise scale that this tree's automatic rule chooses for the default workspace
(``--given``, as the Teach tab gives them): a step's cost grows with the number of basis
functions, and two commits' automatic rules may choose differently, which would measure the
choice rather than the code.

Run: ``.venv/bin/python bench/scrub.py [--browser | --load | --baseline COMMIT [--rounds N]]``.
The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
# ``--code DIR`` (what --baseline passes): this script run on another checkout's code
CODE = Path(sys.argv[sys.argv.index("--code") + 1]) if "--code" in sys.argv else REPO
sys.path.insert(0, str(CODE))
sys.path.insert(1, str(REPO))  # bench.checkout, if CODE has none

from app.core.fits import held_out_training  # noqa: E402
from app.io.net import free_port  # noqa: E402
from app.panels.infer import LIVE, InferPanel  # noqa: E402
from app.studio import Studio  # noqa: E402
from bench.checkout import checkout  # noqa: E402
from promp.learn import fit  # noqa: E402
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT  # noqa: E402

TARGET_MS = 16.0
LOAD_TARGET_MS = 33.0  # p90 under load: two frames at 60 Hz
REFIT_TARGET_MS = 100.0

SWEEP = list(range(5, 101, 5)) + list(range(95, 4, -5))


def scrub_to(panel: InferPanel, percent: int, timeout: float = 30.0) -> float:
    """Set the slider (as a browser would), wait for the loop's scrub step, return its ms."""
    count = panel.steps.count
    panel.controls.percent.value = percent
    deadline = time.monotonic() + timeout
    while (
        panel.steps.count == count
        or panel.view.state.percent != percent
        or panel.view.message.startswith("learning a model")  # the held-out model, fitted
    ):
        if time.monotonic() > deadline:
            raise RuntimeError(f"no scrub step within {timeout} s at {percent} %")
        time.sleep(0.002)
    if panel.view.result is None:
        raise RuntimeError(f"the scrub step at {percent} % failed: {panel.view.message}")
    return panel.steps.last_ms


def sweep(panel: InferPanel, label: str) -> list[float]:
    scrub_to(panel, 50)  # warm up (and fit the held-out model once)
    times = []
    print(f"{label}: percent, recognised, step ms")
    for percent in SWEEP:
        ms = scrub_to(panel, percent)
        times.append(ms)
        print(f"  {percent:3d} %  {panel.view.result.inference.primitive:>10s}  {ms:6.2f}")
    return times


def fill_live_buffer(panel: InferPanel) -> None:
    """The live buffer as if the first demonstration had just been observed."""
    demo = panel.ctx.store.state.demos[panel.controls.primitive.value][0]
    values = demo.select(LAYOUT.columns)
    panel.live.clear()
    for t, row in zip(demo.times, values, strict=True):
        panel.live.append(1000.0 + float(t), row[:3], row[3:])


def studio_settings() -> tuple[int, float, float]:
    """The basis, width and noise scale this tree's automatic rule chooses for the studio's
    default workspace (:func:`bench.infer_step.chosen_settings`; what ``--baseline`` gives
    both sides)."""
    from bench.infer_step import chosen_settings

    s = chosen_settings()
    return s["n_basis"], s["width"], s["noise_scale"]


def paired(baseline: str, rounds: int) -> None:
    """This script on this tree's code and on ``baseline``'s, alternated ABBA, the settings
    given (see the docstring)."""
    runs: dict[str, list[dict]] = {"this": [], "baseline": []}
    given = studio_settings()
    with checkout(baseline) as old:
        sides = {"this": REPO, "baseline": old}
        for r in range(rounds):
            for name in list(sides) if r % 2 == 0 else list(reversed(sides)):
                command = [sys.executable, str(Path(__file__).resolve()), "--code",
                           str(sides[name]), "--given", ",".join(map(str, given))]  # fmt: skip
                done = subprocess.run(command, cwd=sides[name], check=True, capture_output=True,
                                      text=True)  # fmt: skip
                runs[name].append(json.loads(done.stdout.strip().splitlines()[-1]))
                print(f"round {r + 1} {name:8s} median {runs[name][-1]['scrub_ms_median']:6.2f} "
                      f"ms, live {runs[name][-1]['live_scrub_ms_median']:6.2f} ms "
                      f"(load {os.getloadavg()[0]:.1f})", flush=True)  # fmt: skip
    result: dict = {"baseline": baseline, "rounds": rounds, "given": given}
    for key in ("scrub_ms_median", "scrub_ms_p90", "live_scrub_ms_median"):
        for name, side in runs.items():
            result[f"{name}_{key}"] = round(statistics.median(run[key] for run in side), 3)
        result[f"ratio_{key}"] = round(result[f"this_{key}"] / result[f"baseline_{key}"], 3)
    result["load_average_1min"] = round(os.getloadavg()[0], 2)
    this, base = result["this_scrub_ms_median"], result["baseline_scrub_ms_median"]
    print(f"scrub step: this tree {this:.2f} ms, {baseline} {base:.2f} ms: ratio "
          f"{result['ratio_scrub_ms_median']:.2f} (live {result['ratio_live_scrub_ms_median']:.2f};"
          f" both given the basis, width and noise scale {given})")
    print(json.dumps(result))


def give(studio: Studio, given: tuple[int, float, float]) -> None:
    """The workspace's learning settings given (as the Teach tab gives them), and its model
    refitted with them before the sweep."""
    n_basis, width, noise_scale = given
    studio.session.store.set_learning(n_basis, width, noise_scale=noise_scale)
    deadline = time.monotonic() + 120.0
    while True:
        model = studio.session.snapshot().model
        if model is not None and (model.settings.n_basis, model.settings.width,
                                  model.settings.noise_scale) == given:  # fmt: skip
            return
        if time.monotonic() > deadline:
            raise RuntimeError(f"the workspace was not refitted with {given} within 120 s")
        time.sleep(0.01)


def main(browser: bool = False, given: tuple[int, float, float] | None = None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        studio = Studio.start("127.0.0.1", free_port(), Path(tmp) / "workspace")
        pw = chromium = None
        try:
            if given is not None:
                give(studio, given)
            panel = next(p for p in studio.panels if isinstance(p, InferPanel))
            deadline = time.monotonic() + 60.0
            while panel.steps.count == 0 and time.monotonic() < deadline:
                time.sleep(0.01)  # the loop's first frames follow the workspace and infer
            if browser:
                from playwright.sync_api import sync_playwright

                from tests.conftest import CHROMIUM, CHROMIUM_FLAGS

                pw = sync_playwright().start()
                chromium = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_FLAGS)
                page = chromium.new_page(viewport={"width": 1400, "height": 900})
                page.goto(f"http://127.0.0.1:{studio.port}")
                page.get_by_role("tab", name="Infer").click(timeout=60_000)
                time.sleep(2.0)
            test = sweep(panel, f"test demonstration {panel.controls.demo.value} (held out)")
            fit_ms = _fit_ms(panel, studio.session)
            refit_ms = _refit_ms(studio.session)
            panel.controls.source.value = LIVE
            fill_live_buffer(panel)
            live = sweep(panel, "live stream (buffer of one demonstration)")
        finally:
            if chromium is not None:
                chromium.close()
            if pw is not None:
                pw.stop()
            studio.stop()
    result = {
        "scrub_ms_median": round(statistics.median(test), 3),
        "scrub_ms_p90": round(sorted(test)[int(0.9 * (len(test) - 1))], 3),
        "scrub_ms_max": round(max(test), 3),
        "live_scrub_ms_median": round(statistics.median(live), 3),
        "held_out_fit_ms": round(fit_ms, 1),
        "refit_ms_median": round(refit_ms, 1),
        "refit_target_ms": REFIT_TARGET_MS,
        "steps": len(test),
        "target_ms": TARGET_MS,
        "browser_connected": browser,
        "code": str(Path(sys.modules[Studio.__module__].__file__).resolve().parents[1]),
        "given": given,
        "load_average_1min": round(os.getloadavg()[0], 2),
        "cpus": os.cpu_count(),
    }
    print(
        f"scrub step median {result['scrub_ms_median']:.2f} ms (p90 {result['scrub_ms_p90']:.2f},"
        f" max {result['scrub_ms_max']:.2f}); live stream {result['live_scrub_ms_median']:.2f} ms;"
        f" target <= {TARGET_MS:.0f} ms; refit of the workspace {result['refit_ms_median']:.1f} ms"
        f" (Teach tab, target well under {REFIT_TARGET_MS:.0f} ms);"
        f" machine load {result['load_average_1min']}"
    )
    print(json.dumps(result))


def _refit_ms(session, repeats: int = 7) -> float:
    """Median time of the Teach tab's refit of the whole workspace (every primitive, with the
    workspace's learning settings), as the session measures it after every change."""
    timings = []
    for _ in range(repeats):
        session.refit()
        timings.append(session.learner.state.fit_ms)
    return statistics.median(timings)


def _fit_ms(panel: InferPanel, session) -> float:
    """Time of one held-out fit, as the learner does it when a new test demo is picked."""
    snapshot = session.snapshot()
    demos = snapshot.store.demos
    settings = snapshot.resolved_settings()  # as the learner fits: no new choice
    controls = panel.controls
    start = time.perf_counter()
    fit(held_out_training(demos, controls.primitive.value, controls.demo.value), LAYOUT, settings)
    return 1e3 * (time.perf_counter() - start)


def scrubbing_client(port: int, slider_uuid: str, seconds: float, rate_hz: float, report) -> None:
    """One client that scrubs: a bare viser websocket client (no rendering) in its own
    process. It connects as the browser does (viser's subprotocol), sends the Infer slider's
    value as the page sends a drag or an arrow key (``GuiUpdateMessage``), ``rate_hz`` times a
    second, sweeping 5..100 % and back, and reads everything the studio sends meanwhile (the
    updates of every scrub step). Puts (updates sent, messages received, bytes received) in
    ``report``."""
    import asyncio

    import msgspec
    import viser
    import websockets
    from viser import _messages

    async def run() -> tuple[int, int, int]:
        received = [0, 0]
        async with websockets.connect(
            f"ws://127.0.0.1:{port}",
            subprotocols=[f"viser-v{viser.__version__}"],
            max_size=None,
        ) as ws:

            async def read() -> None:
                async for raw in ws:
                    received[0] += 1
                    received[1] += len(raw)

            reader = asyncio.create_task(read())
            # A page reports its camera first: viser registers a client (and runs GUI
            # callbacks for it) only from then on.
            camera = _messages.ViewerCameraMessage(
                wxyz=(1.0, 0.0, 0.0, 0.0), position=(-1.5, 0.0, 1.2), fov=1.0, near=0.01,
                far=100.0, image_height=900, image_width=1400, look_at=(0.0, 0.0, 0.6),
                up_direction=(0.0, 0.0, 1.0),
            )  # fmt: skip
            await ws.send(msgspec.msgpack.encode(camera.as_serializable_dict()))
            await asyncio.sleep(2.0)  # the scene and the GUI arrive first, as in a page
            sent = 0
            percents = list(range(5, 101)) + list(range(99, 5, -1))
            period = 1.0 / rate_hz
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                value = percents[sent % len(percents)]
                message = _messages.GuiUpdateMessage(slider_uuid, {"value": value})
                await ws.send(msgspec.msgpack.encode(message.as_serializable_dict()))
                sent += 1
                await asyncio.sleep(period)
            await asyncio.sleep(1.0)  # the last steps' updates
            reader.cancel()
            return sent, received[0], received[1]

    report.put(asyncio.run(run()))


def under_load(seconds: float = 20.0, clients: int = 2, rate_hz: float = 30.0) -> None:
    """Clients scrubbing at once while Teach records (see the module docstring)."""
    import multiprocessing
    import threading

    import numpy as np

    from app.live.take_controller import Phase
    from app.panels.teach import TeachPanel

    with tempfile.TemporaryDirectory() as tmp:
        studio = Studio.start("127.0.0.1", free_port(), Path(tmp) / "workspace")
        stop = threading.Event()
        steps: list[float] = []
        try:
            panel = next(p for p in studio.panels if isinstance(p, InferPanel))
            teach = next(p for p in studio.panels if isinstance(p, TeachPanel))
            studio.session.wait_for_model()
            scrub_to(panel, 50)  # the held-out model fitted before measuring
            demo = studio.session.store.state.demos[panel.controls.primitive.value][1]
            hand = LAYOUT.extract(demo)[:, :3]

            def drag() -> None:  # the user's drag while recording, at 50 Hz
                start = time.monotonic()
                while not stop.is_set():
                    t = (time.monotonic() - start) % demo.duration
                    target = np.array([np.interp(t, demo.times, hand[:, j]) for j in range(3)])
                    studio.loop.call(lambda p=target: studio.arm.move_hand_to(p))
                    time.sleep(0.02)

            def collect() -> None:  # every scrub step the loop computes meanwhile
                seen = panel.steps.count
                while not stop.is_set():
                    if panel.steps.count != seen:
                        seen = panel.steps.count
                        steps.append(panel.steps.last_ms)
                    time.sleep(0.001)

            teach.record.press()  # Record: the countdown, then sampling
            deadline = time.monotonic() + 30.0
            while teach.record.takes.phase is not Phase.RECORDING and time.monotonic() < deadline:
                time.sleep(0.01)
            recorder = teach.record.takes.recorder
            samples_before, started = recorder.n_samples, time.monotonic()
            threads = [threading.Thread(target=f, daemon=True) for f in (drag, collect)]
            for thread in threads:
                thread.start()
            context = multiprocessing.get_context("spawn")
            report = context.Queue()
            processes = [
                context.Process(
                    target=scrubbing_client,
                    args=(studio.port, panel.controls.percent._impl.uuid, seconds, rate_hz, report),
                )
                for _ in range(clients)
            ]
            for process in processes:
                process.start()
            reports = [report.get(timeout=seconds + 120.0) for _ in processes]
            for process in processes:
                process.join(timeout=30.0)
            recording = teach.record.takes.phase is Phase.RECORDING
            recorded_hz = (recorder.n_samples - samples_before) / (time.monotonic() - started)
            skipped = recorder.skipped
            stop.set()
            for thread in threads:
                thread.join(timeout=5.0)
            teach.record.press()  # Stop (saved like any take)
        finally:
            stop.set()
            studio.stop()
    if not steps:
        raise RuntimeError("no scrub step was computed under load")
    ordered = sorted(steps)
    result = {
        "load_scrub_steps": len(steps),
        "load_scrub_ms_median": round(statistics.median(ordered), 3),
        "load_scrub_ms_p90": round(ordered[int(0.9 * (len(ordered) - 1))], 3),
        "load_scrub_ms_max": round(ordered[-1], 3),
        "load_target_p90_ms": LOAD_TARGET_MS,
        "recording_throughout": recording,
        "recording_rate_hz": round(recorded_hz, 1),
        "recording_ticks_skipped": skipped,
        "clients": clients,
        "client_kind": "viser websocket (no rendering), one process each",
        "slider_updates_sent": [r[0] for r in reports],
        "messages_received": [r[1] for r in reports],
        "seconds": seconds,
        "load_average_1min": round(os.getloadavg()[0], 2),
        "cpus": os.cpu_count(),
    }
    print(
        f"under load ({clients} clients scrubbing at {rate_hz:.0f} Hz each, 1 recording): "
        f"{len(steps)} scrub steps, median {result['load_scrub_ms_median']:.2f} ms, p90 "
        f"{result['load_scrub_ms_p90']:.2f} ms, max {result['load_scrub_ms_max']:.2f} ms "
        f"(target p90 <= {LOAD_TARGET_MS:.0f} ms); machine load {result['load_average_1min']}"
    )
    print(json.dumps(result))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--browser", action="store_true", help="connect a headless Chromium while measuring"
    )
    group.add_argument(
        "--load", action="store_true",
        help="two clients scrubbing at once while a recording runs",
    )  # fmt: skip
    group.add_argument("--baseline", help="a commit to measure beside this tree, alternated")
    parser.add_argument("--rounds", type=int, default=4, help="runs of each side (--baseline)")
    parser.add_argument("--given", help="N,WIDTH,NOISE_SCALE: the workspace's settings given")
    parser.add_argument("--code", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--seconds", type=float, default=20.0, help="how long --load scrubs")
    parser.add_argument("--clients", type=int, default=2, help="scrubbing clients for --load")
    parser.add_argument(
        "--rate", type=float, default=30.0, help="slider updates a second per --load client"
    )
    args = parser.parse_args()
    if args.baseline:
        paired(args.baseline, args.rounds)
    elif args.load:
        under_load(args.seconds, args.clients, args.rate)
    else:
        given = None
        if args.given:
            n, w, ns = args.given.split(",")
            given = (int(n), float(w), float(ns))
        main(browser=args.browser, given=given)
