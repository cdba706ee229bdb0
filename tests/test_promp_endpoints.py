"""Where takes start and end (promp.endpoints): round trips, and starts or ends far from the
primitive's others, are flagged with their sizes in units; nothing else is, whatever the
units, the order or the faults around them. (Before: the round trips and the take that
starts 7 cm off of a real iCub set were learned from, unflagged.)"""

from __future__ import annotations

import re

import numpy as np
import pytest

from promp.data import Demonstration, Layout
from promp.endpoints import endpoint_findings, take_ends
from promp.quality import dataset_findings, split_flagged
from tests.bad_takes import BAD, OFF_START, ROUND_TRIPS, START_OFF, bad_takes
from tests.faults import inject
from tests.synthetic import LAYOUT, make_dataset


def flagged(findings) -> set[tuple[str, str]]:
    return {f.key for f in findings}


def centimetres(pattern: str, message: str) -> float:
    """The number of centimetres after ``pattern`` in ``message``."""
    match = re.search(pattern + r" ([0-9.]+) cm", message)
    assert match, f"{pattern!r} ... cm not in {message!r}"
    return float(match.group(1))


@pytest.mark.parametrize("seed", range(4))
def test_round_trips_and_a_take_that_starts_off_are_flagged_and_nothing_else(seed) -> None:
    dataset = bad_takes(seed)
    findings = dataset_findings(dataset, LAYOUT)
    assert flagged(findings) == BAD
    kinds = {(f.primitive, f.demo, f.kind) for f in findings}
    for key in ROUND_TRIPS:
        assert (*key, "round_trip") in kinds and (*key, "end") in kinds
    (start,) = [f for f in findings if f.key in OFF_START]
    assert start.kind == "start" and start.time == 0.0 and start.unit == "m"
    assert start.size == pytest.approx(START_OFF, abs=0.012)
    assert centimetres("hand starts", start.message) == pytest.approx(100 * start.size, rel=5e-3)
    kept, left_out = split_flagged(dataset, findings)
    assert set(left_out) == BAD and sum(len(v) for v in kept.values()) == 27


def test_a_round_trip_is_said_in_centimetres_against_the_other_takes() -> None:
    dataset = bad_takes(0)
    demos = dataset["base_to_left_goal"]
    trip = next(f for f in dataset_findings(dataset, LAYOUT) if f.kind == "round_trip")
    demo = next(d for d in demos if d.name == trip.demo)
    ends = take_ends(LAYOUT.extract(demo)[:, :3])
    assert trip.size == pytest.approx(ends.back) and trip.unit == "m"
    assert 0.09 < ends.back < 0.13  # back along its path, 18 cm short of a ~28 cm goal
    message = trip.message
    assert centimetres("it ends", message) == pytest.approx(100 * ends.back, rel=5e-3)
    assert centimetres("hand goes", message) == pytest.approx(100 * ends.excursion, rel=5e-3)
    # the others' range: the reaches, not the other round trip
    reaches = [take_ends(LAYOUT.extract(d)[:, :3]).back for d in demos
               if ("base_to_left_goal", d.name) not in ROUND_TRIPS]  # fmt: skip
    low, high = re.search(r"other takes end ([0-9.]+) cm to ([0-9.]+) cm", message).groups()
    assert float(low) == pytest.approx(100 * min(reaches), rel=5e-3)
    assert float(high) == pytest.approx(100 * max(reaches), rel=5e-3)
    assert trip.time == pytest.approx(demo.times[ends.turn] - demo.times[0])


def test_takes_that_all_start_at_one_point_do_not_flag_a_small_offset() -> None:
    """The synthetic reaches all start at 0 (1 mm of noise): a take 1.5 cm off is within the
    floor (a tenth of their 30 cm), one 7 cm off is not."""
    dataset = make_dataset(seed=3, n_demos=8)

    def shifted(metres: float) -> set:
        demo = dataset["left"][4]
        values = demo.values.copy()
        values[:, :3] += metres * np.array([0.0, 0.6, 0.8])
        moved = {**dataset, "left": [*dataset["left"][:4],
                                     Demonstration(demo.times, values, demo.columns, demo.name),
                                     *dataset["left"][5:]]}  # fmt: skip
        return {(f.demo, f.kind) for f in dataset_findings(moved, LAYOUT)}

    assert shifted(0.015) == set()
    assert shifted(0.07) == {("left4", "start"), ("left4", "end")}


def test_a_primitive_of_round_trips_flags_none_of_them() -> None:
    """A wave or a tap comes back every time: nothing is unlike the others."""
    dataset = bad_takes(1)
    layout = LAYOUT
    there_and_back = []
    for demo in dataset["base_to_top_goal"]:
        values = np.concatenate([demo.values, demo.values[::-1][1:]])
        times = np.arange(values.shape[0]) * demo.sample_period
        there_and_back.append(Demonstration(times, values, demo.columns, demo.name))
    assert endpoint_findings("wave", there_and_back, layout, np.zeros((10, 2), bool)) == []


def test_the_head_and_other_non_positions_are_not_checked() -> None:
    """A partner's head turns to look and back within a good take: only places in metres are
    checked (the simulated experiment's heads come back 0-71 % of their turn)."""
    dataset = bad_takes(2)
    as_angles = Layout((LAYOUT.modalities[1],))
    unitless = Layout((LAYOUT.modalities[0].__class__("hand", ("x", "y", "z"), unit=""),))
    for layout in (as_angles, unitless):
        assert dataset_findings(dataset, layout) == []


def test_the_flags_do_not_depend_on_scale_order_or_names() -> None:
    dataset = bad_takes(3)
    findings = {(f.primitive, f.demo, f.kind) for f in dataset_findings(dataset, LAYOUT)}
    scaled, reordered = {}, {}
    for primitive, demos in dataset.items():
        scaled[primitive] = [
            Demonstration(d.times, d.values * [10, 10, 10, 1, 1, 1], d.columns, d.name)
            for d in demos
        ]
        reordered[primitive] = list(reversed(demos))
    assert {(f.primitive, f.demo, f.kind) for f in dataset_findings(scaled, LAYOUT)} == findings
    assert {(f.primitive, f.demo, f.kind) for f in dataset_findings(reordered, LAYOUT)} == findings


def test_a_faulty_copy_flags_what_was_injected_and_the_bad_takes() -> None:
    """The faults of tests/faults.py on the bad takes: each found, no other take flagged, and
    a take that does not move is not also a round trip or a far start."""
    faulty, injected = inject(bad_takes(0), LAYOUT)
    findings = dataset_findings(faulty, LAYOUT)
    assert flagged(findings) == BAD | {(i.primitive, i.demo) for i in injected}
    still = {f.kind for f in findings if f.demo == "faulty/still"}
    assert "still" in still and not still & {"round_trip", "start", "end"}
    # the gap's 20 cm jump moves the take's end: said as well
    gap_kinds = {f.kind for f in findings if f.demo == "faulty/gap"}
    assert "gap" in gap_kinds and gap_kinds <= {"gap", "end"}
