"""Live prediction end to end: an LSL outlet replays demonstrations at 250 Hz with 15 channels
into the headless predictor (``python -m promp.live``, its own process), whose published
streams are read back here.

The demonstrations are the shared set ``lab-records-flt`` (60 real movements, 100 Hz, 3
goals), resampled at 250 Hz, one after the other (shuffled, seed 0) with 0.3 s of the last
sample held between them, for ``--seconds``. The stream ``BenchMocap`` carries 15 channels: the
hand in millimetres (converted by the predictor's mapping ``@mm``), the haptic device's
position (m), the force (N), the moment (N m), and three channels the model does not use (a
second marker: the hand 5 cm aside, m; its name ends with this run's id, as do the others',
so that benches running beside each other do not feed each other). The model is learned over
the four modalities (12 dimensions) from the same set. The marker stream ``BenchMarkers``
says ``start CLASS`` and ``end CLASS`` at each movement's first and last sample (``--start
marker``).

Measured, from this process's pushes and what its inlets receive (one machine, one
``local_clock``):

* ``latency_ms_p50``, ``latency_ms_p99``: from a sample's push to the receipt of the first
  published prediction that includes it (its ``NAME-timing`` sample says the movement's first
  sample and how many were observed; a prediction is received when all its streams are);
* ``predictions_per_s``: predictions published over the movements' time;
* ``samples_dropped``: samples pushed that the predictor did not receive or left out (its
  closing line counts them);
* ``agree_with_offline``: the share of published predictions whose every number (the
  probabilities, the phase, duration and time left with their intervals, the remainder's rows)
  equals, within 1e-9, :func:`promp.evidence.infer` run here on the same samples.

With ``--slow F`` every demonstration is stretched F times in time (resampled at its own
rate, 100 Hz) before the model is learned and the replay made: ``--slow 7`` gives movements of
3.9 to 8 s (median 6 s) at 250 Hz, the long movements the predictor must keep up with; the
model then knows movements that slow (a movement far slower than every demonstration is
another matter: its likely speeds move with every sample).

Targets on this 2-core machine: p99 <= 50 ms, >= 30 predictions/s, 0 dropped, agreement 1.0.
Every LSL stream stays on the loopback (``LSLAPICFG`` is ``tests/lsl_loopback.cfg``).

The studio half is ``bench/live_studio.py``: the same replay into the headless predictor and
into the studio's live source in one run (:func:`figures` takes what was pushed and the
:class:`Published` predictions, wherever they came out).

Run: ``.venv/bin/python bench/live.py [--seconds 60] [--slow 7]``. The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
LSL_CONFIG = REPO / "tests" / "lsl_loopback.cfg"
os.environ["LSLAPICFG"] = str(LSL_CONFIG)  # before pylsl loads
sys.path.insert(0, str(REPO))

import pylsl  # noqa: E402

from bench.checkout import checkout  # noqa: E402
from promp.data import Demonstration, Layout, Modality  # noqa: E402
from promp.datasets import load_records_dataset  # noqa: E402
from promp.evidence.pipeline import infer  # noqa: E402
from promp.inference import Observation, trajectory_at  # noqa: E402
from promp.io import model_to_dict, save_model  # noqa: E402
from promp.learn import fit  # noqa: E402
from promp.live.lsl import new_outlet, open_inlet, release  # noqa: E402

DATA = REPO.parent / "shared" / "data" / "lab-records-flt"
RATE_HZ = 250.0
PAUSE_S = 0.3
TOLERANCE = 1e-9
LAYOUT = Layout((
    Modality("hand", ("x", "y", "z"), unit="m"),
    Modality("device", ("device_x", "device_y", "device_z"), unit="m"),
    Modality("force", ("fx", "fy", "fz"), unit="N"),
    Modality("moment", ("mx", "my", "mz"), unit="Nm"),
))  # fmt: skip
LABELS = ("hand_x", "hand_y", "hand_z", "device_x", "device_y", "device_z", "fx", "fy", "fz",
          "mx", "my", "mz", "second_x", "second_y", "second_z")  # fmt: skip
UNITS = ("mm",) * 3 + ("m",) * 3 + ("N",) * 3 + ("Nm",) * 3 + ("m",) * 3
# Names of this run: a bench running beside (another worktree's) must not feed this one.
RUN = os.environ.setdefault("BENCH_LIVE_RUN", str(os.getpid()))  # its children share it
MOCAP, MARKERS = f"BenchMocap-{RUN}", f"BenchMarkers-{RUN}"
INPUTS = (f"hand={MOCAP}:hand_x,hand_y,hand_z@mm", f"device={MOCAP}:3,4,5",
          f"force={MOCAP}:fx,fy,fz", f"moment={MOCAP}:mx,my,mz")  # fmt: skip
SCALE = np.array([1e-3] * 3 + [1.0] * 9)  # what the mapping converts the 12 used channels by
OUT = f"bench-{RUN}"
STARTUP_S = 180.0  # a predictor starting on a loaded 2-core machine (imports, the model)


@dataclass(eq=False)
class Plan:
    """What the outlet pushes: ``rows`` (n, 15) at ``times`` (n,) s from the start; each
    movement's class and rows ``[first, last]``."""

    times: np.ndarray
    rows: np.ndarray
    movements: list[tuple[str, int, int]]


