"""Mutation testing with mutmut: which changes to the code no test would notice, per module.

By default it mutates ``promp/live/`` and runs the tests that exercise it (the files of
``tests/test_promp_live_*.py`` and ``tests/test_promp_stillness.py``); ``--paths`` and
``--tests`` name others (``--paths promp/inference.py --tests tests/test_promp_inference.py``).
Each mutant runs only the tests that reach the function it changes (mutmut's per-function
selection, recorded in a first, clean run of the tests), fastest first, up to the first that
fails; a mutant of a module of :data:`MODULE_TESTS` only those of its module's test files
(``bench/mutation_select.py``: the pipeline's core is reached by every live test). A mutant
that runs past ``(its tests' clean time + 10 s) x --timeout-multiplier`` (3), or holds one
test past ``its clean time x 3 + 10 s``, is stopped and counted as caught (mutmut's default,
15 times, let one endless loop hold the run 19 minutes).

The run happens in a temporary copy of the repository (the packages the paths are in,
``tests/``, ``docs/`` and ``pyproject.toml``, into which the ``[tool.mutmut]`` table is
written): the user's ``pyproject.toml`` is not touched, and no ``mutants/`` folder of an
earlier run (mutmut keeps results there and reuses them) can leak into this one. The copy is
removed afterwards unless ``--workdir`` names where to keep it (then ``mutmut results`` and
``mutmut show NAME`` run there). The tests that read the shared lab recordings read them from
``../shared/data`` beside the repository (or ``STUDIO_SHARED_DATA``), as they do outside.

Per module it prints the mutants in all, killed, timed out, survived, without a test reaching
them, and excluded, and the score ``(killed + timeouts) / (total - excluded)``: a timeout counts
as killed, as mutmut counts it (the mutant made the tests run far past their time: an endless
loop is a change the tests noticed).

Excluded (the rule, decided from the mutant's code, not from its fate, and not run: the
plugin deselects every test of such a mutant): a mutant equal to the
original function once every message in it is blanked. The messages are the arguments of the
exception in a ``raise`` statement, of ``warnings.warn`` and of a logger's ``debug``/``info``/
``warning``/``error``/``exception``/``critical``; the text of a ``LiveEvent`` (a live
session's event: its second argument or ``text=``; its time and kind are not messages); the
arguments of ``print`` written as a string literal or an f-string; and the texts only a
command's ``--help`` shows (the keywords ``help``, ``description``, ``epilog``, ``metavar``,
``prog`` of any call: argparse's). So a message's text changed (``"XX...XX"``), a message
replaced by ``None`` or dropped, is excluded; the
exception's type, the event's time or kind, what ``print`` writes when it is computed
(``print(json.dumps(summary))``) or where it writes, is not. Tests assert what happened
(numbers, states, an event's kind and fields), not the wording. Every other string (a key, a
kind, a file name, a header, a unit, a detail that is parsed back, a message built into a
variable before it reaches a call) is not excluded.

Install mutmut once (it is not a dependency of the tests, and CI does not run this):
``.venv/bin/python -m pip install -e '.[mutation]'``.

Run: ``.venv/bin/python bench/mutation.py [--paths promp/live] [--tests FILE|FILE::TEST ...]
[--deselect NODE_ID ...] [--max-children N] [--timeout-multiplier X] [--workdir DIR]``;
``--report DIR`` prints the scores of a kept run's folder (one stopped early: its mutants
not checked yet are counted apart). The goal is 60 minutes on the 2 cores: 60.9 minutes for
all 5,981 mutants of ``promp/live`` on 2026-11-30, every module at or above 85 %
(docs/reliability.md). The last line is one JSON
object: ``{module: {total, killed, timeout, survived, no_tests, excluded, score}, ...,
"minutes": M, "load_average": [1, 5, 15 min]}`` (the load when it ends).
"""

from __future__ import annotations

