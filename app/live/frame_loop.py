"""The studio's loop: one thread that runs a frame about 60 times a second.

:class:`FrameLoop` owns the thread, the tasks other threads ask it to run at its next frame
(:meth:`FrameLoop.call`), and what it has done: the start times of the latest frames and the
count of whole frames run (a test that checks that nothing happened waits for frames, not for a
time). :meth:`FrameLoop.wake` runs the next frame at once (a live commitment the arm acts on
waits for no frame period). What a frame does is the studio's (:meth:`app.studio.Studio.step`);
a frame that raises is reported to ``failed`` and the loop goes on.
"""

from __future__ import annotations

import collections
import contextlib
import threading
import time
from collections.abc import Callable, Iterator

import viser

LOOP_HZ = 60.0
FRAMES_KEPT = 4096  # the latest frames' start times (about a minute at 60 Hz)
# The rest after a frame, however late it ends: at least this share of the frame's own time and
# at least MIN_REST_S. A frame holds viser's message group (:func:`one_message_group`) and viser's
# sender only takes messages while no group is open: frames run back to back (each longer than
# the period, as on a busy machine) left it no turn. With both cores busy, frames of 50 ms sent
# a window after 33-40 of 60 frames without the rest, after every frame with it.
REST_SHARE = 0.25
MIN_REST_S = 0.002


@contextlib.contextmanager
def one_message_group(server: viser.ViserServer) -> Iterator[None]:
    """What is sent inside, applied by the browser together (``server.atomic()``), and handed
    to viser's sender at once when the group closes (``server.flush()``).

    Viser's sender looks for messages a window (1/60 s) after it was last woken, and takes none
    while a group is open. Woken when a frame's group closed, it looked again one window later:
    about when the next frame's group closes, and inside it when frames run late. The flush
    makes it look at once, in the rest the loop leaves after each frame (:data:`REST_SHARE`)."""
    with server.atomic():
        yield
    server.flush()


class FrameLoop:
    """Runs ``frame()`` ``hz`` times a second on a thread of its own (see the module docstring).

    Parameters
    ----------
    frame : callable
        One frame; it calls :meth:`run_tasks` where the asked-for tasks belong.
    failed : callable
        ``failed(exception)``, called on the loop's thread when a frame raised.
    hz : float
    """

    def __init__(
        self,
        frame: Callable[[], None],
        failed: Callable[[Exception], None],
        hz: float = LOOP_HZ,
    ):
        self.frame = frame
        self.failed = failed
        self.period = 1.0 / hz
        self.frame_starts: collections.deque[float] = collections.deque(maxlen=FRAMES_KEPT)
        self.frames_done = 0  # whole frames run
        self._tasks: collections.deque[Callable[[], None]] = collections.deque()
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread = threading.Thread(target=self._run, name="studio-loop", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def call(self, task: Callable[[], None]) -> None:
        """Run ``task()`` on the loop's thread at its next frame (from any thread)."""
        self._tasks.append(task)

    def wake(self) -> None:
        """Run the next frame now rather than at the next period (from any thread)."""
        self._wake.set()

    def run_tasks(self) -> None:
        """The tasks asked for so far, in order (from the frame)."""
        while self._tasks:
            self._tasks.popleft()()

    def step(self) -> None:
        """One frame, counted (also callable directly, e.g. from tests)."""
        self.frame_starts.append(time.perf_counter())
        self.frame()
        self.frames_done += 1

    def _run(self) -> None:
        while not self._stop.is_set():
            start = time.perf_counter()
            try:
                self.step()
            except Exception as exc:  # a bug in one frame must not end the loop
                self.failed(exc)
            took = time.perf_counter() - start
            time.sleep(max(MIN_REST_S, REST_SHARE * took))  # the sender's turn (see REST_SHARE)
            self._wake.wait(max(0.0, self.period - (time.perf_counter() - start)))
            self._wake.clear()

    def stop(self) -> None:
        """Stop after the frame under way (waits up to 5 s for it)."""
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