def make_plan(dataset: dict, seconds: float, seed: int = 0) -> Plan:
    demos = [(k, d) for k, ds in dataset.items() for d in ds]
    order = np.random.default_rng(seed).permutation(len(demos))
    rows, movements, n, k = [], [], 0, 0
    while n / RATE_HZ < seconds:
        klass, demo = demos[order[k % len(demos)]]
        k += 1
        t = demo.times - demo.times[0]
        grid = np.arange(0.0, t[-1] + 1e-9, 1.0 / RATE_HZ)
        values = np.column_stack([np.interp(grid, t, c) for c in LAYOUT.extract(demo).T])
        table = np.column_stack([values[:, :3] * 1000.0, values[:, 3:12], values[:, :3] + 0.05])
        movements.append((klass, n, n + grid.size - 1))
        hold = np.repeat(table[-1:], int(PAUSE_S * RATE_HZ), axis=0)
        rows += [table, hold]
        n += grid.size + hold.shape[0]
    table = np.vstack(rows)
    return Plan(np.arange(table.shape[0]) / RATE_HZ, table, movements)


def slowed(dataset: dict, factor: float) -> dict:
    """Every demonstration of ``dataset`` lasting ``factor`` times as long, resampled at its own
    mean sample rate (values linearly interpolated)."""
    if factor == 1.0:
        return dataset
    out = {}
    for klass, demos in dataset.items():
        out[klass] = []
        for d in demos:
            t = (d.times - d.times[0]) * factor
            step = (d.times[-1] - d.times[0]) / (d.times.shape[0] - 1)
            grid = np.arange(0.0, t[-1] + 1e-9, step)
            values = np.column_stack([np.interp(grid, t, c) for c in d.values.T])
            out[klass].append(Demonstration(grid, values, d.columns, d.name))
    return out


@dataclass(eq=False)
class Pushed:
    """The stamps (session clock) and push times of every row, once replayed."""

    stamps: np.ndarray
    pushed_at: np.ndarray


@dataclass(eq=False)
class Published:
    """One prediction as it came out: received at ``received`` (local clock), its timing
    row, probabilities row and remainder rows (see promp.live.outlets)."""

    seq: int
    received: float = 0.0
    timing: np.ndarray | None = None
    probabilities: np.ndarray | None = None
    remainder: list[np.ndarray] = field(default_factory=list)


def replay(plan: Plan, outlet, markers) -> Pushed:
    """Push ``plan`` at its real rate; the start and end markers around each movement."""
    starts = {first: klass for klass, first, _ in plan.movements}
    ends = {last: klass for klass, _, last in plan.movements}
    t0 = pylsl.local_clock() + 0.2
    stamps = t0 + plan.times
    pushed_at = np.empty(stamps.size)
    for k in range(stamps.size):
        delay = stamps[k] - pylsl.local_clock()
        if delay > 0.0005:
            time.sleep(delay)
        if k in starts:
            markers.push_sample([f"start {starts[k]}"], stamps[k])
        outlet.push_sample(plan.rows[k].tolist(), stamps[k])
        pushed_at[k] = pylsl.local_clock()
        if k in ends:
            markers.push_sample([f"end {ends[k]}"], stamps[k])
    return Pushed(stamps, pushed_at)