import argparse
import ast
import copy
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_PATHS = ["promp/live"]
DEFAULT_TESTS = ["tests/test_promp_live_*.py", "tests/test_promp_stillness.py"]
# Left out of the default run: the tests whose subject runs in a child process (mutmut's
# switch to a mutant lives in the test's process: in a child, started elsewhere, it cannot read
# its configuration, and no test reaches the child's functions in its statistics), and the
# end-to-end replays of several seconds each (run again for every mutant of every function they
# reach, they alone would take hours), and the test over real LSL streams (a mutant of the
# transport leaves it waiting for a stream until mutmut's time limit, a minute per mutant).
DEFAULT_DESELECT = [
    "tests/test_promp_live_lsl.py::test_a_vanished_stream_is_found_again_when_it_restarts",
    "tests/test_promp_live_cli.py::test_the_command_predicts_publishes_records_and_stops_cleanly",
    "tests/test_promp_live_lsl.py::test_a_replayed_demonstration_is_predicted_live_and_published",
    "tests/test_promp_live_lsl.py::test_where_liblsl_cannot_load_the_message_says_what_to_do",
    "tests/test_promp_live_lsl.py::test_the_robot_side_reader_waits_for_a_predictor_that_is_not_there_yet",
    "tests/test_promp_live_recorder.py::test_a_kill_during_a_recording_loses_nothing_acknowledged",
    "tests/test_promp_live_movements.py::test_each_guided_take_from_a_busy_sender_is_one_movement_recognised_as_offline",
    "tests/test_promp_live_movements.py::test_a_pause_longer_than_any_learned_ends_the_movement",
]
# Hypothesis (tests/conftest.py's profile "mutation") draws the same examples for every mutant
# (the clean run passed on them: a fault of the code itself found in one mutant's run would
# otherwise "kill" it, and the examples saved would "kill" those after it), and does not shrink
# a failing example (minutes of shrinking per killed mutant, up to mutmut's time limit).
PYTEST_ARGS = ["--hypothesis-profile=mutation", "-p", "mutation_select"]
# The tests a mutant of these modules runs (bench/mutation_select.py; the others run every
# test that reaches the function mutated). The pipeline's core is reached by nearly every live
# test, through a session: its mutants run the tests written for it, not all (a survivor of
# `step` ran 134 tests, over a minute under load, for each mutant).
MODULE_TESTS = {
    # the sinks, recorder, journal, outlets and predictor: reached by every session's test too
    "promp.live.sinks": ["tests/test_promp_live_sinks.py",
                         "tests/test_promp_live_session_runner.py"],
    "promp.live.recorder": ["tests/test_promp_live_recorder.py", "tests/test_promp_live_sinks.py"],
    "promp.live.journal": ["tests/test_promp_live_journal.py", "tests/test_promp_live_recorder.py",
                           "tests/test_promp_live_sinks.py"],
    "promp.live.outlets": ["tests/test_promp_live_outlets.py", "tests/test_promp_live_sinks.py"],
    "promp.live.predictor": ["tests/test_promp_live_predictor.py",
                             "tests/test_promp_live_pipeline.py",
                             "tests/test_promp_live_helper.py"],
    # the recognition's helper process: its own tests (each spawns helpers: ~20 s in all)
    "promp.live.helper": ["tests/test_promp_live_helper.py"],
    "promp.live.pipeline": ["tests/test_promp_live_pipeline.py",
                            "tests/test_promp_live_session_machine.py",
                            "tests/test_promp_live_faults.py",
                            "tests/test_promp_live_decision.py"],
    "promp.live.intake": ["tests/test_promp_live_intake.py",
                          "tests/test_promp_live_session_runner.py",
                          "tests/test_promp_live_faults.py", "tests/test_promp_live_threads.py"],
    "promp.live.session": ["tests/test_promp_live_session_runner.py",
                           "tests/test_promp_live_threads.py", "tests/test_promp_live_sinks.py",
                           "tests/test_promp_live_faults.py",
                           "tests/test_promp_live_session_machine.py"],
    # reached by every session's test too: their survivors ran minutes of them each
    "promp.live.segmenter": ["tests/test_promp_live_segmenter.py",
                             "tests/test_promp_stillness.py"],
    "promp.live.timebase": ["tests/test_promp_live_timebase.py",
                            "tests/test_promp_live_pipeline.py"],
    "promp.live.restamp": ["tests/test_promp_live_restamp.py", "tests/test_promp_live_source.py"],
    "promp.live.source": ["tests/test_promp_live_source.py", "tests/test_promp_live_faults.py",
                          "tests/test_promp_live_intake.py"],
    "promp.live.inputs": ["tests/test_promp_live_inputs.py", "tests/test_promp_live_source.py"],
    "promp.live.transport": ["tests/test_promp_live_transport.py",
                             "tests/test_promp_live_lsl_transport.py"],
    # the command: its own tests, in this process over the fake network (the replay of a
    # session file too); the session file's test of the command replays a long recording
    # (8 s, a module fixture's), for each mutant of the command's main
    "promp.live.cli": ["tests/test_promp_live_cli.py", "tests/test_promp_live_viewer_sink.py"],
    # reached by every session's test too (the first whole run: ~45 s of tests for each
    # mutant of the snapshot, ~50 s for the options'); their own tests and their nearest users'
    "promp.live.snapshot": ["tests/test_promp_live_snapshot.py",
                            "tests/test_promp_live_session_runner.py",
                            "tests/test_promp_live_status_line.py"],
    "promp.live.options": ["tests/test_promp_live_options.py", "tests/test_promp_live_pipeline.py",
                           "tests/test_promp_live_cli.py"],
    "promp.live.session_file": ["tests/test_promp_live_session_records.py",
                                "tests/test_promp_live_session_file.py"],
    # the LSL transport: its tests over loopback streams; in the map so that each of them has
    # its own time limit (a mutant that leaves an inlet waiting held the run ~65 s)
    "promp.live.lsl": ["tests/test_promp_live_lsl_transport.py", "tests/test_promp_live_lsl.py"],
}
# mutmut's time limit on a mutant: (its tests' time in the clean run + CONSTANT) x MULTIPLIER
# seconds of wall time (mutmut's defaults 1 and 15: a mutant of the pipeline's step that loops
# forever held the run 19 minutes). A mutant that runs past it counts as caught (timeout).
TIMEOUT_MULTIPLIER = 3.0
TIMEOUT_CONSTANT = 10.0
# Calls whose arguments are messages for a reader (see the module's docstring).
MESSAGE_CALLS = {"print", "LiveEvent", "warn", "debug", "info", "warning", "error", "exception",
                 "critical"}
