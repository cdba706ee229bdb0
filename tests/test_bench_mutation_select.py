"""bench/mutation_select.py, the plugin that runs a mutant's tests in bench/mutation.py: a
mutant that never ends is stopped in the first test it holds, within that test's own limit,
not after its whole set's time."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
TESTS = """
import time


def test_fast():
    pass


def test_held():
    time.sleep(600)  # a mutant's endless loop


def test_long():
    pass
"""


def run_mutant(folder: Path) -> tuple[int, float]:
    """A mutant's run in mutmut's folder as bench/mutation.py lays it out: the plugin beside
    its map of modules to test files."""
    for name, source in (("mutation_select.py", "mutation_select.py"),
                         ("mutation_rules.py", "mutation.py")):  # fmt: skip
        (folder / name).write_text((REPO / "bench" / source).read_text())
    (folder / "tests").mkdir()
    (folder / "tests" / "test_x.py").write_text(TESTS)
    (folder / "mutation_tests.json").write_text(json.dumps({
        "tests": {"pkg.mod": ["tests/test_x.py"]}, "timeout_multiplier": 3.0,
        "timeout_constant": 1.0,
    }))  # fmt: skip
    durations = {"tests/test_x.py::test_fast": 0.1, "tests/test_x.py::test_held": 0.1,
                 "tests/test_x.py::test_long": 30.0}  # fmt: skip
    (folder / "mutmut-stats.json").write_text(json.dumps({"duration_by_test": durations}))
    (folder / "mutation_excluded.json").write_text(json.dumps({"pkg.mod": []}))
    env = {**os.environ, "MUTANT_UNDER_TEST": "pkg.mod.x_f__mutmut_1",
           "PYTHONPATH": str(folder)}  # fmt: skip
    began = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", "-p",
         "mutation_select", "--rootdir=.", "tests/test_x.py"],
        cwd=folder, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    return done.returncode, time.monotonic() - began


def test_a_mutant_that_never_ends_is_stopped_within_its_test_s_own_limit(tmp_path) -> None:
    code, seconds = run_mutant(tmp_path)
    assert code == 36  # mutmut's exit code for a timeout: caught
    # its test's limit is 0.1 x 3 + 1 s; the whole set's (30.2 + 1) x 3 = 94 s
    assert seconds < 60.0
