"""A set of reaches with the bad takes of a real iCub set: round trips and a take that starts off.

Three primitives of 10 reaches each, at 100 Hz, from a base (takes start within ~1 cm of each
other) to a goal 25-31 cm away (ends within ~1.5 cm), the hand in metres and a head turning
towards the goal; the speed varies +-30 %. In ``base_to_left_goal``, records 1 and 2 are
**round trips**: the hand goes to the goal and comes back along its path, ending
:data:`ROUND_TRIP_FROM_GOAL` from the goal; in ``base_to_front_goal``, record 0 **starts**
:data:`START_OFF` from where the others start. ``base_to_top_goal`` is clean.
:func:`bad_takes` builds it in memory; :func:`write_bad_takes` writes it as a CSV dataset
(``<primitive>/<demo>.csv``) for the importers::

    .venv/bin/python -m tests.bad_takes /tmp/bad-takes
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from promp.data import Demonstration
from promp.datasets import write_csv_dataset
from tests.synthetic import COLUMNS, LAYOUT

GOALS = {
    "base_to_left_goal": np.array([0.05, 0.27, 0.06]),
    "base_to_front_goal": np.array([0.26, 0.02, 0.08]),
    "base_to_top_goal": np.array([0.06, 0.05, 0.27]),
}
ROUND_TRIP_FROM_GOAL = 0.18  # metres: where the round trips end
START_OFF = 0.07  # metres
ROUND_TRIPS = {("base_to_left_goal", "record1"), ("base_to_left_goal", "record2")}
OFF_START = {("base_to_front_goal", "record0")}
BAD = ROUND_TRIPS | OFF_START
RATE = 100.0
N_DEMOS = 10


def _reach(
    rng: np.random.Generator, start: np.ndarray, goal: np.ndarray, name: str, back: float = 0.0
) -> Demonstration:
    """A minimum-jerk reach from ``start`` to ``goal`` over 1.4-2.6 s (and, with ``back`` > 0,
    back along its path until ``back`` metres from the goal), with a bend and 0.5 mm noise;
    the head turns towards the goal as the hand goes."""
    duration = 2.0 * rng.uniform(0.7, 1.3)
    times = np.arange(int(round(duration * RATE)) + 1) / RATE
    s = times / times[-1]
    if back > 0:  # out in the first 55 %, back in the rest
        out = np.clip(s / 0.55, 0, 1)
        ret = np.clip((s - 0.55) / 0.45, 0, 1)
        travel = _min_jerk(out) - (back / np.linalg.norm(goal - start)) * _min_jerk(ret)
    else:
        travel = _min_jerk(s)
    bend = np.array([0.0, 0.0, 0.03]) * np.sin(np.pi * np.clip(travel, 0, 1))[:, None]
    hand = start + travel[:, None] * (goal - start) + bend
    hand += 0.0005 * rng.standard_normal(hand.shape)
    look = np.arctan2(hand[:, 1], 0.6 - hand[:, 0])  # the partner, 60 cm in front, follows
    head = np.column_stack([0.01 * rng.standard_normal(times.size), 0.2 * travel, look])
    return Demonstration(times, np.hstack([hand, head]), COLUMNS, name)


def _min_jerk(s: np.ndarray) -> np.ndarray:
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def bad_takes(seed: int = 0) -> dict[str, list[Demonstration]]:
    """The set described in the module docstring ({primitive: demonstrations}), layout
    :data:`tests.synthetic.LAYOUT` (hand in metres, head in radians)."""
    rng = np.random.default_rng(seed)
    base = np.array([-0.25, -0.05, 0.02])
    dataset: dict[str, list[Demonstration]] = {}
    for primitive, offset in GOALS.items():
        goal = base + offset
        demos = []
        for k in range(N_DEMOS):
            name = f"record{k}"
            start = base + 0.004 * rng.standard_normal(3)
            if (primitive, name) in OFF_START:
                direction = np.array([0.0, -0.6, 0.8])
                start = base + START_OFF * direction
            end = goal + 0.006 * rng.standard_normal(3)
            back = ROUND_TRIP_FROM_GOAL if (primitive, name) in ROUND_TRIPS else 0.0
            demos.append(_reach(rng, start, end, name, back))
        dataset[primitive] = demos
    return dataset


def write_bad_takes(target: Path, seed: int = 0) -> Path:
    """The set as a CSV dataset folder ``target`` (which must not exist); returns it."""
    target = Path(target)
    if target.exists():
        raise ValueError(f"{target} exists: choose a new folder")
    write_csv_dataset(target, bad_takes(seed))
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.bad_takes", description=__doc__)
    parser.add_argument("target", type=Path)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    write_bad_takes(args.target, args.seed)
    print(f"wrote {args.target} (layout: {LAYOUT.names})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
