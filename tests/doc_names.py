"""The names the documents and docstrings cite, and whether they resolve: dotted names of our
packages (``promp.evidence.Evidence.infer``, ``:mod:`~app.live.inference```) and file paths
of the repository (``app/live/regions.py``, ``docs/method.md``, ``app/live/lsl_*.py``).

Used by tests/test_docs_names.py; a helper, not a test, so the test can also show it failing
on a stale name.
"""

from __future__ import annotations

import ast
import builtins
import importlib
import importlib.util
import inspect
import re
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PACKAGES = ("promp", "app", "robots")
DOTTED = re.compile(r"(?<![\w./-])((?:promp|app|robots)(?:\.[A-Za-z_]\w*)+)")
PATH = re.compile(r"(?<![\w./-])((?:promp|app|robots|tests|bench|docs|static)/[\w./*-]*[\w*])")
# A Sphinx role's target: in a docstring, a name without our package's prefix is the module's
# (or, for a member, its class's).
ROLE = re.compile(r":(?:func|mod|class|meth|attr|data|exc|obj):`[~.]*([A-Za-z_][\w.]*)`")
# A file's suffix, not a name: ``app.py`` is not the attribute ``py`` of ``app``.
SUFFIXES = {"py", "md", "json", "csv", "npz", "zip", "png", "txt", "cfg", "js", "toml"}


def sources() -> Iterator[tuple[str, str, str, str]]:
    """(where, text, module, class): README.md and each of docs/*.md (no module), and each
    docstring of promp, app and robots, with its module's dotted name and its class's name (if
    any)."""
    for doc in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        yield doc.relative_to(REPO).as_posix(), doc.read_text(encoding="utf-8"), "", ""
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            where = path.relative_to(REPO).as_posix()
            module = ".".join(path.relative_to(REPO).with_suffix("").parts)
            module = module.removesuffix(".__init__")
            yield from _docstrings(ast.parse(path.read_text(encoding="utf-8")), where, module, "")


def _docstrings(node: ast.AST, where: str, module: str, cls: str):
    doc = ast.get_docstring(node, clean=False) if isinstance(node, DOCUMENTED) else None
    if doc:
        yield f"{where} ({getattr(node, 'name', 'module')})", doc, module, cls
    for child in ast.iter_child_nodes(node):
        inner = child.name if isinstance(child, ast.ClassDef) else cls
        yield from _docstrings(child, where, module, inner)


DOCUMENTED = (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)


def resolves(dotted: str) -> bool:
    """``dotted`` is a module of ours, or a name defined in one (``module.Class.member``)."""
    parts = dotted.split(".")
    if parts[-1] in SUFFIXES:  # a file named in words (``studio.json``)
        return True
    for k in range(len(parts), 0, -1):
        module = ".".join(parts[:k])
        try:
            found = importlib.util.find_spec(module) is not None
        except ModuleNotFoundError:
            found = False
        if not found:
            continue
        return _has(importlib.import_module(module), parts[k:])
    return False


def _has(obj: object, attrs: list[str]) -> bool:
    """``obj.a.b...`` is defined: an attribute, a field without a default, or an attribute a
    class's methods assign (``self.drawn = ...``)."""
    for attr in attrs:
        if not hasattr(obj, attr):
            if attr in getattr(obj, "__annotations__", {}):
                return True  # a field without a class default
            return inspect.isclass(obj) and bool(
                re.search(rf"self\.{attr}\s*[:=]", inspect.getsource(obj)))
        obj = getattr(obj, attr)
    return True


def role_resolves(name: str, module: str, cls: str) -> bool:
    """A role's target ``name`` in a docstring of ``module`` (inside class ``cls``)."""
    if name.split(".")[0] in PACKAGES:
        return resolves(name)
    if hasattr(builtins, name.split(".")[0]):
        return True
    owner = importlib.import_module(module)
    parts = name.split(".")
    if _has(owner, parts[:1]):
        return _has(owner, parts)
    return bool(cls) and _has(getattr(owner, cls), parts)


def path_exists(path: str) -> bool:
    """``path`` (perhaps with ``*``) names a file or folder of the repository."""
    path = path.rstrip("/.")
    return any(REPO.glob(path)) if "*" in path else (REPO / path).exists()


def stale(text: str, module: str = "", cls: str = "") -> list[str]:
    """The dotted names and paths ``text`` cites that do not resolve (a docstring's roles
    against its ``module`` and class ``cls``)."""
    names = [n for n in DOTTED.findall(text) if not resolves(n)]
    paths = [p for p in PATH.findall(text) if not path_exists(p)]
    roles = [r for r in ROLE.findall(text) if module and not role_resolves(r, module, cls)]
    return names + paths + roles
