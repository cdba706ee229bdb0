"""Results kept for the inputs seen last, safe to share between threads.

The fits of one choice of settings read the same demonstrations again and again (every
candidate basis, the final fit, the folds of a sweep), and an inference reuses what it derived
from a model's primitive (the factor of the observed dimensions, its precision). Every input
here is immutable (:class:`promp.data.Demonstration`, :class:`promp.data.Layout`,
:class:`promp.basis.RBFBasis`, a fitted primitive), so a result computed for the same objects is
the same result; results are arrays the callers only read.

Threads: the studio infers on its loop, on the recognition chart's worker and in an evaluation
at the same time, and learns on a worker. Every cache is read and written under one lock
(:data:`_LOCK`), held only for the lookup and the insertion, never while a result is computed
(a fit's core takes a second: holding the lock meanwhile would stall the loop's inference). Two
threads that miss the same entry at once both compute it, and the first one stored is the one
both return: every caller sees one object per key.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable, Hashable, MutableMapping, Sequence
from typing import TypeVar

T = TypeVar("T")
MAX_RECENT = 4
_LOCK = threading.Lock()
_MISSING = object()


def recent(store: list, key: Hashable, items: Sequence[object], make: Callable[[], T]) -> T:
    """What ``make()`` computes for ``items`` (these very objects, by identity) and ``key``,
    kept in ``store`` for the last :data:`MAX_RECENT` lists seen. The entry holds the items,
    so their ids cannot be taken by new objects while it is kept."""
    full = (key, tuple(id(item) for item in items))
    with _LOCK:
        value = _take(store, full)
    if value is not _MISSING:
        return value
    made = make()
    with _LOCK:
        value = _take(store, full)  # another thread may have stored it meanwhile
        if value is _MISSING:
            value = made
            store.append((full, tuple(items), value))
            del store[:-MAX_RECENT]
    return value


def _take(store: list, full: tuple) -> object:
    """The value stored under ``full``, moved to the end (most recent), or ``_MISSING``."""
    for i, (k, _, value) in enumerate(store):
        if k == full:
            store.append(store.pop(i))
            return value
    return _MISSING


def per_object(
    cache: weakref.WeakKeyDictionary, owner: object, key: Hashable, make: Callable[[], T]
) -> T:
    """What ``make()`` computes for ``owner`` (weakly referenced: dropped with it) and ``key``."""
    with _LOCK:
        entries = cache.get(owner)
        if entries is None:
            entries = cache[owner] = {}
    return cached(entries, key, make)


def cached(entries: MutableMapping, key: Hashable, make: Callable[[], T]) -> T:
    """``entries[key]``, computed by ``make()`` the first time (see the module docstring)."""
    with _LOCK:
        value = entries.get(key, _MISSING)
    if value is not _MISSING:
        return value
    made = make()
    with _LOCK:
        return entries.setdefault(key, made)


def cached_on(owner: object, name: str, key: Hashable, make: Callable[[], T]) -> T:
    """What ``make()`` computes for ``key``, kept in a dict ``name`` of ``owner``'s own
    attributes (a frozen dataclass's too: its ``__dict__`` is written directly), so it lives
    and dies with ``owner``."""
    with _LOCK:
        entries = owner.__dict__.get(name)
        if entries is None:
            entries = owner.__dict__[name] = {}
    return cached(entries, key, make)