# Keywords whose text only a command's --help shows (argparse's).
HELP_KEYWORDS = {"help", "description", "epilog", "metavar", "prog"}
KILLED = {"killed", "caught by type check", "segfault"}


def mutmut_config(paths: list[str], tests: list[str], deselect: list[str],
                  timeout_multiplier: float = TIMEOUT_MULTIPLIER) -> str:
    """The ``[tool.mutmut]`` table: mutate ``paths`` (files or folders), run ``tests`` but the
    ``deselect``-ed ones (pytest node ids)."""
    packages = sorted({Path(p).parts[0] for p in paths})
    only = [p if p.endswith(".py") else p.rstrip("/") + "/*" for p in paths]
    return "\n".join([
        "", "[tool.mutmut]",
        f"source_paths = {json.dumps(packages)}",
        'also_copy = ["docs/", "mutation_select.py", "mutation_rules.py", "mutation_tests.json"]',
        f"only_mutate = {json.dumps(only)}",
        f"timeout_multiplier = {float(timeout_multiplier)}",
        f"timeout_constant = {TIMEOUT_CONSTANT}",
        f"pytest_add_cli_args_test_selection = {json.dumps(tests)}",
        f"pytest_add_cli_args = {json.dumps(PYTEST_ARGS + [f'--deselect={d}' for d in deselect])}",
        ""])


