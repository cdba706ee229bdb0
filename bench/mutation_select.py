"""A pytest plugin for bench/mutation.py: a mutant of a module runs only that module's tests.

mutmut runs, for each mutant, the tests its first clean run saw reach the mutated function.
A function of the pipeline's core is reached by nearly every live test (a session steps it),
so each of its mutants that survives runs them all (a minute under load). bench/mutation.py
copies this file into mutmut's folder with ``mutation_tests.json``, a map of a module
(``promp.live.pipeline``) to the test files that test it; while mutmut runs a mutant of a
module in the map (``MUTANT_UNDER_TEST``), the tests of other files are deselected (those of
the module's files that reach the function still run, fastest first, as mutmut orders them).
A mutant of a module not in the map runs every test that reaches it. None selected: pytest
exits 5, which mutmut counts as "no tests" (not caught).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

MAP = Path(__file__).with_name("mutation_tests.json")


def files_for(mutant: str, tests: dict[str, list[str]]) -> list[str] | None:
    """The test files of the module ``mutant`` belongs to (the longest module of ``tests``
    its name starts with), or None."""
    modules = [m for m in tests if mutant.startswith(m + ".")]
    return tests[max(modules, key=len)] if modules else None


def pytest_collection_modifyitems(config, items) -> None:
    mutant = os.environ.get("MUTANT_UNDER_TEST", "")
    if "__mutmut_" not in mutant or not MAP.exists():
        return
    files = files_for(mutant, json.loads(MAP.read_text()))
    if files is None:
        return
    keep = [i for i in items if i.nodeid.split("::")[0] in files]
    if len(keep) < len(items):
        config.hook.pytest_deselected(items=[i for i in items if i not in keep])
        items[:] = keep
