"""The studio's loop (app.live.frame_loop): frames at its period, and at once when woken (the
robot taking over a live commitment waits for no frame period)."""

from __future__ import annotations

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
