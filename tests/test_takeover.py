"""The robot takes over (app.live.takeover): from a live session's own predictions, the arm
starts once per committed movement, on the first prediction carrying the commitment; a new
movement (or a new session's) may start again; without a robot hand, or without the commit
rule, never, and the reason says why."""

from __future__ import annotations

import dataclasses

import pytest

from app.live.takeover import NO_HAND, NO_RULE, TakeOver, unavailable
from promp.decision import CommitRule
from promp.live.session import LiveOptions
from tests.live_fakes import begun_and_ended, synthetic_model


@pytest.fixture(scope="module")
def predictions():
    """Every prediction of a session committing (CommitRule 0.95 for 0.1 s) on two unseen
    movements, begun and ended by calls."""
    made: list = []
    begun_and_ended(synthetic_model(), LiveOptions(start="call", decide=CommitRule(0.95, 0.1)),
                    ("right", "left"), on_prediction=made.append)  # fmt: skip
    movements = sorted({p.movement for p in made})
    assert len(movements) == 2
    for m in movements:  # each commits part-way: predictions before and after
        of = [p for p in made if p.movement == m]
        assert of[0].committed is None and of[-1].committed is not None
    return made


def run(predictions, session: int = 1, enabled: bool = True, reason: str = ""):
    """The take-overs started, feeding ``predictions`` in order."""
    state, starts = TakeOver(), []
    for p in predictions:
        state, start = state.decide(p, (session, p.movement), enabled, reason)
        if start is not None:
            starts.append(start)
    return state, starts


def test_one_start_per_committed_movement_at_its_first_committed_prediction(predictions):
    state, starts = run(predictions)
    assert [s.movement for s in starts] == [(1, 1), (1, 2)]
    for start in starts:
        first = next(p for p in predictions
                     if p.movement == start.movement[1] and p.committed is not None)
        assert start.prediction is first  # not a later one of the same movement
        assert start.commitment == first.committed
        assert start.text.startswith(f"the robot takes over (committed to "
                                     f"{first.committed.primitive!r} at ")  # fmt: skip
    assert state.started is starts[-1]


def test_a_missed_committing_prediction_starts_on_the_next_one_seen(predictions):
    movement = [p for p in predictions if p.movement == 1]
    k = next(i for i, p in enumerate(movement) if p.committed is not None)
    _, starts = run(movement[:k] + movement[k + 2:])  # the loop skipped two predictions
    assert len(starts) == 1 and starts[0].prediction is movement[k + 2]


def test_the_same_movement_of_a_new_session_starts_again(predictions):
    movement = [p for p in predictions if p.movement == 1]
    state, first = run(movement, session=1)
    again = []
    for p in movement:
        state, start = state.decide(p, (2, p.movement), True)
        again += [start] if start is not None else []
    assert len(first) == 1 and [s.movement for s in again] == [(2, 1)]


def test_nothing_starts_before_a_commitment_unticked_or_unavailable(predictions):
    before = [p for p in predictions if p.committed is None]
    assert run(before)[1] == []
    assert run(predictions, enabled=False)[1] == []
    assert run(predictions, reason=NO_HAND)[1] == []
    # a commitment of another movement (a stale one) starts nothing
    stale = dataclasses.replace(predictions[-1], movement=predictions[-1].movement + 1)
    assert TakeOver().decide(stale, (1, stale.movement), True)[1] is None
    assert TakeOver().decide(None, (1, 1), True) == (TakeOver(), None)


def test_the_reason_says_a_missing_hand_before_a_missing_rule():
    assert unavailable(("hand", "head")) == ""
    assert unavailable(("hand",), commits=False) == NO_RULE
    assert unavailable(("human", "emg"), commits=False) == NO_HAND
    assert "'hand'" in NO_HAND and "Commit to a primitive" in NO_RULE


def test_without_a_robot_hand_the_checkbox_is_disabled_and_says_why():
    """The Infer tab's Robot takes over (app.panels.infer.takeover_section), on a workspace
    without 'hand': disabled, its hint and status line giving the reason; with one, enabled."""
    from types import SimpleNamespace

    from app.live.lsl_source import LslSource
    from app.panels.infer.takeover_section import TAKEOVER_HINT, TakeOverSection
    from app.ui.text import escape_html

    box = SimpleNamespace(value=True, disabled=False, hint=TAKEOVER_HINT)
    status = SimpleNamespace(content="")
    playback = SimpleNamespace(held=False)
    section = TakeOverSection(LslSource(transport=lambda: None), box, status, playback)
    section.step(None, ("human", "emg"))
    assert box.disabled and box.hint == f"Unavailable: {NO_HAND}"
    assert 'data-takeover="unavailable"' in status.content
    assert escape_html(NO_HAND) in status.content
    section.step(None, ("hand", "head"))
    assert not box.disabled and box.hint == TAKEOVER_HINT
    assert 'data-takeover="waiting"' in status.content
