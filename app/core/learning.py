"""Learning in the studio: what one refit learns from, its outcome, and the fit itself.

A refit of a training learned a moment ago (Undo delete, a setting put back) reuses that model
(:mod:`app.core.fit_cache`): the outcomes of the last fits are kept by a digest of everything
the fit
reads. A crash is never kept. Any other refit starts from the last model's choice of the
automatic settings, which it keeps unless the demonstrations now say otherwise
(:func:`promp.selection.choose_settings`: the previous choice and its runner-up scored on the
new demonstrations, one or two candidate fits instead of five or six), and every demonstration's
statistics are computed once (:func:`promp.weights.demo_statistics`).
"""

from __future__ import annotations

import time
import traceback
from collections.abc import Mapping
from dataclasses import dataclass, replace

from app.core.fit_cache import MAX_ENTRIES, training_key
from app.core.lru import LruCache
from promp.data import Demonstration, Layout
from promp.learn import fit
from promp.model import ProMPModel, Settings


@dataclass(frozen=True)
class Training:
    """What one refit learns from: a snapshot taken when it was asked for."""

    demos: dict[str, list[Demonstration]]  # the primitives with at least two demonstrations
    layout: Layout
    settings: Settings
    # the last model's choice of settings, which this refit may keep (promp.learn.fit)
    previous: Mapping | None = None


@dataclass(frozen=True)
class Learned:
    """The outcome of one refit: the model, or None and the reason; the time its fit took
    in ms, and whether it was reused from an earlier refit of the same training."""

    model: ProMPModel | None
    error: str | None
    ms: float
    reused: bool = False


# Shared by the sessions of the process (a studio has one; tests open many).
RECENT_FITS: LruCache[Learned] = LruCache(MAX_ENTRIES)


def learn(training: Training, reuse: bool = True) -> Learned:
    """Fit every primitive of ``training`` (runs outside the session's lock), or, when
    ``reuse``, take the outcome of a recent fit of the same training."""
    if not training.demos:
        return Learned(None, "record at least two demonstrations", 0.0)
    key = training_key(training.demos, training.layout, training.settings)
    if reuse and (known := RECENT_FITS.get(key)) is not None:
        return replace(known, reused=True)
    start = time.perf_counter()
    try:
        model = fit(training.demos, training.layout, training.settings,
                    previous=training.previous)  # fmt: skip
        error = None
    except ValueError as exc:
        model, error = None, str(exc)
    except Exception as exc:  # a bug must end the refit visibly, not leave it pending
        traceback.print_exc()
        return Learned(None, f"{type(exc).__name__}: {exc}", 1e3 * (time.perf_counter() - start))
    learned = Learned(model, error, 1e3 * (time.perf_counter() - start))
    RECENT_FITS.put(key, learned)
    return learned
