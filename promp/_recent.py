"""Results kept for the inputs seen last: the fits of one choice of settings read the same
demonstrations again and again (every candidate basis, the final fit, the folds of a sweep).

Every input here is immutable (:class:`promp.data.Demonstration`, :class:`promp.data.Layout`,
:class:`promp.basis.RBFBasis`), so a result computed for the same objects is the same result;
results are arrays the callers only read.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Hashable, Sequence
from typing import TypeVar

T = TypeVar("T")
MAX_RECENT = 4


def recent(store: list, key: Hashable, items: Sequence[object], make: Callable[[], T]) -> T:
    """What ``make()`` computes for ``items`` (these very objects, by identity) and ``key``,
    kept in ``store`` for the last :data:`MAX_RECENT` lists seen. The entry holds the items,
    so their ids cannot be taken by new objects while it is kept."""
    full = (key, tuple(id(item) for item in items))
    for i, (k, _, value) in enumerate(store):
        if k == full:
            store.append(store.pop(i))
            return value
    value = make()
    store.append((full, tuple(items), value))
    del store[:-MAX_RECENT]
    return value


def per_object(
    cache: weakref.WeakKeyDictionary, owner: object, key: Hashable, make: Callable[[], T]
) -> T:
    """What ``make()`` computes for ``owner`` (weakly referenced: dropped with it) and ``key``."""
    entries = cache.setdefault(owner, {})
    if key not in entries:
        entries[key] = make()
    return entries[key]