def _read(name: str, into: dict, kind: str, stop: threading.Event, ready: threading.Event):
    info = pylsl.resolve_byprop("name", name, 1, STARTUP_S)  # a busy machine starts it slowly
    if not info:
        raise RuntimeError(f"the predictor's stream {name} did not appear")
    inlet = open_inlet(info[0], 10.0, max_buflen=360, recover=False)
    ready.set()
    try:
        while not stop.is_set():
            try:
                rows, _ = inlet.pull_chunk(timeout=0.02, max_samples=4096, min_samples=1)
            except pylsl.util.LostError:  # the predictor stopped
                return
            now = pylsl.local_clock()
            for row in rows:
                row = np.asarray(row, dtype=float)
                p = into.setdefault(int(row[0]), Published(int(row[0])))
                p.received = max(p.received, now)
                if kind == "remainder":
                    p.remainder.append(row)
                else:
                    setattr(p, kind, row)
    finally:
        release(inlet)


@contextmanager
def headless(model_path: Path, log: Path, repo: Path = REPO, extra: tuple[str, ...] = ()
             ) -> Iterator[dict]:  # fmt: skip
    """The headless predictor of the code in ``repo`` (this worktree, or a baseline's) on the
    bench's streams, with ``extra`` arguments; yields the dict its predictions are collected
    into (by seq), then stops it with Ctrl-C; its closing JSON is in ``collected['summary']``
    afterwards."""
    command = [sys.executable, "-m", "promp.live", "--model", str(model_path),
               *(a for spec in INPUTS for a in ("--in", spec)), "--out", OUT,
               "--remainder", "hand", "--rate", "50", "--start", "marker", "--markers",
               MARKERS, "--lsl-config", str(LSL_CONFIG), "--status-every", "5",
               *extra]  # fmt: skip
    with open(log, "w") as out:
        # ``-m`` puts the working directory first on sys.path: ``repo``'s promp is the one run
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, cwd=repo)
    with predicting(process, OUT, log) as collected:
        yield collected


@contextmanager
def predicting(process: subprocess.Popen, out: str, log: Path) -> Iterator[dict]:
    """Read a predictor's streams ``out``-timing, -probabilities, -remainder; yields the dict
    its predictions are collected into (by seq), then stops ``process`` with Ctrl-C; the last
    JSON line of its ``log`` (its counts) is in ``collected['summary']`` afterwards."""
    collected: dict = {}
    stop = threading.Event()
    readers = []
    try:
        for kind in ("timing", "probabilities", "remainder"):
            ready = threading.Event()
            thread = threading.Thread(target=_read, daemon=True,
                                      args=(f"{out}-{kind}", collected, kind, stop, ready))
            thread.start()
            readers.append((thread, ready))
        for _, ready in readers:
            if not ready.wait(STARTUP_S + 30.0):
                raise RuntimeError(f"the predictor's streams did not appear; see {log}")
        yield collected
        time.sleep(1.0)  # the last predictions on their way
    finally:
        stop.set()
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=120)
        except subprocess.TimeoutExpired:
            process.kill()  # its counts are then unknown: samples_dropped is null
            process.wait()
        lines = log.read_text().strip().splitlines()
        collected["summary"] = next((json.loads(line) for line in reversed(lines)
                                     if line.startswith("{")), {})  # fmt: skip


