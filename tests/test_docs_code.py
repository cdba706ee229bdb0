"""The code shown in README.md and docs/*.md runs: every ```python block is executed here, each
file's blocks in order in one namespace (as a reader would paste them), in a new process whose
working folder is a temporary one (the examples write nothing into the repository).

A block that cannot run here says so on the line above it, with the reason or the test that runs
it instead: ``<!-- not run: REASON -->`` or ``<!-- run by tests/FILE.py ... -->``."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
BLOCK = re.compile(r"(?:^(<!--[^\n]*-->)\n)?^```python\n(.*?)^```", re.M | re.S)
MARK = re.compile(r"<!-- (not run: .+|run by (tests/\w+\.py)\b.*) -->")
# What a document's blocks print when they ran as they should (beyond not failing).
PRINTS = {
    "README.md": ("s [",),
    "docs/notebook.md": ("ends at", "interval coverage", "curves_ours.png"),
}


def blocks(path: Path) -> list[tuple[str | None, str]]:
    """(the mark above it or None, the code) of every python block of ``path``."""
    return [(m.group(1), m.group(2)) for m in BLOCK.finditer(path.read_text(encoding="utf-8"))]


def test_every_skipped_block_says_why() -> None:
    """A mark above a block is either no mark, or says why it does not run here (or where it
    runs): nothing is skipped silently."""
    for path in DOCS:
        for mark, _code in blocks(path):
            if mark is not None and ("not run" in mark or "run by" in mark):
                match = MARK.fullmatch(mark)
                assert match, (path.name, mark)
                if match.group(2):
                    assert (REPO / match.group(2)).is_file(), (path.name, mark)


@pytest.mark.parametrize("path", DOCS, ids=lambda p: p.relative_to(REPO).as_posix())
def test_the_python_blocks_of_a_document_run(path: Path, tmp_path: Path) -> None:
    code = [c for mark, c in blocks(path) if mark is None or not MARK.fullmatch(mark)]
    if not code:
        return  # nothing to run in this document
    script = tmp_path / "blocks.py"
    script.write_text("\n\n".join(code), encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(REPO), "MPLBACKEND": "Agg", "TMPDIR": str(tmp_path)}
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)  # fmt: skip
    assert done.returncode == 0, f"{path.name}:\n{done.stdout[-2000:]}\n{done.stderr[-4000:]}"
    for text in PRINTS.get(path.relative_to(REPO).as_posix(), ()):
        assert text in done.stdout, (path.name, text, done.stdout[-2000:])


def test_the_documents_with_code_are_all_run() -> None:
    """The documents whose code is checked for what it prints exist and have code."""
    for name in PRINTS:
        assert blocks(REPO / name), name
