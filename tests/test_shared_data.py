"""The tests that read the shared lab recordings find them in one place, are marked ``data``,
and skip with one line saying why where the recordings are absent (a user's clone; CI reruns
``-m data`` with ``STUDIO_SHARED_DATA`` pointed at an empty folder)."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from pathlib import Path

from tests.conftest import REPO

TESTS = REPO / "tests"


def literals(path: Path) -> list[tuple[int, str]]:
    """The string constants of ``path`` that are not docstrings, with their lines."""
    tree = ast.parse(path.read_text())
    docstrings = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
    return [(node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in docstrings]  # fmt: skip


def test_only_conftest_knows_where_the_shared_recordings_are() -> None:
    """Any other path to them would escape the ``data`` marker and the skip."""
    found = [f"{path.name}:{line}: {value!r}" for path in sorted(TESTS.glob("*.py"))
             if path.name not in ("conftest.py", Path(__file__).name)
             for line, value in literals(path)
             if value == "shared" or "shared/data" in value]  # fmt: skip
    assert found == []


MODULE = '''
from tests.conftest import SHARED_DATA, shared_set

FOLDER = SHARED_DATA / "lab-records-flt"


def test_reads_the_set():
    assert shared_set("lab-records-flt").is_dir()


def test_reads_nothing():
    pass
'''


def test_a_test_that_reads_them_is_marked_and_skips_without_them(tmp_path) -> None:
    module = tmp_path / "tests_elsewhere" / "test_reads_shared.py"
    module.parent.mkdir()
    module.write_text(textwrap.dedent(MODULE))
    empty = tmp_path / "no-shared-data"
    empty.mkdir()
    done = subprocess.run(  # the suite's conftest loaded as a plugin: its hooks and helpers
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "tests.conftest",
         "-m", "data", "-rs", "--rootdir", str(module.parent), str(module)],
        cwd=REPO, capture_output=True, text=True, timeout=300,
        env={**os.environ, "STUDIO_SHARED_DATA": str(empty), "PYTHONPATH": str(REPO)},
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "1 passed, 1 skipped" in done.stdout  # both marked (the module holds the path)
    assert f"shared lab recordings not found at {empty}/lab-records-flt" in done.stdout