def offline(model, pushed: Pushed, plan: Plan, p: Published) -> tuple[np.ndarray, np.ndarray]:
    """The published numbers of ``p`` and the same from promp.evidence.infer on the samples
    it observed (flattened, in the order of the outlets' channels)."""
    start, n = float(p.timing[2]), int(p.timing[14])
    i0 = int(np.argmin(np.abs(pushed.stamps - start)))
    correction = start - pushed.stamps[i0]
    times = pushed.stamps[i0:i0 + n] + correction
    values = plan.rows[i0:i0 + n, :12] * SCALE
    obs = Observation(times - times[0], values, LAYOUT.names)
    inference = infer(model, obs)
    elapsed = inference.observed_until
    timing = inference.timing
    left = timing.remaining_after(elapsed)
    duration = inference.duration
    rest = max(duration - elapsed, 0.0)
    after = np.arange(1, int(np.ceil(rest * 50.0)) + 1) / 50.0
    after = np.append(after[after < rest], rest)
    mean, std = trajectory_at(model, inference.posterior, inference.alpha,
                              np.clip((elapsed + after) / duration, 0.0, 1.0))  # fmt: skip
    dims = model.layout.dims(["hand"])
    expected = np.concatenate([
        inference.probabilities,
        [elapsed, timing.observed_fraction.value, timing.observed_fraction.low,
         timing.observed_fraction.high, timing.duration.value, timing.duration.low,
         timing.duration.high, left.value, left.low, left.high, inference.index, n],
        np.column_stack([after, mean[:, dims], std[:, dims]]).ravel(),
    ])  # fmt: skip
    remainder = np.vstack(p.remainder)[:, 4:] if p.remainder else np.zeros((0, 7))
    got = np.concatenate([p.probabilities[2:], p.timing[3:15], remainder.ravel()])
    return got, expected


def figures(model, plan: Plan, pushed: Pushed, published: dict, summary: dict,
            check_every: int = 1, latencies: list | None = None) -> dict:  # fmt: skip
    """The bench's figures from what was pushed and the predictions as they came out (each
    sample's latency, ms, also appended to ``latencies`` when given: runs pooled)."""
    complete = sorted((p for k, p in published.items() if isinstance(k, int)
                       and p.timing is not None and p.probabilities is not None),
                      key=lambda p: p.seq)  # fmt: skip
    # the first prediction (in order of receipt) that includes each sample
    first_seen = np.full(pushed.stamps.size, np.inf)
    for p in complete:
        i0 = int(np.argmin(np.abs(pushed.stamps - float(p.timing[2]))))
        last = i0 + int(p.timing[14])
        block = first_seen[i0:last]
        np.minimum(block, p.received, out=block)
    inside = np.concatenate([np.arange(a, b + 1) for _, a, b in plan.movements])
    seen = inside[np.isfinite(first_seen[inside])]
    never = [(m, int(k - a)) for m, (_, a, b) in enumerate(plan.movements, start=1)
             for k in range(a, b + 1) if not np.isfinite(first_seen[k])]
    if never:
        print(f"samples never predicted (movement, sample): {never[:20]}")
    latency_ms = (first_seen[seen] - pushed.pushed_at[seen]) * 1000.0
    if latencies is not None:
        latencies.append(latency_ms)
    moving_s = sum((b - a) / RATE_HZ for _, a, b in plan.movements)
    checked = complete[::max(check_every, 1)]
    agree = 0
    for p in checked:
        got, expected = offline(model, pushed, plan, p)
        agree += got.shape == expected.shape and bool(np.all(np.abs(got - expected) <= TOLERANCE))
    received = summary.get("received", {}).get(MOCAP, 0)  # not the marker stream's
    left_out = summary.get("left_out", {}).get(MOCAP, 0)
    return {
        "samples": int(pushed.stamps.size),
        "movements": len(plan.movements),
        "predictions": len(complete),
        "samples_in_movements": int(inside.size),
        "samples_never_predicted": int(inside.size - seen.size),
        "predictions_checked": len(checked),
        "latency_ms_p50": round(float(np.percentile(latency_ms, 50)), 2) if seen.size else None,
        "latency_ms_p90": round(float(np.percentile(latency_ms, 90)), 2) if seen.size else None,
        "latency_ms_p99": round(float(np.percentile(latency_ms, 99)), 2) if seen.size else None,
        "predictions_per_s": round(len(complete) / moving_s, 1),
        "samples_dropped": int(pushed.stamps.size - received + left_out) if summary else None,
        "agree_with_offline": round(agree / max(len(checked), 1), 6),
    }


