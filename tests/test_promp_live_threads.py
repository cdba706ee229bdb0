"""A live session's threads (promp.live.session.SessionThreads): the loop steps until stopped
and a failing step is said, not fatal; the resolver looks for the streams again and again, a
failing look said too; start twice starts once; stop ends both, and does nothing on
threads stopped or never started; a failed step's note names the file and line it failed at."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

import promp.live.session
from promp.live.session import SessionThreads
from tests.conftest import wait_until

# How long a thread may take to do what the test waits for: generous for a loaded machine,
# short beside the 30 s default (a mutant that stops a thread costs mutation testing this).
DEADLINE_S = 10.0


@pytest.fixture(autouse=True)
def short_pauses(monkeypatch):
    """The pauses after a failure and between looks, short: the same loops, run faster (a
    mutant that breaks them then costs mutation testing seconds, not minutes)."""
    for name in ("ERROR_PAUSE_S", "FIND_EVERY_S", "FIND_WAIT_S"):
        monkeypatch.setattr(promp.live.session, name, 0.01)


class Intake:
    """What the threads use of the session's intake: looks and notes, counted."""

    def __init__(self, fail_looks: int = 0):
        self.looks, self.notes, self.fail_looks = [], [], fail_looks
        self.threads: set = set()

    def look(self, wait: float) -> None:
        self.looks.append(wait)
        self.threads.add(threading.current_thread())
        if len(self.looks) <= self.fail_looks:
            raise OSError("no network")

    def note(self, text: str) -> None:
        self.notes.append(text)


def test_the_loop_steps_until_stopped_and_a_failing_step_is_said() -> None:
    steps, seen = [], set()

    def step() -> bool:
        steps.append((threading.current_thread().name, threading.get_ident()))
        seen.add(threading.current_thread())
        if len(steps) == 3:
            raise RuntimeError("a defect")
        return len(steps) % 2 == 0

    intake = Intake()
    threads = SessionThreads(step, intake)
    threads.start()
    threads.start()  # already running: no second pair of threads
    wait_until(lambda: len(steps) >= 6, timeout=DEADLINE_S, what="six steps")
    threads.stop()
    done = len(steps)
    assert {name for name, _ in steps} == {"live-session"}
    assert len({ident for _, ident in steps}) == 1  # one loop, however often started
    assert len(intake.notes) == 1 and "RuntimeError" in intake.notes[0]
    assert intake.looks and all(w > 0 for w in intake.looks)
    assert {t.name for t in intake.threads} == {"live-resolver"}
    assert not any(t.is_alive() for t in seen | intake.threads)  # both ended
    assert all(t.daemon for t in seen | intake.threads)  # never keep the process alive
    assert len(steps) == done  # stopped: no step after


def test_a_failing_look_is_said_and_looked_again() -> None:
    intake = Intake(fail_looks=2)
    threads = SessionThreads(lambda: False, intake)
    threads.start()
    wait_until(lambda: len(intake.looks) >= 3, timeout=DEADLINE_S, what="three looks")
    threads.stop()
    assert len(intake.notes) == 2 and all("OSError" in n for n in intake.notes)
    threads.start()  # stopped threads start again
    wait_until(lambda: len(intake.looks) >= 4, timeout=DEADLINE_S, what="a look after the restart")
    threads.stop()


def test_a_step_that_worked_is_followed_by_the_next_at_once(monkeypatch) -> None:
    monkeypatch.setattr(promp.live.session, "IDLE_S", 3600.0)  # an idle pause would hang it
    steps = []

    def step() -> bool:
        steps.append(1)
        return len(steps) > 1 and len(steps) < 5  # idle once, then four that worked

    threads = SessionThreads(step, Intake())
    threads.start()
    wait_until(lambda: len(steps) >= 1, timeout=DEADLINE_S, what="the first step")
    threads.stop()  # interrupts the idle pause after the first (idle) step
    assert len(steps) == 1
    steps.append(1)  # the next step works: no pause
    threads.start()
    wait_until(lambda: len(steps) >= 5, timeout=DEADLINE_S, what="the steps that worked")
    threads.stop()


def test_stopping_threads_never_started_or_stopped_already_does_nothing() -> None:
    intake = Intake()
    threads = SessionThreads(lambda: False, intake)
    threads.stop()  # never started
    threads.start()
    wait_until(lambda: intake.looks, timeout=DEADLINE_S, what="a look")
    threads.stop()
    threads.stop()  # stopped already
    looks = len(intake.looks)
    threads.start()  # and they start again
    wait_until(lambda: len(intake.looks) > looks, timeout=DEADLINE_S, what="a look after")
    threads.stop()


def _fails() -> bool:
    raise KeyError("deep in the step")


def test_a_failing_step_s_note_names_where_it_failed() -> None:
    intake = Intake()
    threads = SessionThreads(lambda: _fails(), intake)  # raised a call below the step
    threads.start()
    wait_until(lambda: intake.notes, timeout=DEADLINE_S, what="the note of a failed step")
    threads.stop()
    where = f"{Path(__file__).name}:{_fails.__code__.co_firstlineno + 1}"
    assert "KeyError" in intake.notes[0] and where in intake.notes[0]
