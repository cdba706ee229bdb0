"""The decision rule (promp.decision): when it commits, on hand-made probability sequences."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from promp.decision import CommitRule, Decision, commit_steps


def run(rule: CommitRule, times, probabilities):
    """Every update through the rule: (final state, [(update index, decision)])."""
    state, made = rule.start(), []
    for i, (t, p) in enumerate(zip(times, probabilities, strict=True)):
        state, decision = state.update(t, p)
        if decision is not None:
            made.append((i, decision))
    return state, made


def test_it_commits_once_the_probability_has_stayed_above_for_the_window() -> None:
    rule = CommitRule(threshold=0.8, window=0.1)
    times = np.arange(10) * 0.03  # 0, 0.03, ..., 0.27 s
    low, high = [0.5, 0.3, 0.2], [0.1, 0.85, 0.05]
    probabilities = [low] * 3 + [high] * 7  # above from 0.09 s on
    state, made = run(rule, times, probabilities)
    # 0.09 + 0.1 = 0.19 s: the update at 0.21 s (index 7) is the first at least 0.1 s later.
    assert [i for i, _ in made] == [7]
    assert made[0][1] == Decision(primitive=1, probability=0.85, time=times[7], since=times[3])
    assert state.committed and state.decision == made[0][1]
    # Committed stays committed: a later drop, or another primitive, changes nothing.
    state, again = state.update(0.5, [0.9, 0.05, 0.05])
    assert again is None and state.decision == made[0][1]


def test_a_window_of_zero_commits_at_the_first_update_above() -> None:
    state, made = run(CommitRule(0.6, window=0.0), [0.0, 0.1, 0.2],
                      [[0.5, 0.5], [0.7, 0.3], [0.9, 0.1]])  # fmt: skip
    assert [(i, d.primitive) for i, d in made] == [(1, 0)]


def test_a_window_of_five_samples_at_50_hz_is_five_samples() -> None:
    """Sample times summed in floating point (0.16 - 0.06 = 0.0999...98 s) still make 0.1 s:
    the rule does not wait for a sixth sample."""
    times = np.arange(0.0, 1.0, 0.02)
    probabilities = [[0.95, 0.05] if i >= 7 else [0.5, 0.5] for i in range(times.size)]
    assert times[12] - times[7] < 0.1
    assert [i for i, _ in run(CommitRule(0.9, 0.1), times, probabilities)[1]] == [12]


def test_it_never_commits_below_the_threshold() -> None:
    times = np.linspace(0.0, 2.0, 101)
    probabilities = [[0.79, 0.11, 0.1]] * 101
    state, made = run(CommitRule(0.8, 0.1), times, probabilities)
    assert made == [] and not state.committed


def test_a_flicker_never_commits_however_long_it_is_above_in_all() -> None:
    """Above the threshold every other update: 1 s above in total, never 0.1 s in one run."""
    times = np.arange(100) * 0.02
    probabilities = [[0.95, 0.05] if i % 2 == 0 else [0.7, 0.3] for i in range(100)]
    assert run(CommitRule(0.9, 0.1), times, probabilities)[1] == []
    # Two primitives taking the lead in turn, both above a low threshold: the run restarts
    # with each change of leader.
    swap = [[0.6, 0.3, 0.1] if (i // 3) % 2 == 0 else [0.3, 0.6, 0.1] for i in range(100)]
    assert run(CommitRule(0.5, 0.1), times, swap)[1] == []
    # The same leader throughout: it commits.
    assert run(CommitRule(0.5, 0.1), times, [[0.6, 0.3, 0.1]] * 100)[1][0][0] == 5


def test_an_update_without_a_prediction_breaks_the_run() -> None:
    times = np.arange(8) * 0.03
    above = [0.9, 0.1]
    assert [i for i, _ in run(CommitRule(0.8, 0.1), times, [above] * 8)[1]] == [4]
    probabilities = [above, above, above, None, above, above, above, above]
    assert run(CommitRule(0.8, 0.1), times, probabilities)[1] == []  # starts again at 0.12 s
    longer = [above] * 3 + [None] + [above] * 6
    (_, made) = run(CommitRule(0.8, 0.1), np.arange(10) * 0.03, longer)
    assert [i for i, _ in made] == [8] and made[0][1].since == pytest.approx(0.12)


def test_the_window_is_seconds_of_the_movement_whatever_the_update_rate() -> None:
    """The same evidence (above the threshold from 0.5 s) looked at 100, 30 and 7 times a
    second, at irregular times: it commits no earlier than 0.6 s and at most one update
    later, where a window counted in updates would wait 5 x as long at 7 Hz as at 35 Hz."""
    rng = np.random.default_rng(0)
    for rate in (100.0, 30.0, 7.0):
        times = np.cumsum(rng.uniform(0.5, 1.5, 60) / rate)
        probabilities = [[0.95, 0.05] if t >= 0.5 else [0.6, 0.4] for t in times]
        _, made = run(CommitRule(0.9, 0.1), times, probabilities)
        (i, decision), = made
        assert decision.time >= 0.6 - 1e-9 and times[i - 1] < 0.6 + 1.5 / rate
        assert decision.since >= 0.5 and decision.since - 0.5 <= 1.5 / rate


def test_bad_updates_are_refused_and_change_nothing() -> None:
    rule = CommitRule(0.9, 0.1)
    state, _ = rule.start().update(0.5, [0.5, 0.5])
    for time, p, match in (
        (0.4, [0.5, 0.5], "time order"),
        (math.nan, [0.5, 0.5], "finite"),
        (0.6, [0.5, math.nan], "finite and in"),
        (0.6, [0.5, 0.3, 0.2], "3 probabilities after updates of 2"),
        (0.6, [[0.5, 0.5]], "1-D"),
        (0.6, [1.5, -0.5], "in \\[0, 1\\]"),
    ):
        with pytest.raises(ValueError, match=match):
            state.update(time, p)
    assert state.time == 0.5 and state.n_primitives == 2  # immutable: nothing changed
    for threshold, window in ((0.0, 0.1), (1.2, 0.1), (0.9, -0.1), (0.9, math.inf)):
        with pytest.raises(ValueError):
            CommitRule(threshold, window)


@settings(max_examples=200, deadline=None)
@given(
    steps=st.lists(
        st.tuples(st.floats(0.0, 0.05), st.integers(0, 2), st.floats(0.3, 1.0), st.booleans()),
        min_size=1, max_size=40,
    ),
    window=st.sampled_from([0.0, 0.02, 0.05, 0.1]),
)  # fmt: skip
def test_the_batch_over_thresholds_is_the_rule_at_each(steps, window) -> None:
    """:func:`commit_steps` (the evaluation's, every threshold at once) commits where the
    rule's updates do, at every threshold, on arbitrary sequences with gaps and ties."""
    times = np.cumsum([dt for dt, *_ in steps])
    probabilities = np.full((len(steps), 3), np.nan)
    for i, (_, leader, top, answered) in enumerate(steps):
        if answered:
            probabilities[i] = (1.0 - top) / 2
            probabilities[i, leader] = top
    thresholds = np.array([0.34, 0.5, 0.6, 0.75, 0.9, 0.99, 1.0])
    batch, primitives = commit_steps(times, probabilities, thresholds, window)
    for j, threshold in enumerate(thresholds):
        rows = [None if np.isnan(p).any() else p for p in probabilities]
        _, made = run(CommitRule(threshold, window), times, rows)
        expected = made[0] if made else (-1, None)
        assert batch[j] == expected[0]
        assert primitives[j] == (expected[1].primitive if made else -1)
