"""The stillness rule (promp/stillness.py): speeds, the moving spans of a recording, the pauses
inside a demonstration and their bound, and the same spans found as the samples come, whatever
their chunks, each decided soon after its sample."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from promp.data import Demonstration
from promp.fitting import learned_stillness
from promp.live.segmenter import Segmenter, StillRule
from promp.live.timebase import Rows
from promp.stillness import (
    MARGIN_S,
    MIN_MOVE_S,
    MIN_STILL_S,
    SMOOTH_S,
    MovingSpans,
    inner_pause,
    moving,
    moving_spans,
    pause_bound,
    speed,
    still_parts,
)
from tests.conftest import SHARED_DATA
from tests.synthetic import COLUMNS, LAYOUT

SETS = ("lab-records-heights", "lab-records-flt", "lab-records-flt-shapes")


def streamed(times, values, units, widths, cuts, min_still_s=MIN_STILL_S):
    """``MovingSpans`` fed ``times``/``values`` cut at ``cuts``, then finished: its events."""
    spans = MovingSpans(units, widths)
    events = []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        before = times[a - 1] if a else -np.inf
        events += [(e, times[b - 1], before)
                   for e in spans.push(times[a:b], values[a:b], min_still_s)]  # fmt: skip
    return events, spans.finish(min_still_s)


def check_equal_to_offline(times, values, units, widths, cuts, min_still_s=MIN_STILL_S):
    """The streamed starts and ends are the offline spans', each decided as soon as its
    samples allow: an end within ``min_still_s + SMOOTH_S`` of its last moving sample; a start
    within half a window of the moving sample that made its run of motion long enough
    (``MIN_MOVE_S`` and half a window), which comes less than ``min_still_s`` after the run's
    moving sample before it (a run may pause for less than that and go on), so within
    ``MIN_MOVE_S + SMOOTH_S + min_still_s`` of its first moving sample."""
    blocks, column = [], 0
    for unit, width in zip(units, widths, strict=True):
        blocks.append((values[:, column:column + width], unit))
        column += width
    offline = moving_spans(times, blocks, min_still_s)
    events, tail = streamed(times, values, units, widths, cuts, min_still_s)
    starts = [e for e, _, _ in events if e.kind == "start"] + [e for e in tail
                                                                 if e.kind == "start"]
    ends = [e for e, _, _ in events if e.kind == "end"] + [e for e in tail if e.kind == "end"]
    got = [(int(np.searchsorted(times, s.first - MARGIN_S, side="left")),
            int(np.searchsorted(times, e.last + MARGIN_S, side="right")))
           for s, e in zip(starts, ends, strict=True)]  # fmt: skip
    assert len(starts) == len(ends)
    assert got == offline
    for event, newest, before in events:  # decided on the samples up to the chunk's last
        assert event.decided == newest
        # no later than the chunk that brought the samples up to the bound: the chunk before
        # it ended earlier
        if event.kind == "end":
            assert before < event.last + min_still_s + SMOOTH_S
        else:
            assert event.last - event.first >= MIN_MOVE_S + 0.5 * SMOOTH_S
            assert before <= event.last + 0.5 * SMOOTH_S
            assert event.last < event.first + MIN_MOVE_S + 0.5 * SMOOTH_S + min_still_s
    return offline


def test_speed_is_the_distance_over_the_window_even_at_the_ends() -> None:
    times = np.arange(100) * 0.01
    values = np.column_stack([0.05 * times, np.zeros(100), np.ones(100)])
    assert_allclose(speed(times, values), 0.05, rtol=1e-9)
    angles = np.column_stack([np.mod(3.0 * times + np.pi - 0.1, 2 * np.pi) - np.pi])
    assert_allclose(speed(times, angles, angular=True), 3.0, rtol=1e-9)  # across the wrap


def test_a_burst_of_late_samples_is_not_faster_than_the_hand() -> None:
    """Push-time stamps of a late sender: 0.3 s without samples, then the backlog a few
    microseconds apart; the speed is at most the 0.3 s of motion seen within one window
    (2.5 cm/s * (0.3 + 0.2) / 0.2), not a step over microseconds."""
    true = np.arange(200) * 0.01
    stamps = true.copy()
    late = (true > 0.6) & (true < 0.9)
    stamps[late] = 0.9 + 1e-5 * np.arange(late.sum())
    stamps = np.maximum.accumulate(stamps + 1e-9 * np.arange(200))
    values = np.column_stack([0.025 * true, 0 * true, 0 * true])
    assert speed(stamps, values).max() <= 0.025 * (0.3 + SMOOTH_S) / SMOOTH_S + 1e-9


def test_the_pause_inside_a_demonstration_and_its_bound() -> None:
    times = np.arange(400) * 0.01
    x = np.concatenate([np.zeros(50), np.linspace(0, 0.1, 100), np.full(100, 0.1),
                        np.linspace(0.1, 0.2, 100), np.full(50, 0.2)])  # fmt: skip
    values = np.column_stack([x, 0 * x, 0 * x])
    pause = inner_pause(times, [(values, "m")])
    assert 0.8 <= pause <= 1.2  # the 1 s hold in the middle, not the still ends
    assert inner_pause(times[:200], [(values[:200], "m")]) == 0.0
    assert pause_bound([]) == 0.0 and pause_bound([0.0, 0.0]) == 0.0
    assert pause_bound([0.0, 0.7]) == 0.7
    assert_allclose(pause_bound([0.6, 0.8, 0.0, 0.7]), 0.9)  # the longest, + mean spacing
    # a hesitation far beyond the others does not set the bound
    assert_allclose(pause_bound([0.6, 0.62, 0.64, 0.66, 0.68, 0.7, 5.0]), 0.72)


# ---------------------------------------------------------------------------- generated streams


@st.composite
def recordings(draw):
    """A recording of a hand (m) and maybe a head (rad): phases still, moving, slow (below
    the idle speed) and twitching, at irregular steps, with a little noise; chunk cuts."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_phases = draw(st.integers(1, 12))
    times, hand, head = [0.0], [np.zeros(3)], [np.zeros(2)]
    for _ in range(n_phases):
        kind = draw(st.sampled_from(["still", "move", "slow", "twitch"]))
        length = draw(st.floats(0.05, 1.5))
        velocity = rng.normal(size=3)
        velocity *= {"still": 0.0, "move": rng.uniform(0.05, 0.4), "slow": 0.01,
                     "twitch": 0.3}[kind] / np.linalg.norm(velocity)  # fmt: skip
        if kind == "twitch":
            length = min(length, 0.1)
        turn = rng.uniform(-4, 4, 2) if kind == "move" and draw(st.booleans()) else np.zeros(2)
        end = times[-1] + length
        while times[-1] < end:
            dt = rng.uniform(0.004, 0.03)
            times.append(times[-1] + dt)
            hand.append(hand[-1] + velocity * dt + rng.normal(scale=2e-5, size=3))
            head.append(head[-1] + turn * dt)
    times = 100.0 + np.asarray(times)
    head = np.mod(np.asarray(head) + np.pi, 2 * np.pi) - np.pi  # wrapped, as sensors give
    with_head = draw(st.booleans())
    values = np.hstack([np.asarray(hand), head]) if with_head else np.asarray(hand)
    units, widths = (("m", "rad"), (3, 2)) if with_head else (("m",), (3,))
    sizes = draw(st.lists(st.integers(1, 40), min_size=1, max_size=200))
    cuts = np.unique(np.clip(np.cumsum([0, *sizes]), 0, times.size))
    cuts = [*cuts.tolist(), times.size] if cuts[-1] != times.size else cuts.tolist()
    still = draw(st.sampled_from([MIN_STILL_S, 0.8, 1.3]))
    return times, values, units, widths, cuts, still


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(recordings())
def test_streamed_spans_equal_the_offline_spans_whatever_the_chunks(recording) -> None:
    times, values, units, widths, cuts, still = recording
    check_equal_to_offline(times, values, units, widths, cuts, still)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(recordings())
