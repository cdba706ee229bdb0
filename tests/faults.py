"""Faulty copies of real datasets: what a real rig's logs hold, injected on purpose.

Per primitive, three demonstrations are **added** (the clean ones stay as they are, so a
method that leaves the faulty ones out sees exactly the clean set):

* ``faulty/still``: 22 s at the set's rate in which the hand moves 1 mm (a recording started
  and stopped without a movement), at the start of the primitive's first demonstration;
* ``faulty/gap``: the primitive's demonstration of median duration with a 20 s pause of the
  timestamps after its middle sample and a 20 cm jump of the hand across it (the logger paused);
* ``faulty/slow``: its slowest demonstration, 3x slower (resampled at the same rate).

:func:`inject` works on a dataset in memory; :func:`write_faulty_records` writes a faulty copy
of a lab-record folder (13 columns) for the evaluation's command line::

    .venv/bin/python -m tests.faults ../shared/data/lab-records-flt /tmp/flt-faulty
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from promp.data import Demonstration, Layout
from promp.datasets import RECORD_COLUMNS, guess_layout, load_records_dataset

STILL_S = 22.0
STILL_MOTION = 0.001  # metres of motion in all
GAP_S = 20.0
JUMP = 0.20  # metres across the gap
SLOWER = 3.0


@dataclass(frozen=True)
class Injected:
    """One injected fault: where, and the kind of finding it must raise."""

    primitive: str
    demo: str
    kind: str
    time: float | None  # seconds after the demonstration's start, for a gap


def _still(first: Demonstration, period: float, rng: np.random.Generator) -> Demonstration:
    n = int(round(STILL_S / period)) + 1
    walk = np.cumsum(rng.normal(size=(n, first.values.shape[1])), axis=0)
    walk -= walk.mean(axis=0)
    walk *= STILL_MOTION / max(float(np.linalg.norm(np.ptp(walk, axis=0))), 1e-12)
    values = first.values[0] + walk
    return Demonstration(np.arange(n) * period, values, first.columns, name="faulty/still")


def _gap(demo: Demonstration, hand: list[int], rng: np.random.Generator) -> tuple:
    middle = demo.n_samples // 2
    times = demo.times.copy()
    times[middle:] += GAP_S
    values = demo.values.copy()
    direction = rng.normal(size=len(hand))
    values[middle:, hand] += JUMP * direction / np.linalg.norm(direction)
    gap = Demonstration(times, values, demo.columns, name="faulty/gap")
    return gap, float(demo.times[middle - 1] - demo.times[0])


def _slow(demo: Demonstration) -> Demonstration:
    period = demo.sample_period
    n = int(round(SLOWER * demo.duration / period)) + 1
    times = np.arange(n) * period
    source = demo.times[0] + times / SLOWER
    values = np.column_stack(
        [np.interp(source, demo.times, demo.values[:, c]) for c in range(demo.values.shape[1])]
    )
    return Demonstration(times, values, demo.columns, name="faulty/slow")


def inject(
    dataset: dict[str, list[Demonstration]], layout: Layout, seed: int = 0
) -> tuple[dict[str, list[Demonstration]], list[Injected]]:
    """A copy of ``dataset`` with the three faulty demonstrations added to every primitive
    (see the module docstring), and what was injected. The jump moves the layout's first
    modality (the hand)."""
    rng = np.random.default_rng(seed)
    out: dict[str, list[Demonstration]] = {}
    injected: list[Injected] = []
    for primitive, demos in dataset.items():
        columns = demos[0].columns
        hand = [columns.index(c) for c in layout.modalities[0].columns]
        period = float(np.median([d.sample_period for d in demos]))
        by_duration = sorted(demos, key=lambda d: d.duration)
        gap, at = _gap(by_duration[len(demos) // 2], hand, rng)
        added = [_still(demos[0], period, rng), gap, _slow(by_duration[-1])]
        out[primitive] = list(demos) + added
        injected += [
            Injected(primitive, "faulty/still", "still", None),
            Injected(primitive, "faulty/gap", "gap", at),
            Injected(primitive, "faulty/slow", "duration", None),
        ]
    return out, injected


def write_faulty_records(source: Path, target: Path, seed: int = 0) -> list[Injected]:
    """Copy the lab-record folder ``source`` to ``target`` (which must not exist) with the
    faults of :func:`inject` added; returns what was injected."""
    target = Path(target)
    if target.exists():
        raise ValueError(f"{target} exists: choose a new folder for the faulty copy")
    dataset = load_records_dataset(Path(source))
    layout = guess_layout(RECORD_COLUMNS[1:])
    faulty, injected = inject(dataset, layout, seed)
    for primitive, demos in faulty.items():
        for demo in demos:
            path = target / primitive / f"{demo.name}.txt"
            path.parent.mkdir(parents=True, exist_ok=True)
            np.savetxt(path, np.column_stack([demo.times, demo.values]), fmt="%.10g")
    return injected


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m tests.faults",
        description="Write a faulty copy of a lab-record dataset (still, gap + jump, 3x slow "
        "demonstrations added to every class).",
    )
    parser.add_argument("source", type=Path)
    parser.add_argument("target", type=Path)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    try:
        injected = write_faulty_records(args.source, args.target, args.seed)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for item in injected:
        at = "" if item.time is None else f" at {item.time:.3g} s"
        print(f"{item.primitive}/{item.demo}: {item.kind}{at}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
