"""Demonstrations keyed by what they hold, not by what their files are called.

Whatever depends on which demonstrations come first (the trials the automatic rule holds out,
a quick sweep's subset, the order in which a fit adds the demonstrations' weights) follows
their content: renaming the files, reading them in another order or moving them between
sub-folders changes none of it, nor does a change of unit.

The key of a demonstration (:func:`content_key`) is a digest of a unit-free summary: its
number of samples, its duration in seconds (6 significant digits), and for every column, in
the demonstration's order, its mean, standard deviation, first, middle and last values, each
divided by the column's largest magnitude and rounded to 6 decimals. A change of unit
multiplies a column by a positive constant, which the division takes out; the rounding absorbs
the last bits the multiplication changes (a value lands on the other side of a rounding step
with a probability of about 1e-9 per number). Two demonstrations share a key only when they
agree in every one of these numbers (a copy of a file, in practice), and then which comes
first changes nothing.
"""

from __future__ import annotations

import hashlib
import weakref
from collections.abc import Mapping, Sequence

import numpy as np

from promp._recent import per_object
from promp.data import Demonstration

__all__ = [
    "canonical_dataset", "content_key", "content_order", "keyed_shuffle", "DECIMALS",
]  # fmt: skip

DECIMALS = 6  # of the summary's unit-free numbers (each within [-1, 1])
_KEYS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _summary(demo: Demonstration) -> str:
    values = demo.values
    peak = np.max(np.abs(values), axis=0)
    unit_free = values / np.where(peak > 0.0, peak, 1.0)
    middle = demo.n_samples // 2
    numbers = np.stack(
        [unit_free.mean(axis=0), unit_free.std(axis=0), unit_free[0], unit_free[middle],
         unit_free[-1]],
        axis=1,
    ).ravel()  # fmt: skip
    # + 0.0: a -0.0 rounded from a tiny negative number is written as 0.0
    cells = ",".join(f"{round(float(v), DECIMALS) + 0.0:.{DECIMALS}f}" for v in numbers)
    return f"{demo.n_samples};{demo.duration:.6g};{values.shape[1]};{cells}"


def content_key(demo: Demonstration) -> str:
    """The key of ``demo``: 32 hexadecimal digits, the same for the same recording whatever
    its name, its file or its columns' units (see the module docstring). Computed once per
    demonstration object."""
    return per_object(
        _KEYS, demo, "key",
        lambda: hashlib.sha256(_summary(demo).encode()).hexdigest()[:32],
    )  # fmt: skip


def content_order(demos: Sequence[Demonstration]) -> list[int]:
    """The indices of ``demos`` by their keys (ties, copies of one recording, in their given
    order)."""
    return sorted(range(len(demos)), key=lambda i: content_key(demos[i]))


def keyed_shuffle(demos: Sequence[Demonstration], salt: str) -> list[int]:
    """The indices of ``demos`` in a pseudo-random order drawn from their content and
    ``salt`` (e.g. a seed and a primitive's name): the same demonstrations come in the same
    order whatever their names or their order in ``demos``, and removing one leaves the
    others' order as it was."""
    def draw(i: int) -> str:
        return hashlib.sha256(f"{salt}/{content_key(demos[i])}".encode()).hexdigest()

    return sorted(range(len(demos)), key=lambda i: (draw(i), content_key(demos[i])))


def canonical_dataset(
    dataset: Mapping[str, Sequence[Demonstration]],
) -> dict[str, list[Demonstration]]:
    """``dataset`` with every primitive's demonstrations in content order
    (:func:`content_order`), the primitives in their given order: what a fit adds up in one
    order whatever the files' names and order."""
    return {
        name: [demos[i] for i in content_order(demos)] for name, demos in dataset.items()
    }
