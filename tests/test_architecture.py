"""The shape of the code: no import cycle between our modules nor between any two of our
packages (promp's core, ``promp/*.py``, the bottom of promp), ``promp`` imports nothing of
``app`` or ``robots``, ``robots`` nothing of ``app``, panels nothing of the studio, no file of
``app`` over 400 lines nor of ``robots`` or ``promp`` over 500, no function over 80 lines of
code, and no class of ``app`` with more than 25 members (attributes and methods).
docs/ARCHITECTURE.md's paths are checked against a trace of the running studio in
tests/test_architecture_paths.py.

The import graph is read from the source (every ``import`` statement, also inside functions and
under ``TYPE_CHECKING``): an edge goes from a module to each module of ours it names.
"""

from __future__ import annotations

import ast
from pathlib import Path

from tests.conftest import REPO

PACKAGES = ("app", "promp", "robots")
MAX_LINES = {"app": 400, "robots": 500}
MAX_MEMBERS = 25  # attributes and methods of a class of app


def module_files() -> dict[str, Path]:
    """Every module of our packages, by dotted name (a package by its ``__init__.py``)."""
    modules = {}
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            parts = list(path.relative_to(REPO).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            modules[".".join(parts)] = path
    return modules


def _ours(name: str, modules: dict[str, Path]) -> str | None:
    """The module of ours ``name`` is or lies in (None for another library)."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def import_graph() -> dict[str, set[str]]:
    """{module: the modules of ours it imports}."""
    modules = module_files()
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = package.split(".")
                    base = ".".join([*parts[: len(parts) - node.level + 1], *filter(None, [base])])
                # "from package import module" names the module, else what lies in ``base``.
                targets = [
                    f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                    for alias in node.names
                ]
            else:
                continue
            edges.update(found for t in targets if (found := _ours(t, modules)) not in (None, name))
        graph[name] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_import_graph_finds_a_cycle() -> None:
    """The check itself: a cycle through a function-local import is found."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_the_graph_reads_every_kind_of_import() -> None:
    graph = import_graph()
    assert "app.ui.context" in graph["app.panels.teach.panel"]  # from app.ui.context import ...
    assert "app.io.exchange" in graph["app.panels.data.panel"]  # from app.io import exchange
    assert "app.panels.teach.panel" in graph["app.panels.teach"]  # a package's own module
    assert "robots.icub.scenario" in graph["app.studio"]  # imported inside a function


def test_no_import_cycle_between_our_modules() -> None:
    assert cycles(import_graph()) == []


def package_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """{package: the packages of ours its modules import}: a module belongs to the folder it
    is in (``app.io.workspace`` to ``app.io``; a package's ``__init__`` to the package)."""
    modules = module_files()

    def package(name: str) -> str:
        return name if modules[name].name == "__init__.py" else name.rpartition(".")[0]

    out: dict[str, set[str]] = {}
    for name, targets in graph.items():
        edges = out.setdefault(package(name), set())
        edges.update(package(t) for t in targets if package(t) != package(name))
    return out


def test_the_package_graph_groups_modules_by_folder() -> None:
    packages = package_graph(import_graph())
    assert "app.io" in packages["app.core"]  # the store writes the workspace folder
    assert "app" not in {p for targets in packages.values() for p in targets}  # the top: cli


def test_no_import_cycle_between_packages() -> None:
    """No two folders of ours import each other, through any chain: promp's own modules (the
    method's core, ``promp/*.py``) import none of its sub-packages; the sub-packages (rigs,
    datasets, selection, learn, evaluate, baselines, live) build on the core and on each other
    one way."""
    packages = package_graph(import_graph())
    assert cycles(packages) == []
    assert packages["promp"] <= set(), packages["promp"]  # the core is the bottom of promp


def test_dependencies_go_one_way() -> None:
    graph = import_graph()
    wrong = {
        (module, target)
        for module, targets in graph.items()
        for target in targets
        if (module.startswith("promp") and target.startswith(("app", "robots")))
        or (module.startswith("robots") and target.startswith("app"))
        or (module.startswith("app.panels") and target == "app.studio")
    }
    assert wrong == set()


def test_no_file_of_app_or_robots_is_too_long() -> None:
    long = {
        str(path.relative_to(REPO)): n
        for package, limit in MAX_LINES.items()
        for path in (REPO / package).rglob("*.py")
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > limit
    }
    assert long == {}


PROMP_MAX_LINES = 500


def test_no_file_of_promp_is_over_500_lines() -> None:
    long = {
        path.relative_to(REPO).as_posix(): n
        for path in (REPO / "promp").rglob("*.py")
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > PROMP_MAX_LINES
    }
    assert long == {}


MAX_FUNCTION_LINES = 80  # lines of code of a function, its docstring excluded


def function_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """A function's lines from its ``def`` to its last line (comments and blank lines
    included, decorators not), its docstring excluded."""
    lines = node.end_lineno - node.lineno + 1
    first = node.body[0]
    if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(
        first.value.value, str
    ):
        lines -= first.end_lineno - first.lineno + 1
    return lines


def long_functions(source: str, path: str) -> dict[str, int]:
    """{``path:Class.function``: lines} of the functions of ``source`` over
    :data:`MAX_FUNCTION_LINES` (:func:`function_lines`), methods named by their class."""
    found = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            elif isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                if (n := function_lines(child)) > MAX_FUNCTION_LINES:
                    found[f"{path}:{prefix}{child.name}"] = n
                visit(child, f"{prefix}{child.name}.")

    visit(ast.parse(source), "")
    return found


def test_the_function_length_counts_code_not_docstrings() -> None:
    """The check itself: 81 lines of code fail, 80 with a docstring of 30 pass, a nested
    function and a method are named by what holds them."""
    body = "".join(f"    x{i} = {i}\n" for i in range(79))
    docstring = '    """' + "\n" * 29 + '    """\n'
    assert long_functions(f"def f():\n{docstring}{body}", "m.py") == {}
    assert long_functions(f"def f():\n{docstring}{body}    y = 0\n", "m.py") == {"m.py:f": 81}
    nested = f"class C:\n    def g(self):\n        def h():\n{body}    y = 0\n".replace(
        "\n    x", "\n            x"
    ).replace("\n    y", "\n            y")
    assert set(long_functions(nested, "m.py")) == {"m.py:C.g", "m.py:C.g.h"}


def test_no_function_is_over_80_lines_of_code() -> None:
    """No function of promp, app or robots (nested ones and methods too) over
    :data:`MAX_FUNCTION_LINES` lines of code."""
    long = {}
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            relative = path.relative_to(REPO).as_posix()
            long.update(long_functions(path.read_text(encoding="utf-8"), relative))
    assert long == {}


def members(cls: ast.ClassDef) -> set[str]:
    """A class's members: what its body defines (methods, properties, class attributes,
    fields) and every ``self.<name>`` its methods assign."""
    names = set()
    for node in cls.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            names.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.Assign):
            names.update(t.id for t in node.targets if isinstance(t, ast.Name))
    for node in ast.walk(cls):
        if isinstance(node, ast.Assign | ast.AnnAssign | ast.AugAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names.update(
                    sub.attr
                    for sub in ast.walk(target)
                    if isinstance(sub, ast.Attribute)
                    and isinstance(sub.value, ast.Name)
                    and sub.value.id == "self"
                )
    return names


def test_members_counts_what_a_class_defines_and_assigns() -> None:
    source = """class A:
    x: int
    y = 1
    def __init__(self):
        self.z, self.w = 1, 2
        self.x = 3
    @property
    def p(self):
        return self.q
"""
    (cls,) = ast.parse(source).body
    assert members(cls) == {"x", "y", "__init__", "z", "w", "p"}


def test_no_class_of_app_has_more_than_25_members() -> None:
    large = {
        f"{path.relative_to(REPO)}:{node.name}": len(members(node))
        for path in (REPO / "app").rglob("*.py")
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(node, ast.ClassDef) and len(members(node)) > MAX_MEMBERS
    }
    assert large == {}


# ---------------------------------------------------------------------- the documented paths


def test_every_name_a_script_imports_from_our_modules_exists() -> None:
    """bench/, docs/ and the tests' helpers run as scripts that no other test imports: a name
    they import from promp, app or robots that a restructuring moved is found here, not by the
    next person who runs the script."""
    import importlib

    missing = []
    for path in sorted([*REPO.glob("bench/*.py"), *REPO.glob("docs/*.py")]):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.ImportFrom) or node.level or node.module is None:
                continue
            if node.module.split(".")[0] not in {"promp", "app", "robots", "tests"}:
                continue
            module = importlib.import_module(node.module)
            for alias in node.names:
                if hasattr(module, alias.name):
                    continue
                try:
                    importlib.import_module(f"{node.module}.{alias.name}")
                except ImportError:
                    missing.append(f"{path.relative_to(REPO)}: {node.module}.{alias.name}")
    assert not missing, missing
