"""Faults of real recordings: found, named, and kept out of learning unless asked for.

A real rig's logs hold demonstrations that never move, logging gaps with a jump across them,
timestamps that repeat or go back, rates that differ between streams and durations far outside
the others'. Each check below returns :class:`Finding` s (the demonstration, its file, the
time in it and the size, in words); nothing here edits or drops a demonstration.

Checks of one demonstration on its own (:func:`demo_findings`):

* ``timestamps``: found by the readers (:func:`increasing_samples`): samples whose time does not
  exceed every earlier one (a repeated stamp, a clock that went back) cannot be placed in time;
  the reader keeps the others and reports how many it set aside, and where;
* ``gap``: a step between samples longer than :data:`promp.gaps.GAP_FACTOR` times the
  demonstration's median step (the logger paused), with the jump of every modality across it
  and the demonstration's two spans (:func:`promp.gaps.duration_text`);
* ``jump``: a step of a modality larger than :data:`JUMP_SHARE` of the demonstration's extent
  in that modality **and** :data:`JUMP_RATIO` times its own pace (the step that
  :data:`JUMP_QUANTILE` of its moving steps stay under): a glitch, not a fast movement (a fast
  or jerky movement has many large steps; a large step of two streams at once, within
  :data:`JUMP_NEAR` samples, such as the dragged hand and the head the simulated partner turns
  after it, is the movement: a glitch is one stream's alone).

Checks against the other demonstrations (:func:`dataset_findings`):

* ``still``: a modality whose extent is below :data:`STILL_SHARE` of the median extent of the
  same modality over its primitive's other demonstrations (a recording started and stopped
  without a movement);
* ``rate``: a median sampling period more than :data:`RATE_FACTOR` times longer or shorter than
  the median over the dataset;
* ``duration``: a duration (without its gaps) more than :data:`DURATION_FACTOR` times beyond
  the longest (or shortest) of its primitive's other demonstrations that are not far out
  themselves: people move at different speeds (3-6x within a class of the lab recordings),
  a 98 s take among 4 s ones is something else;
* ``round_trip``, ``start``, ``end``: where a take starts and ends in a position modality,
  against its primitive's other takes (:mod:`promp.endpoints`: a take that comes back to where
  it started, or starts or ends far from where the others do), in the modalities it moves in.

Sizes and times are written by :mod:`promp.units` (``2.07 mm``, ``24.4 cm``, ``12°``,
``0.4 s``), as the studio writes them.

Every threshold is a ratio of the data's own quantities (no unit, no absolute time), so the
same rule holds for a hand in metres, a head in radians or an EMG in volts. On the three shared
lab sets and the simulated experiment none of them fires (``tests/test_promp_quality.py``)
but three takes that end elsewhere than their class's others (:mod:`promp.endpoints`); the
nearest clean values are given beside each constant.

Excluding is the caller's choice (:func:`split_flagged`): the evaluation and the studio leave
flagged demonstrations out of learning by default and say so; the files are never touched.
A demonstration with a gap may be repaired on request (:func:`promp.gaps.repair_gaps`), never
by default.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Mapping, Sequence

import numpy as np

from promp.data import Demonstration, Layout
from promp.endpoints import endpoint_findings
from promp.finding import KINDS, Finding
from promp.gaps import active_duration, duration_text, gap_steps
from promp.outliers import MIN_OTHERS, OUTLIER_Z, robust_deviation
from promp.units import amount, seconds

__all__ = [
    "DURATION_FACTOR", "Finding", "JUMP_NEAR", "JUMP_QUANTILE", "JUMP_RATIO", "JUMP_SHARE",
    "KINDS", "MIN_OTHERS", "OUTLIER_Z", "RATE_FACTOR", "STILL_SHARE", "by_demo",
    "dataset_findings", "demo_findings", "increasing_samples", "ordinary", "split_flagged",
    "timestamp_finding", "winsorized"
]  # fmt: skip

# A jump: over 20 % of the extent in one step and 5x the demonstration's own pace, the step
# that 90 % of its moving steps stay under (clean sets: at most 7 % of the extent on the hand;
# the simulated head turns 40 % of its extent in one step, at most 2.1x its pace; a take
# dragged in the browser by a slow page moves in a few 5 cm steps and stands still between
# them: its pace is those steps).
JUMP_SHARE = 0.2
JUMP_RATIO = 5.0
JUMP_QUANTILE = 0.9
# Two streams' large steps this many samples apart are one movement (the studio's simulated
# partner turns its head 2-3 samples after the dragged hand moves, at 50 Hz).
JUMP_NEAR = 5
# Still: under 10 % of the class's median extent (clean sets: at least 56 %).
STILL_SHARE = 0.1
# Rate: 3x off the dataset's median period (a 30 Hz camera beside 100 Hz logs; the studio
# records at 50 Hz, which may join an imported 100 Hz set).
RATE_FACTOR = 3.0
# Duration: over 2x the longest (or under half the shortest) of the others that are not far
# out themselves (clean sets: the longest is at most 1.3x the next one).
DURATION_FACTOR = 2.0

# ------------------------------------------------------------------------------ readers


def increasing_samples(times: np.ndarray) -> np.ndarray:
    """The samples that can be placed in time, boolean mask of shape (n,): those whose time
    exceeds every earlier sample's (a repeated stamp or a clock that went back is set aside;
    the first sample is always kept)."""
    times = np.asarray(times, dtype=float)
    if times.size == 0:
        return np.zeros(0, dtype=bool)
    before = np.maximum.accumulate(np.concatenate([[-np.inf], times[:-1]]))
    return times > before


def timestamp_finding(
    times: np.ndarray, keep: np.ndarray, primitive: str, demo: str, file: str = ""
) -> Finding | None:
    """The ``timestamps`` finding of a reader that kept ``keep`` of ``times`` (None if it kept
    every sample)."""
    dropped = np.flatnonzero(~keep)
    if dropped.size == 0:
        return None
    first = int(dropped[0])
    t0 = float(times[0])
    previous = float(np.max(times[:first]))
    what = "repeats" if times[first] == previous else "goes back from"
    return Finding(
        primitive,
        demo,
        "timestamps",
        float(times[first] - t0),
        float(dropped.size),
        "samples",
        f"timestamps not increasing: {dropped.size} of {times.size} samples set aside (the "
        f"first, sample {first}, {what} {seconds(previous - t0)} at {seconds(times[first] - t0)})",
        file,
    )


# ------------------------------------------------------------------------------ one demo


def _modality_steps(values: np.ndarray) -> np.ndarray:
    """Euclidean length of each step of a modality's values, shape (n - 1,)."""
    return np.linalg.norm(np.diff(values, axis=0), axis=1)


