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

mutmut's time limit on a mutant comes from the time of every test that reaches it; for a
module of the map the limit is the one of the tests it runs: ``(their clean time + constant) x
multiplier`` (both in the map's file, as bench/mutation.py passes them to mutmut), after which
the mutant's process ends with mutmut's exit code for a timeout (36: caught). Each test has its
own limit within that one, ``its clean time x multiplier + constant``: a mutant that loops
for ever is stopped in the first test it holds, not after its whole set's time (a minute and
a half for a set of 25 s; the first run of the whole of ``promp/live`` spent a quarter of its
time waiting out such mutants).

A mutant that changes only messages (bench/mutation.py's rule, here ``mutation_rules.py``, its
copy) is excluded from the score whatever its fate: it runs no test (pytest exits 5). Its tests
would all pass (no test asserts a message's wording), each of them, for every such mutant: the
help texts of the command's options alone were 223 mutants of 14 s of tests each.
"""

from __future__ import annotations

import ast
import json
import os
import signal
import time
from pathlib import Path

import pytest

MAP = Path(__file__).with_name("mutation_tests.json")
EXCLUDED = Path("mutation_excluded.json")  # per module, its mutants that change only messages
TIMEOUT_EXIT = 36  # mutmut's exit code for a mutant that ran past its time (a timeout)


def files_for(mutant: str, tests: dict[str, list[str]]) -> list[str] | None:
    """The test files of the module ``mutant`` belongs to (the longest module of ``tests``
    its name starts with), or None."""
    modules = [m for m in tests if mutant.startswith(m + ".")]
    return tests[max(modules, key=len)] if modules else None


def excluded(mutant: str) -> bool:
    """Whether mutmut's ``mutant`` (``promp.live.cli.x_parser__mutmut_2``) changes only
    messages: the names of its module's such mutants, found once in its mutated source (the
    working folder's; seconds for a module of 900 mutants) and kept in :data:`EXCLUDED`."""
    module, name = mutant.rsplit(".", 1)
    known = json.loads(EXCLUDED.read_text()) if EXCLUDED.exists() else {}
    if module not in known:
        known[module] = _message_only_mutants(module)
        part = EXCLUDED.with_name(f"{EXCLUDED.name}.{os.getpid()}")
        part.write_text(json.dumps(known))
        part.replace(EXCLUDED)  # whole, for the next mutant's process
    return name in known[module]


def _message_only_mutants(module: str) -> list[str]:
    try:
        from mutation_rules import _blanked, _functions, _message_paths
    except ImportError:  # not copied: every mutant runs
        return []
    source = Path(*module.split(".")).with_suffix(".py")
    if not source.exists():
        source = Path(*module.split("."), "__init__.py")
    functions = _functions(ast.parse(source.read_text()))
    found = []
    for name, original in functions.items():  # message_only, each original blanked once
        if not name.endswith("__mutmut_orig"):
            continue
        paths, stem = _message_paths(original), name.removesuffix("orig")
        plain, blank = _blanked(original, set()), _blanked(original, paths)
        found += [m for m, f in functions.items() if m.startswith(stem) and m != name
                  and _blanked(f, set()) != plain and _blanked(f, paths) == blank]
    return found


def pytest_configure(config) -> None:
    """In mutmut's first run of the tests (no mutant), the excluded mutants of every mutated
    module, before any mutant's process (and its time limit) starts."""
    if "__mutmut_" in os.environ.get("MUTANT_UNDER_TEST", "") or not MAP.exists():
        return
    for meta in sorted(Path().rglob("*.py.meta")):
        module = ".".join(meta.with_suffix("").with_suffix("").parts)
        excluded(module.removesuffix(".__init__") + ".x")


def pytest_collection_modifyitems(config, items) -> None:
    mutant = os.environ.get("MUTANT_UNDER_TEST", "")
    if "__mutmut_" not in mutant or not MAP.exists():
        return
    if excluded(mutant):
        config.hook.pytest_deselected(items=list(items))
        items[:] = []
        return
    chosen = json.loads(MAP.read_text())
    files = files_for(mutant, chosen["tests"])
    if files is None:
        return
    keep = [i for i in items if i.nodeid.split("::")[0] in files]
    if len(keep) < len(items):
        config.hook.pytest_deselected(items=[i for i in items if i not in keep])
        items[:] = keep
    stats = Path("mutmut-stats.json")  # mutmut's, in its folder (the tests' working one)
    durations = json.loads(stats.read_text())["duration_by_test"] if stats.exists() else {}
    constant, multiplier = chosen["timeout_constant"], chosen["timeout_multiplier"]
    limit = (sum(durations.get(i.nodeid, 1.0) for i in keep) + constant) * multiplier
    _LIMITS.update({i.nodeid: durations.get(i.nodeid, 1.0) * multiplier + constant
                    for i in keep})  # fmt: skip
    _LIMITS[_WHOLE] = time.monotonic() + limit
    signal.signal(signal.SIGALRM, lambda *_: os._exit(TIMEOUT_EXIT))
    signal.setitimer(signal.ITIMER_REAL, limit)


_LIMITS: dict[str, float] = {}  # a mutant's tests: {node id: seconds}, and the whole set's end
_WHOLE = ""  # the key of the whole set's end (time.monotonic())


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """Each test of a mutant within its own limit, and within what is left of its set's."""
    if _WHOLE not in _LIMITS:  # the clean run, or a module outside the map
        yield
        return
    left = _LIMITS[_WHOLE] - time.monotonic()
    signal.setitimer(signal.ITIMER_REAL, max(min(_LIMITS.get(item.nodeid, left), left), 1e-3))
    yield
    signal.setitimer(signal.ITIMER_REAL, max(_LIMITS[_WHOLE] - time.monotonic(), 1e-3))
