"""Names in the order a person counts them: ``record2`` before ``record10``.

Every list of demonstrations, takes, classes, runs or files that the method reads or the studio
shows is ordered by :func:`natural_key` (:func:`natural_sorted`), so a folder of
``record0.txt`` ... ``record13.txt`` is read, learned from and listed as ``record0``,
``record1``, ..., ``record13``, never ``record0``, ``record1``, ``record10``, ..., ``record2``.

A name is cut into runs of ASCII digits and runs of anything else; digit runs compare as
numbers, the rest without regard to case; ties are broken by the name as written, so the order
is total and the same on every machine. A path compares part by part (``reach/take2/arm``
before ``reach/take10/arm``).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from pathlib import PurePath
from typing import TypeVar

__all__ = ["DIGITS", "natural_key", "natural_sorted"]

_T = TypeVar("_T")
DIGITS = re.compile(r"([0-9]+)")


def _text_key(text: str) -> tuple:
    parts = DIGITS.split(text)  # text, digits, text, digits, ..., text: types alternate
    return (
        tuple(int(p) if i % 2 else p.casefold() for i, p in enumerate(parts)),
        text,
    )


def natural_key(name: str | PurePath) -> tuple:
    """The sort key of ``name`` (a string, or a path compared part by part).

    Examples
    --------
    >>> sorted(["record10", "record2", "Record1"], key=natural_key)
    ['Record1', 'record2', 'record10']
    """
    if isinstance(name, PurePath):
        return tuple(_text_key(part) for part in name.parts)
    return _text_key(str(name))


def natural_sorted(
    items: Iterable[_T], key: Callable[[_T], str | PurePath] | None = None, reverse: bool = False
) -> list[_T]:
    """``items`` in natural order of their names (``key(item)``, or the items themselves)."""
    if key is None:
        return sorted(items, key=natural_key, reverse=reverse)  # type: ignore[arg-type]
    return sorted(items, key=lambda item: natural_key(key(item)), reverse=reverse)
