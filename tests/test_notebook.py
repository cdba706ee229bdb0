"""docs/notebook.md runs as it is: every python block, in order, in one namespace."""

from __future__ import annotations

import re
import shutil

import pytest

from tests.conftest import REPO

BLOCK = re.compile(r"```python\n(.*?)```", re.DOTALL)


@pytest.mark.slow
def test_the_scripting_guide_runs(capsys) -> None:
    text = (REPO / "docs" / "notebook.md").read_text(encoding="utf-8")
    blocks = BLOCK.findall(text)
    assert len(blocks) == 5
    namespace: dict = {}
    try:
        for i, block in enumerate(blocks, 1):
            exec(compile(block, f"docs/notebook.md block {i}", "exec"), namespace)  # noqa: S102
    finally:
        if "work" in namespace:  # the guide's own temporary folder
            shutil.rmtree(namespace["work"], ignore_errors=True)
    out = capsys.readouterr().out
    assert "ends at" in out and "interval coverage" in out and "curves_ours.png" in out
