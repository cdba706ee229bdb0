"""The live session's commitment (``--decide``): promp.CommitRule run on the session's own
predictions, one movement at a time; one ``decision`` event per movement, at the prediction
where the rule commits, and the ``committed`` channel of the timing outlet."""

from __future__ import annotations

import numpy as np

from promp.decision import CommitRule
from promp.live.commitment import DECISION, Commitment, Committing
from promp.live.outlets import TIMING_LABELS, PredictionOutlets, outlet_specs
from promp.live.session import LiveOptions
from promp.live.status import LiveEvent
from tests.live_fakes import FakeTransport, Tap, begun_and_ended, synthetic_model

RULE = CommitRule(threshold=0.95, window=0.1)
COMMITTED = TIMING_LABELS.index("committed")
model = synthetic_model


class Run:
    """A session observing the hand of unseen movements (Begin / End), publishing as
    ``robot``: what each step gave its sinks, and what the outlets were pushed."""

    def __init__(self, decide: CommitRule | None, classes=("right", "left")):
        self.transport = FakeTransport()
        outlets = PredictionOutlets(outlet_specs(model(), "robot", None), self.transport.outlet)
        self.tap = Tap()
        begun_and_ended(model(), LiveOptions(start="call", decide=decide), classes,
                        transport=self.transport, outlets=outlets, sinks=[self.tap])  # fmt: skip
        self.outputs = list(self.tap.outputs)
        self.predictions = [p for o in self.outputs for p in o.predictions]
        self.events = [e for o in self.outputs for e in o.events]

    def pushed(self, kind: str) -> list:
        return self.transport.outlets[f"robot-{kind}"].pushed


def offline(predictions) -> dict[int, tuple[int, int]]:
    """Per movement, the seq of the prediction where the rule, run on its published
    predictions from a fresh start, commits, and the primitive."""
    found: dict[int, tuple[int, int]] = {}
    states: dict[int, object] = {}
    for p in predictions:
        if p.movement in found:
            continue
        state = states.get(p.movement, RULE.start())
        states[p.movement], decision = state.update(p.elapsed, p.probabilities)
        if decision is not None:
            found[p.movement] = (p.seq, decision.primitive)
    return found


def test_one_decision_event_per_movement_at_the_prediction_the_rule_commits() -> None:
    run = Run(RULE)
    names = list(model().names)
    expected = offline(run.predictions)
    movements = sorted({p.movement for p in run.predictions})
    assert len(movements) == 2 and sorted(expected) == movements  # both commit
    for movement, truth in zip(movements, ("right", "left"), strict=True):
        seq, primitive = expected[movement]
        assert names[primitive] == truth
        steps = [o for o in run.outputs
                 if any(e.kind == DECISION and f"movement {movement} " in e.text
                        for e in o.events)]  # fmt: skip
        assert len(steps) == 1  # one event, once a movement
        (event,) = [e for e in steps[0].events if e.kind == DECISION]
        # emitted with the prediction that committed, in the same step
        (p,) = [p for p in steps[0].predictions if p.seq == seq]
        assert p.committed is not None and p.committed.index == primitive
        assert event.time == p.last
        assert event.text == (f"movement {movement} committed to {truth!r} at "
                              f"{p.elapsed:.3f} s ({100 * p.phase.value:.0f} % observed, "
                              f"p {p.probabilities[primitive]:.2f})")  # fmt: skip
        # before it the movement is undecided, from it on committed to the same primitive
        mine = [q for q in run.predictions if q.movement == movement]
        assert all(q.committed is None for q in mine if q.seq < seq)
        assert all(q.committed.index == primitive for q in mine if q.seq >= seq)
    assert sum(e.kind == DECISION for e in run.events) == 2
    sent = [row[0] for row, _ in run.pushed("events")]
    assert sum(" committed to " in text for text in sent) == 2