def copy_repository(workdir: Path, paths: list[str], tests: list[str],
                    deselect: list[str], timeout_multiplier: float = TIMEOUT_MULTIPLIER) -> None:
    """The packages of ``paths``, the tests, the docs, pyproject.toml (with the table) and the
    plugin choosing a module's tests (:data:`MODULE_TESTS`) with its map."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for top in sorted({Path(p).parts[0] for p in paths} | {"tests", "docs"}):
        shutil.copytree(REPO / top, workdir / top, ignore=ignore)
    shutil.copy(REPO / "bench" / "mutation_select.py", workdir / "mutation_select.py")
    shutil.copy(Path(__file__), workdir / "mutation_rules.py")  # the plugin's exclusion rule
    chosen = {"tests": MODULE_TESTS, "timeout_multiplier": float(timeout_multiplier),
              "timeout_constant": TIMEOUT_CONSTANT}  # fmt: skip
    (workdir / "mutation_tests.json").write_text(json.dumps(chosen, indent=1))
    text = (REPO / "pyproject.toml").read_text()
    if "[tool.mutmut]" in text:
        raise ValueError("pyproject.toml has a [tool.mutmut] table: this script writes its own")
    (workdir / "pyproject.toml").write_text(
        text + mutmut_config(paths, tests, deselect, timeout_multiplier))


def _functions(tree: ast.AST) -> dict[str, ast.FunctionDef | ast.AsyncFunctionDef]:
    return {n.name: n for n in ast.walk(tree)
            if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)}


def _call_name(call: ast.Call) -> str:
    f = call.func
    return f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""


def _is_text(node: ast.AST) -> bool:
    return isinstance(node, ast.JoinedStr) or (
        isinstance(node, ast.Constant) and isinstance(node.value, str))


def _message_paths(function: ast.AST) -> set[tuple]:
    """Where the messages of ``function`` are: the paths (fields and indices from the function)
    of the arguments of a raised exception, of ``warn`` and a logger's methods, of LiveEvent's
    text (its second argument or ``text=``), the string or f-string arguments of print, and
    the help texts (:data:`HELP_KEYWORDS`) of any call."""
    paths: set[tuple] = set()

    def visit(node: ast.AST, path: tuple) -> None:
        call, at = None, path
        if isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call):
            call, at = node.exc, path + ("exc",)
        elif isinstance(node, ast.Call) and _call_name(node) in MESSAGE_CALLS:
            call = node
        if call is not None:
            name = _call_name(call) if call is node else "raise"
            for i, a in enumerate(call.args):
                if (name == "LiveEvent" and i != 1) or (name == "print" and not _is_text(a)):
                    continue
                paths.add(at + ("args", i))
            paths.update(at + ("keywords", i, "value") for i, k in enumerate(call.keywords)
                         if name == "LiveEvent" and k.arg == "text")
        if isinstance(node, ast.Call):
            paths.update(path + ("keywords", i, "value") for i, k in enumerate(node.keywords)
                         if k.arg in HELP_KEYWORDS)
        for field, value in ast.iter_fields(node):
            if isinstance(value, ast.AST):
                visit(value, path + (field,))
            elif isinstance(value, list):
                for i, item in enumerate(value):
                    if isinstance(item, ast.AST):
                        visit(item, path + (field, i))

    visit(function, ())
    return paths


def _blanked(function: ast.AST, paths: set[tuple]) -> str:
    """The dump of ``function`` with its name and the nodes at ``paths`` blanked."""
    function = copy.deepcopy(function)
    function.name = ""
    for path in paths:
        try:
            parent = function
            for step in path[:-1]:
                parent = parent[step] if isinstance(step, int) else getattr(parent, step)
            if isinstance(path[-1], int):
                parent[path[-1]] = ast.Constant("")
            else:
                setattr(parent, path[-1], ast.Constant(""))
        except (AttributeError, IndexError, TypeError):
            continue  # the mutant has no node there (an argument removed): not blanked
    return ast.dump(function)


def message_only(original: ast.AST, mutant: ast.AST) -> bool:
    """Whether ``mutant`` differs from ``original`` only in messages (see the docstring)."""
    paths = _message_paths(original)
    return _blanked(original, set()) != _blanked(mutant, set()) and \
        _blanked(original, paths) == _blanked(mutant, paths)  # fmt: skip


def _read_json(path: Path) -> dict:
    """``path``'s JSON, read again if mutmut was writing it (a running run's report)."""
    for _ in range(9):
        try:
            return json.loads(path.read_text())
        except json.JSONDecodeError:
            time.sleep(0.2)
    return json.loads(path.read_text())


def module_scores(workdir: Path) -> dict[str, dict]:
    """Per mutated module: the counts of mutmut's verdicts, the excluded mutants, the score."""
    from mutmut.stats import status_by_exit_code

    scores: dict[str, dict] = {}
    for meta in sorted((workdir / "mutants").rglob("*.py.meta")):
        source = meta.with_suffix("")
        module = ".".join(source.relative_to(workdir / "mutants").with_suffix("").parts)
        functions = _functions(ast.parse(source.read_text()))
        verdicts: Counter[str] = Counter()
        excluded = 0
        for key, code in _read_json(meta)["exit_code_by_key"].items():
            name = key.removeprefix(module.removesuffix(".__init__") + ".")
            original = functions[name.rsplit("__mutmut_", 1)[0] + "__mutmut_orig"]
            if message_only(original, functions[name]):
                excluded += 1
                continue
            status = status_by_exit_code[code]
            verdicts["killed" if status in KILLED else status.replace(" ", "_")] += 1
        total = sum(verdicts.values()) + excluded
        caught = verdicts["killed"] + verdicts["timeout"]
        pending = verdicts["not_checked"]  # a run stopped early: scored on what it checked
        scores[module] = {"total": total, "killed": verdicts["killed"],
                          "timeout": verdicts["timeout"], "survived": verdicts["survived"],
                          "no_tests": verdicts["no_tests"], "excluded": excluded,
                          "score": round(caught / max(total - excluded - pending, 1), 3)}
        if pending:
            scores[module]["not_checked"] = pending
        other = set(verdicts) - {"killed", "timeout", "survived", "no_tests", "not_checked"}
        if other:
            scores[module]["other"] = {k: verdicts[k] for k in sorted(other)}
    return scores