def _extent(values: np.ndarray) -> float:
    """The size of the box a modality's values span (norm of the per-column ranges)."""
    return float(np.linalg.norm(np.ptp(values, axis=0)))


def demo_findings(
    demo: Demonstration, layout: Layout, primitive: str, file: str = ""
) -> list[Finding]:
    """``gap`` and ``jump`` findings of one demonstration (see the module docstring)."""
    out: list[Finding] = []
    values = layout.extract(demo)
    t0 = float(demo.times[0])
    gaps = gap_steps(demo.times)
    median_step = float(np.median(np.diff(demo.times)))
    for i in gaps:
        length = float(demo.times[i + 1] - demo.times[i])
        jumps = []
        for modality in layout.modalities:
            x = values[:, layout.dims([modality.name])]
            jump = float(np.linalg.norm(x[i + 1] - x[i]))
            jumps.append(f"{modality.name} jumps {amount(jump, modality.unit)}")
        out.append(
            Finding(
                primitive,
                demo.name,
                "gap",
                float(demo.times[i] - t0),
                length,
                "s",
                f"a {seconds(length)} gap in the timestamps at {seconds(demo.times[i] - t0)} "
                f"({length / median_step:.0f}x the median step; {', '.join(jumps)} across it; "
                f"{duration_text(demo.times)})",
                file,
            )
        )
    across_gaps = set(int(i) for i in gaps)
    paced = {}
    for modality in layout.modalities:
        x = values[:, layout.dims([modality.name])]
        steps, extent = _modality_steps(x), _extent(x)
        moving = steps[steps > 1e-6 * extent]
        if steps.size >= 3 and extent > 0 and moving.size:
            # its own pace when it moves: a take that only moves in a few large steps (a hand
            # dragged in the browser by a slow page, sampled and held) has a large pace
            paced[modality.name] = (steps, extent, float(np.quantile(moving, JUMP_QUANTILE)))
    for name, (steps, extent, own) in paced.items():
        unit = layout.modality(name).unit
        for i in np.flatnonzero((steps > JUMP_SHARE * extent) & (steps > JUMP_RATIO * own)):
            # a step of the whole scene (another modality also moving a large share of its
            # extent within a few samples: streams are not sampled at the same instant, and a
            # head source lags the hand) is the movement; a glitch is one stream's alone
            near = slice(max(i - JUMP_NEAR, 0), i + JUMP_NEAR + 1)
            others = [
                bool(np.any(s[near] > JUMP_SHARE * e))
                for other, (s, e, _) in paced.items()
                if other != name
            ]
            if int(i) in across_gaps or any(others):
                continue
            out.append(
                Finding(
                    primitive,
                    demo.name,
                    "jump",
                    float(demo.times[i + 1] - t0),
                    float(steps[i]),
                    unit,
                    f"{name} jumps {amount(float(steps[i]), unit)} in one step at "
                    f"{seconds(demo.times[i + 1] - t0)} ({steps[i] / extent:.0%} of its extent; "
                    f"{JUMP_QUANTILE:.0%} of its moving steps are under {amount(own, unit)})",
                    file,
                )
            )
    return out