def test_the_timing_outlet_carries_the_committed_primitive() -> None:
    run = Run(RULE)
    expected = offline(run.predictions)
    rows = np.vstack([row for row, _ in run.pushed("timing")])
    assert rows.shape == (len(run.predictions), len(TIMING_LABELS))
    for row, p in zip(rows, run.predictions, strict=True):
        assert row[0] == p.seq
        seq, primitive = expected[p.movement]
        assert row[COMMITTED] == (primitive if p.seq >= seq else -1)
    # the second movement starts undecided although the first committed
    first, second = sorted(expected)
    start = next(i for i, p in enumerate(run.predictions) if p.movement == second)
    assert rows[start - 1, COMMITTED] == expected[first][1]
    assert rows[start, COMMITTED] == -1


def test_no_decision_without_decide() -> None:
    run = Run(None, classes=("right",))
    assert offline(run.predictions)  # the rule would have committed
    assert not any(e.kind == DECISION or "committed" in e.text for e in run.events)
    assert all(p.committed is None for p in run.predictions)
    rows = np.vstack([row for row, _ in run.pushed("timing")])
    assert np.all(rows[:, COMMITTED] == -1)


def test_a_failed_prediction_breaks_the_run_and_a_cut_back_one_is_not_taken() -> None:
    """Committing alone: an update without a prediction starts the window again (the rule's
    word), the still end's last prediction (earlier on the movement's clock) is left out
    rather than refused, and a new movement starts from the rule's start."""
    sure = np.array([0.95, 0.05])
    c = Committing(RULE, ("a", "b"))
    c, made = c.update(1, 0.00, sure, 0.0, 10.00)
    c = c.missed(1, 0.05)
    c, made = c.update(1, 0.10, sure, 0.1, 10.10)
    assert made is None  # 0.1 s after the first update, but the run began again at 0.1 s
    c, made = c.update(1, 0.15, sure, 0.2, 10.15)
    assert made is None
    c, made = c.update(1, 0.20, sure, 0.3, 10.20)
    assert made == Commitment(1, 0, "a", 0.20, 0.3, 0.95, 10.20)
    assert made.event() == LiveEvent(10.20, made.text, DECISION)
    c, again = c.update(1, 0.12, sure, 0.3, 10.12)  # cut back: not taken, still committed
    assert again is None and c.commitment == made
    c, made = c.update(2, 0.00, sure[::-1], 0.0, 11.00)
    assert made is None and c.commitment is None and c.movement == 2


def test_an_update_or_a_failure_at_the_same_time_as_the_last_is_taken() -> None:
    """Only an earlier time is cut back: a prediction at the same time as the last counts (a
    window of 0 commits on it), and so does a failure (the run begins again)."""
    sure = np.array([0.05, 0.95])
    c = Committing(CommitRule(threshold=0.9, window=0.0), ("a", "b"))
    c, made = c.update(1, 0.5, np.array([0.5, 0.5]), 0.5, 10.5)
    assert made is None
    c, made = c.update(1, 0.5, sure, 0.5, 10.5)
    assert made is not None and (made.index, made.primitive) == (1, "b")
    c = Committing(RULE, ("a", "b"))
    c, _ = c.update(1, 0.0, sure, 0.0, 10.0)
    c = c.missed(1, 0.0)
    c, made = c.update(1, 0.1, sure, 0.1, 10.1)
    assert made is None  # the run began again at 0.1 s


def test_a_failure_after_the_commitment_keeps_it() -> None:
    sure = np.array([0.95, 0.05])
    c = Committing(RULE, ("a", "b"))
    c, _ = c.update(1, 0.0, sure, 0.0, 10.0)
    c, made = c.update(1, 0.1, sure, 0.5, 10.1)
    assert made is not None
    c = c.missed(1, 0.2)
    assert c.commitment == made and c.movement == 1
    c, again = c.update(1, 0.3, sure, 0.6, 10.3)
    assert c.commitment == made and c.state is not None
