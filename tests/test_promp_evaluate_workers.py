"""An evaluation killed by a signal (``kill``, ``kill -9``) leaves no worker process behind:
each of joblib's workers ends once the evaluation that started it has, even in the middle of
a fold (without that, a worker finishes its folds first: minutes of a sweep nobody waits for)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from tests.conftest import REPO, wait_until


class Forever:
    """A method whose fit never ends: a worker on it is still computing when it is killed."""

    def fit(self, train, sample_period) -> None:
        threading.Event().wait()

    def infer(self, demo, n_observed, observe, alpha_method):
        raise AssertionError("never reached")


SWEEP = """
from promp.evaluate.sweep import run_sweep
from tests.synthetic import LAYOUT, make_dataset
from tests.test_promp_evaluate_workers import Forever

run_sweep(Forever, make_dataset(n_demos=4, seed=0), LAYOUT, [50.0], ["ml"], [["hand"]], jobs=2)
"""


def children(pid: int) -> set[int]:
    """The processes whose parent is ``pid`` (Linux's /proc)."""
    found = set()
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and stat(int(entry.name))[1] == str(pid):
                found.add(int(entry.name))
        except (OSError, IndexError):  # gone meanwhile
            continue
    return found


def stat(pid: int) -> list[str]:
    """A process's state and its parent (``/proc/PID/stat`` after the name)."""
    return (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()


def alive(pid: int) -> bool:
    try:
        return stat(pid)[0] != "Z"  # a zombie has ended; only its parent's wait is missing
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux's /proc")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_a_killed_evaluation_leaves_no_worker_running(sig) -> None:
    evaluation = subprocess.Popen([sys.executable, "-c", SWEEP], cwd=REPO,
                                  start_new_session=True)  # fmt: skip
    try:
        def started() -> set[int]:
            found = {pid for pid in children(evaluation.pid) if alive(pid)}
            return found if len(found) >= 2 else set()

        workers = wait_until(started, timeout=120, what="the evaluation's workers")
        assert evaluation.poll() is None  # killed while its workers work
        evaluation.send_signal(sig)
        evaluation.wait(timeout=60)
        wait_until(lambda: not any(alive(pid) for pid in workers), timeout=60,
                   what=lambda: f"the workers {sorted(p for p in workers if alive(p))} to end")
    finally:
        try:
            os.killpg(evaluation.pid, signal.SIGKILL)  # whatever is left of the group
        except ProcessLookupError:
            pass
