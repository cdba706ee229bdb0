"""promp.live.snapshot: what a session keeps of its outputs stays bounded however long it runs,
and each snapshot says whether anything was predicted and that it is a new one."""

from __future__ import annotations

from types import SimpleNamespace

from promp.live.snapshot import EVENTS_KEPT, TIMES_KEPT, SessionRecord


def prediction(number: int) -> SimpleNamespace:
    return SimpleNamespace(compute_s=0.001 * number, number=number)


def test_a_record_keeps_the_latest_outputs_within_its_bounds() -> None:
    record = SessionRecord()
    n = EVENTS_KEPT + 7
    events = [SimpleNamespace(time=float(i)) for i in range(n)]
    boundaries = [SimpleNamespace(movement=f"m{i}") for i in range(n)]
    record.add(events, boundaries, [prediction(i) for i in range(n)], list(range(n)))
    record.add([], [SimpleNamespace(movement=None)], [], [])  # a start ends no movement
    record.compute_s.extend([0.0] * TIMES_KEPT)
    snap = record.snapshot(1.0, (), (), None, {}, ())
    assert [e.time for e in snap.events] == [float(i) for i in range(7, n)]
    assert snap.ended == tuple(f"m{i}" for i in range(7, n))
    assert snap.recorded == tuple(range(7, n))
    assert len(record.compute_s) == TIMES_KEPT
    assert snap.n_events == n and snap.predictions == n  # counted, not kept
    assert snap.prediction.number == n - 1


def test_each_snapshot_is_new_and_says_when_nothing_was_predicted_yet() -> None:
    record = SessionRecord()
    first = record.snapshot(1.0, (), (), None, {}, ())
    assert first.prediction is None and first.predictions == 0
    second = record.snapshot(2.0, (), (), None, {}, ())
    assert second.version == first.version + 1
