"""The session's side of the checks (:mod:`app.io.demo_checks`): which demonstrations are flagged,
which are left out of learning, the user's Keep, and the repair of a gap.

A part of :class:`app.core.session.Session` (it works on the session's demonstrations, lock and
workspace); kept apart so that the session's file stays one idea long.
"""

from __future__ import annotations

from app.io.dataset_import import safe_name
from promp.data import Demonstration
from promp.quality import Finding, repair_gaps, split_flagged


class FlaggedDemos:
    """Methods of :class:`app.core.session.Session` about flagged demonstrations."""

    def _recheck(self) -> None:
        """Find the demonstrations' faults again (:mod:`app.io.demo_checks`; lock held)."""
        self.findings: list[Finding] = self.checks.findings(self.demos, self.layout)

    def left_out(self) -> dict[tuple[str, str], list[Finding]]:
        """The flagged demonstrations the user did not keep (left out of learning)."""
        with self.lock:
            return split_flagged(self.demos, self.findings, self.checks.kept)[1]

    def findings_of(self, primitive: str, demo: str) -> list[Finding]:
        with self.lock:
            return [f for f in self.findings if f.key == (primitive, demo)]

    def learned_demos(self) -> dict[str, list[Demonstration]]:
        """Every primitive's demonstrations that learning uses: all but :meth:`left_out`."""
        with self.lock:
            return split_flagged(self.demos, self.findings, self.checks.kept)[0]

    def set_kept(self, primitive: str, demo: str, kept: bool) -> None:
        """Learn from a flagged demonstration after all (``kept``), or leave it out again (the
        default); stored in the workspace's index, the file never touched."""
        with self.lock:
            self.entry(primitive)
            if demo not in {d.name for d in self.demos[primitive]}:
                raise ValueError(f"primitive {primitive!r} has no demonstration {demo!r}")
            checks = self.checks.keep(primitive, demo, kept)
            if checks == self.checks:
                return
            self._save_index(checks=checks)
            self.checks = checks
            self._changed(recheck=False)

    def repair_gap(self, primitive: str, demo: str, mode: str) -> list[Demonstration]:
        """New demonstrations from ``demo``'s gap repaired (:func:`promp.quality.repair_gaps`:
        ``"cut"`` keeps the part before the gap, ``"split"`` every part), written beside it
        (``<demo>-cut``, ``<demo>-part1``...); ``demo`` itself stays as it is (flagged).

        Raises
        ------
        ValueError
            Unknown primitive or demonstration, no gap, an unknown mode.
        """
        with self.lock:
            self.entry(primitive)
            original = next((d for d in self.demos[primitive] if d.name == demo), None)
            if original is None:
                raise ValueError(f"primitive {primitive!r} has no demonstration {demo!r}")
            parts = repair_gaps(original, mode)
            if parts == [original]:
                raise ValueError(f"{demo} has no gap in its timestamps")
            # never over a file already there (one the session could not read, say)
            folder = self.workspace.demo_dir(primitive)
            taken = {d.name for d in self.demos[primitive]} | {p.stem for p in folder.glob("*")}
            made = []
            for k, part in enumerate(parts, start=1):
                suffix = "cut" if mode == "cut" else f"part{k}"
                name = safe_name(f"{demo[: 40 - len(suffix) - 1]}-{suffix}", taken)
                made.append(Demonstration(part.times, part.values, part.columns, name=name))
            for part in made:
                self.workspace.write_demo(primitive, part, self.layout)
                self.demos[primitive].append(part)
            self._changed()
            return made
