"""A finding of the checks of faulty recordings: one fault of one demonstration, in words.

The checks that make them live beside their concept (:mod:`promp.quality`: timestamps, gaps,
jumps, still takes, rates, durations; :mod:`promp.endpoints`: where a take starts and ends);
a :class:`Finding` is what the studio, the evaluation and the command lines show, store and
leave out of learning alike.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass

__all__ = ["Finding", "KINDS"]

KINDS = (
    "timestamps", "gap", "jump", "still", "rate", "duration", "round_trip", "start", "end"
)  # fmt: skip


@dataclass(frozen=True)
class Finding:
    """One fault of one demonstration.

    Attributes
    ----------
    primitive, demo : str
        The demonstration (its primitive, and its name there).
    kind : str
        One of :data:`KINDS`.
    time : float or None
        Seconds after the demonstration's first sample where the fault is; None for the
        whole demonstration (``still``, ``rate``, ``duration``).
    size : float
        How big it is, in ``unit`` (the gap's length, the jump, the extent, the period...).
    unit : str
    message : str
        The finding in words, with its numbers.
    file : str
        The file it was read from (relative to the dataset), when known.
    """

    primitive: str
    demo: str
    kind: str
    time: float | None
    size: float
    unit: str
    message: str
    file: str = ""

    @property
    def key(self) -> tuple[str, str]:
        return (self.primitive, self.demo)

    @property
    def where(self) -> str:
        return self.file or f"{self.primitive}/{self.demo}"

    def describe(self) -> str:
        """One line: the file (or primitive/demo) and the message."""
        return f"{self.where}: {self.message}"

    def to_json(self) -> dict:
        return asdict(self)

    @classmethod
    def from_json(cls, data: Mapping) -> Finding:
        """The inverse of :meth:`to_json`; ValueError on a malformed entry."""
        try:
            time = data["time"]
            finding = cls(
                primitive=str(data["primitive"]),
                demo=str(data["demo"]),
                kind=str(data["kind"]),
                time=None if time is None else float(time),
                size=float(data["size"]),
                unit=str(data["unit"]),
                message=str(data["message"]),
                file=str(data.get("file", "")),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"not a finding: {data!r} ({exc})") from None
        if finding.kind not in KINDS:
            raise ValueError(f"unknown kind of finding {finding.kind!r}; expected one of {KINDS}")
        return finding
