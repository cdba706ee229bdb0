"""The demonstrations' typicality as the workspace keeps it: each score once given, and the
demonstrations still to score.

Every demonstration that comes into a workspace is scored once, against its primitive's others
as they were then (:mod:`promp.typicality`): a take when it is recorded, an imported dataset's
demonstrations when it is imported (they are listed as *pending* until the learner has scored
them, so a studio stopped meanwhile scores them when it opens the workspace again). The scores
are kept in ``studio.json``, in the checks (:mod:`app.io.demo_checks`), and travel with the
workspace (its export and import)::

    "typicality": {"given": [{"primitive": "reach", "demo": "record3", "score": -0.31,
                              "percentile": 0.64, "coverage": 1.0}, ...],
                   "pending": [["reach", "record4"], ...]}

A score stays with the name it was given to until another demonstration takes that name (a new
take, an import): a deleted demonstration brought back from the trash keeps its score.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field

from promp.typicality import Typicality

Key = tuple[str, str]  # (primitive, demonstration)


@dataclass(frozen=True)
class DemoScores:
    """The scores given and the demonstrations pending (see the module docstring).

    Attributes
    ----------
    given : mapping of (primitive, demo) to Typicality
    pending : frozenset of (primitive, demo)
        Demonstrations to score (imported, not yet scored).
    """

    given: Mapping[Key, Typicality] = field(default_factory=dict)
    pending: frozenset[Key] = frozenset()

    def __bool__(self) -> bool:
        return bool(self.given or self.pending)

    def to_json(self) -> dict:
        return {
            "given": [
                {"primitive": p, "demo": d, **self.given[(p, d)].to_json()}
                for p, d in sorted(self.given)
            ],
            "pending": sorted([p, d] for p, d in self.pending),
        }

    @classmethod
    def from_json(cls, data: object, label: str) -> DemoScores:
        """The inverse of :meth:`to_json`; a ``ValueError`` starting with ``label``."""
        if not isinstance(data, dict):
            raise ValueError(f"{label}: 'checks.typicality' must be an object")
        given, pending = data.get("given", []), data.get("pending", [])
        if not isinstance(given, list) or not all(isinstance(g, dict) for g in given):
            raise ValueError(f"{label}: 'checks.typicality.given' must be a list of objects")
        if not isinstance(pending, list) or not all(_is_key(k) for k in pending):
            raise ValueError(
                f"{label}: 'checks.typicality.pending' must be a list of [primitive, demo]"
            )
        scores = {}
        for entry in given:
            if not _is_key([entry.get("primitive"), entry.get("demo")]):
                raise ValueError(f"{label}: a typicality needs a 'primitive' and a 'demo' name")
            try:
                scores[(entry["primitive"], entry["demo"])] = Typicality.from_json(entry)
            except ValueError as exc:
                raise ValueError(f"{label}: {exc}") from None
        return cls(scores, frozenset((p, d) for p, d in pending))

    def scored(self, scores: Mapping[Key, Typicality | None]) -> DemoScores:
        """These scores given (None: the demonstration cannot be scored, too few others),
        no longer pending."""
        given = dict(self.given)
        given.update({key: score for key, score in scores.items() if score is not None})
        return DemoScores(given, self.pending - set(scores))

    def asked(self, keys: Collection[Key]) -> DemoScores:
        """``keys``, new demonstrations (a take, a repaired gap's parts), to score: a score
        given before to their names goes."""
        keys = set(keys)
        given = {key: score for key, score in self.given.items() if key not in keys}
        return DemoScores(given, self.pending | keys)

    def renamed(self, old: str, new: str) -> DemoScores:
        """The same scores with primitive ``old`` called ``new``."""

        def key(k: Key) -> Key:
            return (new, k[1]) if k[0] == old else k

        return dataclasses.replace(
            self,
            given={key(k): score for k, score in self.given.items()},
            pending=frozenset(key(k) for k in self.pending),
        )


def _is_key(item: object) -> bool:
    return isinstance(item, list) and len(item) == 2 and all(isinstance(s, str) for s in item)
