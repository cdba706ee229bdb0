"""What the checks of :mod:`promp.quality` say about a workspace's demonstrations, and what the
user decided.

A demonstration with a finding (a gap, a jump, one that does not move, a rate or a duration far
from its primitive's others) is left out of learning by default; the user may keep it (one
click in the Teach tab). That choice, and the findings of the import that cannot be found again
from the stored files (samples set aside because their timestamps did not increase), are stored
in the workspace's ``studio.json`` under ``"checks"``, with the demonstrations' typicality
(:mod:`app.io.demo_scores`)::

    "checks": {"kept": [["reach", "person1_record3"]],
               "imported": [{"primitive": "reach", "demo": "...", "kind": "timestamps", ...}],
               "typicality": {"given": [...], "pending": [...]}}

Leaving a demonstration out never touches its file. The other findings are computed again from
the demonstrations whenever they change (a few milliseconds for a hundred of them).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from app.io.demo_scores import DemoScores
from promp.data import Demonstration, Layout
from promp.quality import Finding, dataset_findings


@dataclass(frozen=True)
class DemoChecks:
    """The user's choices, the import's findings and the typicality scores (see the module
    docstring)."""

    kept: frozenset[tuple[str, str]] = field(default_factory=frozenset)
    imported: tuple[Finding, ...] = ()
    scores: DemoScores = DemoScores()

    def __bool__(self) -> bool:
        return bool(self.kept or self.imported or self.scores)

    def to_json(self) -> dict:
        out = {
            "kept": sorted([p, d] for p, d in self.kept),
            "imported": [f.to_json() for f in self.imported],
        }
        if self.scores:
            out["typicality"] = self.scores.to_json()
        return out

    @classmethod
    def from_json(cls, data: object, label: str) -> DemoChecks:
        """The inverse of :meth:`to_json`; a ``ValueError`` starting with ``label``."""
        if not isinstance(data, dict):
            raise ValueError(f"{label}: 'checks' must be an object")
        kept = data.get("kept", [])
        if not isinstance(kept, list) or not all(
            isinstance(k, list) and len(k) == 2 and all(isinstance(s, str) for s in k)
            for k in kept
        ):
            raise ValueError(f"{label}: 'checks.kept' must be a list of [primitive, demo]")
        imported = data.get("imported", [])
        if not isinstance(imported, list):
            raise ValueError(f"{label}: 'checks.imported' must be a list")
        try:
            findings = tuple(Finding.from_json(f) for f in imported)
        except ValueError as exc:
            raise ValueError(f"{label}: {exc}") from None
        scores = DemoScores.from_json(data.get("typicality", {}), label)
        return cls(frozenset((p, d) for p, d in kept), findings, scores)

    def with_scores(self, scores: DemoScores) -> DemoChecks:
        return dataclasses.replace(self, scores=scores)

    def keep(self, primitive: str, demo: str, kept: bool) -> DemoChecks:
        key = (primitive, demo)
        return dataclasses.replace(self, kept=self.kept | {key} if kept else self.kept - {key})

    def renamed(self, old: str, new: str) -> DemoChecks:
        """The same choices and findings with primitive ``old`` called ``new``."""
        return DemoChecks(
            frozenset((new if p == old else p, d) for p, d in self.kept),
            tuple(
                dataclasses.replace(f, primitive=new) if f.primitive == old else f
                for f in self.imported
            ),
            self.scores.renamed(old, new),
        )

    def findings(
        self, demos: Mapping[str, Sequence[Demonstration]], layout: Layout
    ) -> list[Finding]:
        """Every finding of ``demos`` ({primitive: demonstrations}): the import's (for the
        demonstrations still there) and the checks' (named by their workspace file)."""
        present = {(p, d.name) for p, items in demos.items() for d in items}
        files = {key: f"demos/{key[0]}/{key[1]}.csv" for key in present}
        found = [f for f in self.imported if f.key in present]
        return found + dataset_findings(demos, layout, files)
