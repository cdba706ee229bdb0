"""The shape of the code: no import cycle between our modules nor between our packages,
``promp`` imports nothing of ``app`` or ``robots``, ``robots`` nothing of ``app``, panels nothing
of the studio, and no file of ``app`` or ``robots`` over 500 lines.

The import graph is read from the source (every ``import`` statement, also inside functions and
under ``TYPE_CHECKING``): an edge goes from a module to each module of ours it names.
"""

from __future__ import annotations

import ast
from pathlib import Path

from tests.conftest import REPO

PACKAGES = ("app", "promp", "robots")
MAX_LINES = 500


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


def test_no_import_cycle_between_the_packages_of_app_and_robots() -> None:
    packages = package_graph(import_graph())
    ours = {p: {t for t in targets if t.startswith(("app", "robots"))}
            for p, targets in packages.items() if p.startswith(("app", "robots"))}  # fmt: skip
    assert cycles(ours) == []


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


def test_no_file_of_app_or_robots_is_over_500_lines() -> None:
    long = {
        str(path.relative_to(REPO)): n
        for package in ("app", "robots")
        for path in (REPO / package).rglob("*.py")
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert long == {}