def test_the_segmenter_cuts_the_rows_the_offline_spans_hold(recording) -> None:
    times, values, units, widths, cuts, still = recording
    blocks, column, cols = [], 0, []
    for unit, width in zip(units, widths, strict=True):
        blocks.append((values[:, column:column + width], unit))
        cols.append((slice(column, column + width), unit))
        column += width
    offline = moving_spans(times, blocks, still)
    pause = float(np.nextafter(still, 0)) if still > MIN_STILL_S else 0.0  # ends at >= still
    seg = Segmenter("still", values.shape[1], cols, max_movement_s=1e9,
                    rule=StillRule({"p": pause}))  # fmt: skip
    ended = []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        ended += [x.movement for x in seg.feed(Rows(times[a:b], values[a:b]))
                  if x.kind == "end"]  # fmt: skip
    got = [(int(np.searchsorted(times, m.times[0])), int(np.searchsorted(times, m.times[-1])) + 1)
           for m in ended]  # fmt: skip
    assert got == offline[:len(got)]
    if len(got) < len(offline):  # only the last, when its end cannot be decided yet
        assert len(got) == len(offline) - 1
        last_moving = times[np.flatnonzero(moving(times, blocks))[-1]]
        assert times[-1] - last_moving < still + SMOOTH_S / 2 + 0.03  # 0.03: the longest step


# ---------------------------------------------------------------------------- the shared sets