def print_table(scores: dict[str, dict]) -> None:
    """One line per module (the mutants not checked yet, if the run was stopped, last)."""
    print(f"{'module':<32} {'total':>6} {'killed':>6} {'timeout':>7} {'survived':>8} "
          f"{'no test':>7} {'excluded':>8} {'score':>6}")
    for module, s in scores.items():
        print(f"{module:<32} {s['total']:>6} {s['killed']:>6} {s['timeout']:>7} "
              f"{s['survived']:>8} {s['no_tests']:>7} {s['excluded']:>8} {s['score']:>6.1%}")
        if s.get("other") or s.get("not_checked"):
            print(f"{'':<32} and {s.get('other', {})}, not checked: {s.get('not_checked', 0)} "
                  "(the score is of those checked)")


def selected_tests(patterns: list[str]) -> list[str]:
    """The test files of ``patterns`` (globs from the repository), and the tests named by a
    node id (``FILE::NAME``, kept as given: a glob of ``FILE`` alone would match nothing and
    drop it). A pattern that matches no file is an error."""
    chosen: set[str] = set()
    for pattern in patterns:
        file, sep, node = pattern.partition("::")
        found = [str(t.relative_to(REPO)) for t in REPO.glob(file)]
        if not found:
            raise ValueError(f"--tests {pattern!r} matches no test file")
        chosen.update(f"{f}{sep}{node}" for f in found)
    return sorted(chosen)


def main(paths: list[str], tests: list[str], deselect: list[str], max_children: int | None,
         workdir: Path | None, timeout_multiplier: float = TIMEOUT_MULTIPLIER) -> dict:
    started = time.monotonic()
    tests = selected_tests(tests)
    keep = workdir is not None
    workdir = workdir or Path(tempfile.mkdtemp(prefix="mutation-"))
    if keep and workdir.exists():
        raise ValueError(f"--workdir {workdir} exists: name a new folder")
    workdir.mkdir(parents=True, exist_ok=True)
    try:
        copy_repository(workdir, paths, tests, deselect, timeout_multiplier)
        env = dict(os.environ)
        env.setdefault("STUDIO_SHARED_DATA", str(REPO.parent / "shared" / "data"))
        command = [str(Path(sys.executable).with_name("mutmut")), "run"]
        if max_children:
            command += ["--max-children", str(max_children)]
        log = workdir / "mutmut.log"
        with log.open("w") as out:
            # its own process group: stopping this script (Ctrl-C, SIGTERM) stops mutmut and
            # the mutant it runs, not only this process
            done = subprocess.Popen(command, cwd=workdir, env=env, stdout=out,
                                    stderr=subprocess.STDOUT, start_new_session=True)
            signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
            try:
                done.wait()
            finally:
                if done.poll() is None:
                    os.killpg(done.pid, signal.SIGKILL)
                    done.wait()
        if done.returncode != 0:
            sys.stdout.write(log.read_text()[-4000:])
            raise SystemExit(f"mutmut failed ({done.returncode}); its output: {log}")
        scores = module_scores(workdir)
    finally:
        if not keep:
            shutil.rmtree(workdir, ignore_errors=True)
    print_table(scores)
    result = {**scores, "minutes": round((time.monotonic() - started) / 60, 1),
              "load_average": [round(x, 2) for x in os.getloadavg()]}
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--paths", nargs="+", default=DEFAULT_PATHS,
                        help="files or folders to mutate, relative to the repository")
    parser.add_argument("--tests", nargs="+", default=DEFAULT_TESTS,
                        help="test files (globs, relative to the repository) or FILE::TEST")
    parser.add_argument("--deselect", nargs="*", default=DEFAULT_DESELECT,
                        help="test node ids left out (default: the list in this script)")
    parser.add_argument("--max-children", type=int, default=None,
                        help="mutants tested at once (mutmut's default: the number of cores)")
    parser.add_argument("--timeout-multiplier", type=float, default=TIMEOUT_MULTIPLIER,
                        help="mutmut's time limit per mutant, times its tests' clean time")
    parser.add_argument("--workdir", type=Path, default=None,
                        help="a new folder to run in and keep (default: a temporary one)")
    parser.add_argument("--report", type=Path, default=None, metavar="WORKDIR",
                        help="no run: the scores of a kept (or stopped) run's folder")
    args = parser.parse_args()
    if args.report is not None:
        scores = module_scores(args.report)
        print_table(scores)
        print(json.dumps(scores))
        raise SystemExit(0)
    main(args.paths, args.tests, args.deselect, args.max_children, args.workdir,
         args.timeout_multiplier)