# ------------------------------------------------------------------------------ the dataset


def dataset_findings(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    files: Mapping[tuple[str, str], str] | None = None,
) -> list[Finding]:
    """Every finding of every demonstration of ``dataset`` ({primitive: demonstrations}):
    its own faults (:func:`demo_findings`) and how it compares with the others (``still``,
    ``rate``, ``duration``), ordered by primitive, demonstration and time.

    ``files`` names the file of a (primitive, demo) in the findings. The timestamps findings
    come from the readers, not from here (a :class:`Demonstration`'s times always increase).
    """
    files = files or {}
    out: list[Finding] = []
    all_demos = [d for demos in dataset.values() for d in demos]
    if not all_demos:
        return out
    periods = np.array([d.sample_period for d in all_demos])
    dataset_period = float(np.median(periods))
    for primitive, demos in dataset.items():
        extents = np.array(
            [
                [_extent(layout.extract(d)[:, layout.dims([m.name])]) for m in layout.modalities]
                for d in demos
            ]
        ).reshape(len(demos), len(layout.modalities))
        durations = np.array([active_duration(d) for d in demos])
        still = _still(extents)
        placed = by_demo(endpoint_findings(primitive, demos, layout, still, files))
        for j, demo in enumerate(demos):
            file = files.get((primitive, demo.name), "")
            out.extend(demo_findings(demo, layout, primitive, file))
            others = np.delete(np.arange(len(demos)), j)
            ratio = demo.sample_period / dataset_period
            if len(all_demos) > MIN_OTHERS and max(ratio, 1 / ratio) > RATE_FACTOR:
                out.append(
                    Finding(
                        primitive,
                        demo.name,
                        "rate",
                        None,
                        demo.sample_period,
                        "s",
                        f"sampled at {1 / demo.sample_period:.3g} Hz, the dataset at "
                        f"{1 / dataset_period:.3g} Hz ({max(ratio, 1 / ratio):.1f}x off)",
                        file,
                    )
                )
            if others.size < MIN_OTHERS:
                continue
            for m, modality in enumerate(layout.modalities):
                typical = float(np.median(extents[others, m]))
                if still[j, m]:
                    out.append(
                        Finding(
                            primitive,
                            demo.name,
                            "still",
                            None,
                            float(extents[j, m]),
                            modality.unit,
                            f"{modality.name} does not move: "
                            f"{amount(float(extents[j, m]), modality.unit)} in all, where "
                            f"{primitive}'s other demonstrations move "
                            f"{amount(typical, modality.unit)} (median)",
                            file,
                        )
                    )
            finding = _duration_finding(
                primitive, demo, durations[j], durations[others], file
            )
            if finding is not None:
                out.append(finding)
            out.extend(placed.get((primitive, demo.name), []))
    return out