def shared_session(name: str):
    """Every take of a shared set (sorted by class and name), one after the other with 1.5 s
    of its last sample held between them (the hand carried on from where the last ended)."""
    from promp.datasets import load_records_dataset

    root = SHARED_DATA / name
    if not root.is_dir():
        pytest.skip(f"shared lab recordings not found at {root}")
    dataset = load_records_dataset(root)
    times, values, t0, offset = [], [], 0.0, np.zeros(3)
    for klass in sorted(dataset):
        for demo in sorted(dataset[klass], key=lambda d: d.name):
            xyz = demo.select(["x", "y", "z"])
            xyz = xyz - xyz[0] + offset
            t = demo.times - demo.times[0]
            hold = t[-1] + np.arange(1, 151) * 0.01
            times += [t0 + t, t0 + hold]
            values += [xyz, np.repeat(xyz[-1:], 150, axis=0)]
            t0, offset = t0 + hold[-1] + 0.01, xyz[-1]
    return np.concatenate(times), np.vstack(values)


@pytest.mark.parametrize("name", SETS)
def test_streamed_spans_equal_the_offline_spans_on_the_shared_sets(name: str) -> None:
    times, values = shared_session(name)
    rng = np.random.default_rng(0)
    cuts = np.unique(np.concatenate([[0], np.cumsum(rng.integers(1, 30, times.size)), [0]]))
    cuts = [*cuts[cuts < times.size].tolist(), times.size]
    offline = check_equal_to_offline(times, values, ("m",), (3,), cuts)
    n_takes = sum(1 for _ in np.flatnonzero(np.diff(times) > 0.02)) // 1  # noqa: F841
    assert len(offline) >= 60  # every take a movement (none split: checked per take below)


@pytest.mark.parametrize("name", SETS)
def test_no_take_of_the_shared_sets_pauses_for_the_rule(name: str) -> None:
    from promp.datasets import load_records_dataset

    root = SHARED_DATA / name
    if not root.is_dir():
        pytest.skip(f"shared lab recordings not found at {root}")
    for demos in load_records_dataset(root).values():
        for demo in demos:
            blocks = [(demo.select(["x", "y", "z"]), "m")]
            assert len(moving_spans(demo.times, blocks)) == 1
            assert inner_pause(demo.times, blocks) < MIN_STILL_S


def test_a_twitch_shorter_than_the_minimum_is_never_started() -> None:
    """A jump (a tracking glitch: 3 cm in one step) and 8 mm in 0.03 s are moving for about a
    window (the window's width of a burst): twitches; 5 cm in 0.3 s is a movement."""
    times = np.arange(300) * 0.01
    for size, steps, found in ((0.03, 1, 0), (0.008, 4, 0), (0.05, 31, 1)):
        x = np.concatenate([np.zeros(100), np.linspace(0, size, steps + 1)[1:],
                            np.full(200 - steps, size)])  # fmt: skip
        values = np.column_stack([x, 0 * x, 0 * x])
        events, tail = streamed(times, values, ("m",), (3,), [0, 150, 300])
        assert len(moving_spans(times, [(values, "m")])) == found
        assert [e.kind for e, _, _ in events] + [e.kind for e in tail] == \
            ["start", "end"] * found  # fmt: skip


def test_a_fit_learns_each_modalitys_stillness_of_each_demonstration_every_time() -> None:
    """``promp.fitting.learned_stillness`` keeps each demonstration's parts once computed (every
    candidate basis of a choice and every fold of an evaluation learn them again): what it
    returns, the first time and from what it kept, is :func:`still_parts` of each modality's own
    columns, here the hand still for its first 0.6 s and the head for its first 1.2 s."""
    times = np.arange(0.0, 3.0, 0.02)
    demos = []
    for shift in (0.0, 0.1):
        values = np.zeros((times.size, len(COLUMNS)))
        values[:, :3] = np.clip((times - 0.6 - shift) / 0.8, 0.0, 1.0)[:, None] * 0.3
        values[:, 3:] = np.clip((times - 1.2 - shift) / 0.8, 0.0, 1.0)[:, None] * 0.5
        demos.append(Demonstration(times, values, COLUMNS))
    expected = {
        name: np.array([still_parts(times, [(d.values[:, cols], unit)]) for d in demos]).T
        for name, cols, unit in (("hand", slice(0, 3), "m"), ("head", slice(3, 6), "rad"))
    }
    assert expected["hand"][0, 0] < expected["head"][0, 0]  # the two modalities differ
    for _ in range(2):  # computed, then kept
        learned = learned_stillness(demos, LAYOUT)
        for name, parts in expected.items():
            assert_allclose([learned[name][p] for p in ("lead", "pause", "trail")], parts)
