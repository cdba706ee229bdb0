"""Learning a model: the settings the data leaves open are chosen, then the primitives fitted.

:func:`fit` is the entry point of the library. It sits above :mod:`promp.model` (the fit with
every setting given) and :mod:`promp.selection` (the choice, which fits and scores candidate
models), so neither imports the other's caller.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from promp.data import Demonstration, Layout, sample_period_of
from promp.fitting import fit_with
from promp.model import ProMPModel, Settings
from promp.selection import choose_settings


def fit(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings | None = None,
    sample_period: float | None = None,
    previous: Mapping | None = None,
) -> ProMPModel:
    """Learn one primitive per entry of ``dataset`` ({primitive name: demonstrations}).

    Settings left to the data (None: by default the basis count, its width and the noise
    scale) are chosen from ``dataset`` by :func:`promp.selection.choose_settings`; the model's
    ``settings`` hold the values used and ``report["settings"]`` what was chosen, and why.
    ``previous``: the ``report["settings"]`` of a fit of nearly the same demonstrations (the
    studio's refit after a demonstration was added or deleted), which the choice may keep
    (:func:`promp.selection.choose_settings`).

    Raises
    ------
    ValueError
        No primitive, a primitive with fewer than 2 demonstrations, a demonstration without
        the layout's columns.
    """
    settings = settings or Settings()
    if not dataset:
        raise ValueError("no primitive to learn: the dataset is empty")
    all_demos = [d for demos in dataset.values() for d in demos]
    dt = sample_period if sample_period is not None else sample_period_of(all_demos)
    if not np.isfinite(dt) or dt <= 0:
        raise ValueError(f"sample_period must be positive, got {dt}")
    for name, demos in dataset.items():
        if len(demos) < 2:
            raise ValueError(
                f"primitive {name!r} has {len(demos)} demonstration(s); at least 2 are needed "
                "to learn a distribution"
            )
    if settings.automatic or settings.duration_temperature is None:
        settings, choice = choose_settings(dataset, layout, settings, dt, previous)
    else:
        choice = {"rule": "given (n_basis, width, noise_scale and duration_temperature set "
                  "explicitly)"}  # fmt: skip
    model = fit_with(dataset, layout, settings, dt)
    return dataclasses.replace(model, report={"settings": choice, **model.report})