def _still(extents: np.ndarray) -> np.ndarray:
    """Which takes do not move in which modality, bool of the shape of ``extents`` (n_demos,
    n_modalities): under :data:`STILL_SHARE` of the median extent of the primitive's other
    takes (none with fewer than :data:`MIN_OTHERS` others)."""
    still = np.zeros(extents.shape, dtype=bool)
    if extents.shape[0] <= MIN_OTHERS:
        return still
    for j in range(extents.shape[0]):
        typical = np.median(np.delete(extents, j, axis=0), axis=0)
        still[j] = (typical > 0) & (extents[j] < STILL_SHARE * typical)
    return still


def ordinary(logs: np.ndarray) -> np.ndarray:
    """Which of ``logs`` (log durations or log speeds; along the last axis, each row on its
    own) are not far out, boolean mask of the same shape: within :data:`OUTLIER_Z` robust
    deviations (median absolute deviation, as a normal's standard deviation) of the median,
    or within :data:`DURATION_FACTOR` of it (a class of nearly equal durations has almost no
    deviation). Two far-out takes then cannot hide each other."""
    logs = np.asarray(logs, dtype=float)
    centre = np.median(logs, axis=-1, keepdims=True)
    bound = np.maximum(OUTLIER_Z * robust_deviation(logs), math.log(DURATION_FACTOR))
    return np.abs(logs - centre) <= bound


def winsorized(logs: np.ndarray) -> np.ndarray:
    """``logs`` (along the last axis, each row on its own) with the far-out values
    (:func:`ordinary`) brought to the nearest ordinary one: the same values when none is far
    out. What the speed prior and the coupling of shape and speed are fitted to, so that one
    demonstration 30x slower than the others (kept by the user despite its finding) cannot
    stretch them."""
    logs = np.asarray(logs, dtype=float)
    keep = ordinary(logs)
    low = np.where(keep, logs, np.inf).min(axis=-1, keepdims=True)
    high = np.where(keep, logs, -np.inf).max(axis=-1, keepdims=True)
    return np.clip(logs, low, high)


def _duration_finding(
    primitive: str, demo: Demonstration, duration: float, others: np.ndarray, file: str
) -> Finding | None:
    ordinary_ones = others[ordinary(np.log(others))]
    longest, shortest = float(ordinary_ones.max()), float(ordinary_ones.min())
    if duration > DURATION_FACTOR * longest:
        what = f"{duration / longest:.1f}x the longest"
    elif duration < shortest / DURATION_FACTOR:
        what = f"{shortest / duration:.1f}x shorter than the shortest"
    else:
        return None
    return Finding(
        primitive,
        demo.name,
        "duration",
        None,
        duration,
        "s",
        f"lasts {duration_text(demo.times)}, {what} of {primitive}'s other demonstrations "
        f"({seconds(shortest)} to {seconds(longest)}, "
        f"median {seconds(float(np.median(ordinary_ones)))}"
        + (f"; {others.size - ordinary_ones.size} far out left aside"
           if ordinary_ones.size < others.size else "")
        + ")",
        file,
    )


# ------------------------------------------------------------------------------ exclusion


def by_demo(findings: Iterable[Finding]) -> dict[tuple[str, str], list[Finding]]:
    """The findings grouped by (primitive, demo), in their order."""
    out: dict[tuple[str, str], list[Finding]] = {}
    for finding in findings:
        out.setdefault(finding.key, []).append(finding)
    return out


def split_flagged(
    dataset: Mapping[str, Sequence[Demonstration]],
    findings: Iterable[Finding],
    include: Collection[tuple[str, str]] = (),
) -> tuple[dict[str, list[Demonstration]], dict[tuple[str, str], list[Finding]]]:
    """The demonstrations to learn from, and those left out with their findings.

    A demonstration with a finding is left out unless its (primitive, demo) is in
    ``include`` (the user chose to keep it). Nothing is copied or edited; a primitive keeps its
    place (and may end up with fewer demonstrations than it needs: the fit says so).
    """
    flagged = by_demo(findings)
    kept: dict[str, list[Demonstration]] = {}
    excluded: dict[tuple[str, str], list[Finding]] = {}
    for primitive, demos in dataset.items():
        kept[primitive] = []
        for demo in demos:
            key = (primitive, demo.name)
            if key in flagged and key not in include:
                excluded[key] = flagged[key]
            else:
                kept[primitive].append(demo)
    return kept, excluded
