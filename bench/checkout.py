"""Another commit's code beside this one's, for the benches that measure a change in one run
(``bench/live.py --baseline``, ``bench/scrub.py --baseline``)."""

from __future__ import annotations

import subprocess
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


@contextmanager
def checkout(commit: str) -> Iterator[Path]:
    """A temporary ``git worktree`` of ``commit`` (the code before a change, run beside this
    one's); removed on leaving. It is the bench's own folder: nothing of the user's is touched."""
    where = Path(tempfile.mkdtemp(prefix="bench-baseline-")) / "repo"
    subprocess.run(["git", "worktree", "add", "--detach", str(where), commit], cwd=REPO,
                   check=True, capture_output=True)  # fmt: skip
    try:
        yield where
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(where)], cwd=REPO,
                       check=False, capture_output=True)  # fmt: skip
        where.parent.rmdir()
