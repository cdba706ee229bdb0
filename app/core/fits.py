"""Fits the studio learned a moment ago, by what they learned from.

:func:`promp.learn.fit` is a pure function of the demonstrations, the layout and the settings,
and its models are immutable, so a fit of a training learned a moment ago (Undo delete, a
setting put back, a workspace switched back to, the same workspace opened again, a held-out
model looked at again) takes that model at once instead of learning it again: with automatic
settings a fit of the default workspace takes a second or two. The key is a digest of
everything the fit reads (each demonstration's name, columns, times and values, in order; the
layout; the settings). Only what the method answered is kept, a model or its refusal
(``ValueError``), never a crash.

One :class:`FitCache` is given to the studio's learner (:class:`app.core.learner.Learner`);
whoever makes several learners share their fits by giving them the same cache (the tests do).
"""

from __future__ import annotations

import hashlib
import threading
import time
import traceback
from collections import OrderedDict
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Generic, TypeVar

import numpy as np

from promp.data import Demonstration, Layout
from promp.learn import fit
from promp.model import ProMPModel, Settings

MAX_ENTRIES = 16  # recent trainings kept: the workspace's refits and the held-out models

V = TypeVar("V")


class LruCache(Generic[V]):
    """At most ``max_entries`` values by key, the least recently used dropped first;
    thread-safe."""

    def __init__(self, max_entries: int = 8):
        if max_entries < 1:
            raise ValueError(f"a cache must hold at least one entry, got {max_entries}")
        self.max_entries = max_entries
        self._entries: OrderedDict[Hashable, V] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Hashable) -> V | None:
        with self._lock:
            value = self._entries.get(key)
            if value is not None:
                self._entries.move_to_end(key)
            return value

    def put(self, key: Hashable, value: V) -> None:
        with self._lock:
            self._entries[key] = value
            self._entries.move_to_end(key)
            while len(self._entries) > self.max_entries:
                self._entries.popitem(last=False)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()

    def __contains__(self, key: Hashable) -> bool:
        with self._lock:
            return key in self._entries

    def __len__(self) -> int:
        with self._lock:
            return len(self._entries)


@dataclass(frozen=True)
class Training:
    """What one fit learns from."""

    demos: Mapping[str, Sequence[Demonstration]]  # primitives with at least two demonstrations
    layout: Layout
    settings: Settings
    # the last model's choice of settings, which this fit may keep (promp.learn.fit)
    previous: Mapping | None = None

    @property
    def n_demos(self) -> int:
        return sum(len(items) for items in self.demos.values())


@dataclass(frozen=True)
class Fitted:
    """The outcome of one fit: the model, or None and the reason; the time the fit took in
    ms, and whether it was reused from an earlier fit of the same training."""

    model: ProMPModel | None
    error: str | None
    ms: float
    reused: bool = False


def training_key(
    demos: Mapping[str, Sequence[Demonstration]], layout: Layout, settings: Settings
) -> str:
    """A digest of what a fit of ``demos`` over ``layout`` with ``settings`` reads."""
    digest = hashlib.sha256(repr((layout, settings)).encode())
    for name, items in demos.items():
        digest.update(repr((name, len(items))).encode())
        for demo in items:
            digest.update(repr((demo.name, demo.columns, demo.values.shape)).encode())
            digest.update(np.ascontiguousarray(demo.times, dtype=float).tobytes())
            digest.update(np.ascontiguousarray(demo.values, dtype=float).tobytes())
    return digest.hexdigest()


class FitCache(LruCache[Fitted]):
    """The outcomes of the last fits, by :func:`training_key` (see the module docstring)."""

    def __init__(self, max_entries: int = MAX_ENTRIES):
        super().__init__(max_entries)

    def fit(self, training: Training, reuse: bool = True) -> Fitted:
        """Fit every primitive of ``training``, or, when ``reuse``, take the outcome of a
        recent fit of the same training."""
        if not training.demos:
            return Fitted(None, "record at least two demonstrations", 0.0)
        key = training_key(training.demos, training.layout, training.settings)
        if reuse and (known := self.get(key)) is not None:
            return replace(known, reused=True)
        start = time.perf_counter()
        try:
            model = fit(training.demos, training.layout, training.settings,
                        previous=training.previous)  # fmt: skip
            error = None
        except ValueError as exc:
            model, error = None, str(exc)
        except Exception as exc:  # a bug must end the fit visibly, not leave it pending
            traceback.print_exc()
            return Fitted(None, f"{type(exc).__name__}: {exc}", 1e3 * (time.perf_counter() - start))
        fitted = Fitted(model, error, 1e3 * (time.perf_counter() - start))
        self.put(key, fitted)
        return fitted


def held_out_training(
    demos: Mapping[str, Sequence[Demonstration]],
    primitive: str,
    demo_name: str,
    group: tuple[str, Sequence[tuple[str, str]]] | None = None,
) -> dict[str, list[Demonstration]]:
    """The training set of the model that must not see ``demo_name`` of ``primitive``: every
    primitive with at least two demonstrations once the test one is removed. With ``group``
    (its name and its (primitive, demonstration) keys, the test one among them), the whole
    group is held out, and every primitive must keep two.

    Raises
    ------
    ValueError
        Unknown primitive or demonstration, or fewer than two demonstrations of ``primitive``
        left (its model could not be learned, so it could not be recognised); with ``group``,
        of any primitive.
    """
    if primitive not in demos:
        raise ValueError(f"unknown primitive {primitive!r}")
    if demo_name not in {d.name for d in demos[primitive]}:
        raise ValueError(f"primitive {primitive!r} has no demonstration {demo_name!r}")
    held = {(primitive, demo_name)} | set(group[1] if group is not None else ())
    train = {
        name: [d for d in items if (name, d.name) not in held] for name, items in demos.items()
    }
    if group is not None:
        short = next((n for n, items in train.items() if len(items) < 2), None)
        if short is not None:
            raise ValueError(
                f"holding out the group {group[0]!r} of {demo_name!r} leaves {short!r} with "
                f"{len(train[short])} demonstration(s); a primitive needs two to be learned"
            )
    if len(train[primitive]) < 2:
        raise ValueError(
            f"holding out {demo_name!r} leaves {primitive!r} with {len(train[primitive])} "
            "demonstration(s); record at least three to test one"
        )
    return {name: items for name, items in train.items() if len(items) >= 2}