def bench_outlets():
    """The outlets ``BenchMocap`` (15 labelled channels with their units) and
    ``BenchMarkers``."""
    info = pylsl.StreamInfo(MOCAP, "Mocap", len(LABELS), RATE_HZ, pylsl.cf_double64,
                            MOCAP)  # fmt: skip
    channels = info.desc().append_child("channels")
    for label, unit in zip(LABELS, UNITS, strict=True):
        c = channels.append_child("channel")
        c.append_child_value("label", label)
        c.append_child_value("unit", unit)
    markers = pylsl.StreamInfo(MARKERS, "Markers", 1, 0, pylsl.cf_string, MARKERS)
    return new_outlet(info), new_outlet(markers)


def replayed(model_path: Path, plan: Plan, tmp: Path, repo: Path = REPO,
             extra: tuple[str, ...] = ()) -> tuple[Pushed, dict, float]:  # fmt: skip
    """``plan`` replayed into the predictor of the code in ``repo`` (``extra`` arguments):
    what was pushed, the predictions collected (with ``'summary'``), the replay's seconds."""
    log = tmp / "predictor.log"
    outlet, markers = bench_outlets()
    with headless(model_path, log, repo, extra) as published:
        if not (outlet.wait_for_consumers(60.0) and markers.wait_for_consumers(60.0)):
            raise RuntimeError("the predictor did not connect to the bench's streams")
        time.sleep(0.5)
        began = time.monotonic()
        pushed = replay(plan, outlet, markers)
        replay_s = time.monotonic() - began
    release(outlet)  # the next run's streams have the same names
    release(markers)
    print("\n".join(log.read_text().splitlines()[-4:]))
    return pushed, published, replay_s


def older_format(model) -> dict:
    """``model`` as a version-2 file (what the code before the stillness learned wrote:
    without each primitive's ``stillness``), for a baseline that reads no later version."""
    data = model_to_dict(model)
    data["version"] = 2
    for primitive in data["primitives"]:
        primitive.pop("stillness", None)
    return data


def baseline_model(model, repo: Path) -> dict:
    """``model`` as the baseline checked out in ``repo`` reads it: the same file where its
    ``promp/io.py`` reads this version (both sides then predict the same model: the pair
    times the code, not two models), else :func:`older_format`."""
    import re

    data = model_to_dict(model)
    found = re.search(r"^READABLE_VERSIONS = \(([^)]*)\)", (repo / "promp" / "io.py").read_text(),
                      re.MULTILINE)  # fmt: skip
    readable = {int(v) for v in found.group(1).replace(" ", "").split(",") if v} if found else set()
    return data if data["version"] in readable else older_format(model)


