"""The studio's loop (app.live.frame_loop): frames at its period, and at once when woken (the
robot taking over a live commitment waits for no frame period)."""

from __future__ import annotations

import time

from app.live.frame_loop import FrameLoop
from tests.conftest import wait_until


def test_a_woken_loop_runs_its_next_frame_without_waiting_for_the_period() -> None:
    failures: list = []
    loop = FrameLoop(lambda: None, failures.append, hz=1e-4)  # a period of 10,000 s
    loop.start()
    try:
        wait_until(lambda: loop.frames_done >= 1, what="the first frame")
        for n in (2, 3):
            loop.wake()
            wait_until(lambda n=n: loop.frames_done >= n, what=f"frame {n}, woken")
    finally:
        loop.stop()
    assert not failures and not loop._thread.is_alive()


def test_frames_longer_than_the_period_leave_viser_a_turn_to_send() -> None:
    """A frame holds viser's message group, and viser's sender takes messages only while no
    group is open, a window (1/60 s) after it was woken. Frames that each take longer than the
    period (a busy machine) ran back to back, the sender always looked inside one, and the
    browser got nothing: a fresh-clone run under a busy core waited 120 s for a via-point's list
    entry. A client on a websocket gets the frames' updates while they run: a window for most
    frames (``bench/frame_sends.py``, whose harness this is: 1 window in 3 s of 59 frames before;
    48 of 46 after, with two busy loops beside)."""
    from bench.frame_sends import measure

    result = measure("flush+rest", frame_s=0.05, seconds=3.0)
    assert result["frames"] >= 10, result
    assert result["windows"] >= result["frames"] / 4, result


def test_a_late_frame_is_followed_by_a_rest() -> None:
    """However late a frame ends, the loop rests a share of its time before the next one: with
    both cores busy, viser's sender woken by the flush got a window for 33-40 of 60 frames
    without the rest, every frame with it."""
    from app.live.frame_loop import MIN_REST_S, REST_SHARE

    spans: list[tuple[float, float]] = []

    def late_frame() -> None:
        start = time.perf_counter()
        time.sleep(0.03)  # two periods at 60 Hz
        spans.append((start, time.perf_counter()))

    failures: list = []
    loop = FrameLoop(late_frame, failures.append)
    loop.start()
    try:
        wait_until(lambda: len(spans) >= 6, what="six frames")
    finally:
        loop.stop()
    assert not failures
    for (start, end), (following, _) in zip(spans[:-1], spans[1:], strict=True):
        assert following - end >= max(MIN_REST_S, REST_SHARE * (end - start)) * 0.99
