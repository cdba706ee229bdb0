"""The files docs/ARCHITECTURE.md's trees name, read from its code blocks (used by
tests/test_architecture_tree.py).

A tree is a code block of lines ``NAME   description``: an entry (a folder ``name/`` or
modules ``a.py, b.py``) indented by two spaces under its folder, its description continued on
lines indented further (12 spaces or more). A description names more files of the entry's
folder (``workspace_index.py: studio.json``), or elsewhere by a path (``panels/infer/
replay_section.py``, relative to the entry's folder or one above it; ``promp/recognition.py``,
from the repository); ``lsl_*.py`` names a deliberate group.
"""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
BLOCK = re.compile(r"^```\n(.*?)^```", re.M | re.S)
ENTRY_INDENT = 12  # an entry starts before this column; a description's next line after it
NAME = re.compile(r"(?<![\w/.*-])([\w*][\w*/-]*\.py|[\w*][\w*-]*(?:/[\w*-]+)*/)(?![\w/])")
TOP = ("promp", "app", "robots", "tests", "bench", "docs", "static")


def tree_blocks(text: str) -> list[str]:
    """The code blocks of ``text`` that are trees (their first line is a folder entry)."""
    return [b for b in BLOCK.findall(text) if re.match(r"^[\w/]+/\s", b)]


def named(block: str) -> set[str]:
    """The repository paths (folders end with ``/``) that ``block`` names, as written: they
    may not exist (the check's business)."""
    out: set[str] = set()
    stack: list[tuple[int, str]] = []  # (indent, folder) of the entries above
    folder = ""
    for line in block.splitlines():
        if not line.strip():
            continue
        indent = len(line) - len(line.lstrip())
        text = line.strip()
        if indent < ENTRY_INDENT:
            head, text = _split(line.strip())
            while stack and stack[-1][0] >= indent:
                stack.pop()
            parent = stack[-1][1] if stack else ""
            names = [n.strip() for n in head.split(",")]
            for name in names:
                out.add(parent + name)
            folder = parent + names[0] if names[0].endswith("/") else parent
            if names[0].endswith("/"):
                stack.append((indent, folder))
        for name in NAME.findall(text):
            out.add(_resolve(name, folder))
    return out


def _split(line: str) -> tuple[str, str]:
    """An entry's line: its names (``a.py, b.py`` or ``name/``) and its description."""
    m = re.match(r"^(\S+(?:, \S+)*)(?:\s+(.*))?$", line)
    return m.group(1), m.group(2) or ""


def _resolve(name: str, folder: str) -> str:
    """``name`` seen in a description under ``folder``: from the repository when it starts
    there, else from ``folder`` or the nearest folder above it where it exists."""
    if name.split("/")[0] in TOP and "/" in name:
        return name
    parts = folder.rstrip("/").split("/") if folder else []
    for k in range(len(parts), -1, -1):
        base = "/".join(parts[:k])
        candidate = f"{base}/{name}" if base else name
        if _exists(candidate):
            return candidate
    return f"{folder}{name}"


def _exists(path: str) -> bool:
    path = path.rstrip("/")
    return any(REPO.glob(path)) if "*" in path else (REPO / path).exists()


def missing(paths: set[str]) -> list[str]:
    """The paths of ``paths`` that name nothing on disk (a pattern: no file)."""
    return sorted(p for p in paths if not _exists(p))


def unlisted(paths: set[str], packages: tuple[str, ...] = ("promp", "app", "robots")) -> list[str]:
    """The packages (``folder/``) and modules of ``packages`` that ``paths`` neither names nor
    groups (``app/live/lsl_*.py``)."""
    found = []
    for package in packages:
        for path in sorted((REPO / package).rglob("*.py")):
            rel = path.relative_to(REPO).as_posix()
            if "__pycache__" in rel:
                continue
            if path.name == "__init__.py":
                folder = rel.removesuffix("__init__.py")
                if folder not in paths:
                    found.append(folder)
            elif not any(Path(rel).match(p) if "*" in p else rel == p for p in paths):
                found.append(rel)
    return found