def paired(model, plan: Plan, tmp: Path, baseline: str, rounds: int, check_every: int,
           extra: tuple[str, ...] = ()) -> dict:  # fmt: skip
    """This worktree's predictor (``extra`` arguments) and ``baseline``'s, run one after the
    other ``rounds`` times (their order swapped each round, ABBA), on the same plan; each
    side's latencies pooled over its runs, and the ratio of the p99s. ``baseline``
    ``processes=1`` is this worktree's predictor in one process (``--processes 1``)."""
    current_path, old_path = tmp / "model.json", tmp / "model-baseline.json"
    save_model(current_path, model)
    sides: dict[str, dict] = {"current": {"latency": [], "runs": []},
                              "baseline": {"latency": [], "runs": []}}  # fmt: skip
    one = baseline == "processes=1"
    with contextlib.nullcontext(REPO) if one else checkout(baseline) as old_repo:
        old_path.write_text(json.dumps(baseline_model(model, Path(old_repo))))
        for r in range(rounds):
            order = [("current", REPO, current_path, extra),
                     ("baseline", old_repo, current_path if one else old_path,
                      ("--processes", "1") if one else ())]  # fmt: skip
            for side, repo, path, args in order if r % 2 == 0 else order[::-1]:
                pushed, published, _ = replayed(path, plan, tmp, repo, args)
                run = figures(model, plan, pushed, published, published.get("summary", {}),
                              check_every, sides[side]["latency"])  # fmt: skip
                print(side, json.dumps(run))
                sides[side]["runs"].append(run)
    result: dict = {"baseline": baseline, "rounds": rounds}
    for side, got in sides.items():
        latency = np.concatenate(got["latency"])
        prefix = "" if side == "current" else "baseline_"
        runs = got["runs"]
        result[prefix + "latency_ms_p50"] = round(float(np.percentile(latency, 50)), 2)
        result[prefix + "latency_ms_p90"] = round(float(np.percentile(latency, 90)), 2)
        result[prefix + "latency_ms_p99"] = round(float(np.percentile(latency, 99)), 2)
        result[prefix + "latency_ms_p99_per_run"] = [r["latency_ms_p99"] for r in runs]
        result[prefix + "predictions_per_s"] = round(float(np.mean(
            [r["predictions_per_s"] for r in runs])), 1)  # fmt: skip
        dropped = [r["samples_dropped"] for r in runs]
        result[prefix + "samples_dropped"] = None if None in dropped else sum(dropped)
        # (the offline engine is this worktree's: the baseline's agreement says whether the
        # two engines give the same numbers, 0 once the method changed, as the quadrature of
        # the branch wip/adaptive-quadrature did: docs/live.md)
        agree = "agree_with_offline" if side == "current" else "agree_with_this_engine"
        result[prefix + agree] = min(r["agree_with_offline"] for r in runs)
    result["ratio_p99"] = round(result["latency_ms_p99"] / result["baseline_latency_ms_p99"], 3)
    return result


def main(seconds: float = 60.0, check_every: int = 1, slow: float = 1.0,
         baseline: str | None = None, rounds: int = 2, processes: int | None = None
         ) -> dict:  # fmt: skip
    if not slow >= 1.0:
        raise ValueError(f"--slow must be at least 1 (a stretch factor), got {slow}")
    if rounds < 1:
        raise ValueError(f"--rounds must be at least 1, got {rounds}")
    dataset = slowed(load_records_dataset(DATA), slow)
    model = fit(dataset, LAYOUT)
    plan = make_plan(dataset, seconds)
    extra = () if processes is None else ("--processes", str(processes))
    with tempfile.TemporaryDirectory() as tmp:
        if baseline is not None:
            result = paired(model, plan, Path(tmp), baseline, rounds, check_every, extra)
        else:
            model_path = Path(tmp) / "model.json"
            save_model(model_path, model)
            pushed, published, replay_s = replayed(model_path, plan, Path(tmp), REPO, extra)
            result = figures(model, plan, pushed, published, published.get("summary", {}),
                             check_every)  # fmt: skip
            result["replay_s"] = round(replay_s, 1)
    result["slow"] = slow
    result["movement_s_median"] = round(float(np.median(
        [(b - a) / RATE_HZ for _, a, b in plan.movements])), 2)  # fmt: skip
    result["load_average"] = [round(x, 2) for x in os.getloadavg()]
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0,
                        help="how long the replay lasts (default 60 s)")
    parser.add_argument("--check-every", type=int, default=1, metavar="K",
                        help="compare every K-th prediction with the offline engine (default "
                        "1: all)")
    parser.add_argument("--slow", type=float, default=1.0, metavar="F",
                        help="stretch every demonstration F times in time (default 1; 7: "
                        "movements of 4 to 8 s)")
    parser.add_argument("--baseline", metavar="COMMIT",
                        help="also run the predictor of COMMIT (a temporary git worktree), "
                        "alternating with this one's on the same replay; prints both and the "
                        "ratio of their p99 latencies; 'processes=1': this worktree's in one "
                        "process (--processes 1)")
    parser.add_argument("--processes", type=int, choices=(1, 2), default=None,
                        help="this worktree's predictor's --processes (default: its own "
                        "default, 2 on two cores)")
    parser.add_argument("--rounds", type=int, default=2,
                        help="with --baseline: runs of each side, their order swapped each "
                        "round (default 2)")
    args = parser.parse_args()
    print(json.dumps(main(args.seconds, args.check_every, args.slow, args.baseline,
                          args.rounds, args.processes)))
