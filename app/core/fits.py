"""Recent refits, by what they learned from.

:func:`promp.learn.fit` is a pure function of the demonstrations, the layout and the settings,
and its models are immutable, so a refit of a state the session learned a moment ago (Undo
delete, a setting put back, a workspace switched back to, the same workspace opened again)
can take that model at once instead of learning it again: with automatic settings a refit of
the default workspace takes a second or two. The key is a digest of everything the fit reads
(each demonstration's name, columns, times and values, in order; the layout; the settings).
Only what the method answered is kept, a model or its refusal (``ValueError``), never a crash.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence

import numpy as np

from promp.data import Demonstration, Layout
from promp.model import Settings

MAX_ENTRIES = 8  # recent trainings kept (app.core.session.RECENT_FITS)


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
