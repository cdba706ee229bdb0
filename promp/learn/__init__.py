"""Learning a model: the settings the data leaves open are chosen, then the primitives fitted.

:func:`fit` is the entry point of the library. It sits above :mod:`promp.model` (the fit with
every setting given) and :mod:`promp.selection` (the choice, which fits and scores candidate
models), so neither imports the other's caller.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from promp.content_key import canonical_dataset
from promp.data import Demonstration, Layout, sample_period_of
from promp.fitting import fit_with
from promp.model import ProMPModel, Settings
from promp.selection import choose_settings

__all__ = ["choose", "fit"]


def fit(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings | None = None,
    sample_period: float | None = None,
    previous: Mapping | None = None,
    regions: bool = True,
) -> ProMPModel:
    """Learn one primitive per entry of ``dataset`` ({primitive name: demonstrations}).

    Per demonstration, ridge weights on the phase basis (Eqs. 1-2); per primitive, their mean
    and covariance, under a prior pooled across the primitives (Eqs. 3-4), regressed on the
    log speed; the observation noise of every modality and its Eq. 7 speed model
    (:mod:`promp.fitting`). The demonstrations are taken in the order of their content
    (:func:`promp.content_key.canonical_dataset`): the model is the same, to the last bit,
    whatever their names and order. Settings left to the data (None: by default the basis count, its
    width, the noise scale and the duration's temperature) are chosen from ``dataset`` first
    by :func:`promp.selection.choose_settings`.

    Parameters
    ----------
    dataset : mapping of str to sequence of Demonstration
        ``{primitive name: demonstrations}``, at least 2 per primitive, each with the
        layout's columns.
    layout : Layout
        The modalities to learn (columns of the demonstrations; others are ignored).
    settings : Settings, optional
        Default ``Settings()``: everything automatic.
    sample_period : float, optional
        The period (s) that converts alpha to durations; default: the demonstrations'
        median sample step.
    previous : mapping, optional
        The ``report["settings"]`` of a fit of nearly the same demonstrations (the studio's
        refit after a demonstration was added or deleted), which the choice may keep.
    regions : bool, default True
        Calibrate each primitive's drawn region on its demonstrations left out in turn
        (:attr:`~promp.model.Primitive.region_scale`, :mod:`promp.region_calibration`).
        Recognition and prediction never read it: the evaluation's folds skip it.

    Returns
    -------
    ProMPModel
        Its ``settings`` hold the values used, ``report["settings"]`` what was chosen, and
        why.

    Raises
    ------
    ValueError
        No primitive, a primitive with fewer than 2 demonstrations, a demonstration without
        the layout's columns.
    """
    settings = settings or Settings()
    dataset, dt = _checked(dataset, sample_period)
    if settings.to_choose:
        settings, choice = choose_settings(dataset, layout, settings, dt, previous)
    else:
        choice = {"rule": "given (n_basis, width, noise_scale and duration_temperature set "
                  "explicitly)"}  # fmt: skip
    model = fit_with(dataset, layout, settings, dt, regions=regions)
    return dataclasses.replace(model, report={"settings": choice, **model.report})


def choose(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings | None = None,
    sample_period: float | None = None,
) -> Settings:
    """The settings :func:`fit` would learn ``dataset`` with: every automatic one chosen (the
    duration's temperature too), the given ones kept. ``fit(other, layout, choose(dataset,
    ...))`` learns ``other`` at the settings chosen on ``dataset`` without choosing again (the
    evaluation's folds: :func:`promp.evaluate.sweep.run_sweep`). The arguments and errors are
    :func:`fit`'s."""
    settings = settings or Settings()
    dataset, dt = _checked(dataset, sample_period)
    if settings.to_choose:
        settings, _ = choose_settings(dataset, layout, settings, dt)
    return settings


def _checked(
    dataset: Mapping[str, Sequence[Demonstration]], sample_period: float | None
) -> tuple[dict[str, list[Demonstration]], float]:
    """``dataset`` in the order of its demonstrations' content and the sample period, checked
    as :func:`fit` says."""
    if not dataset:
        raise ValueError("no primitive to learn: the dataset is empty")
    # Each primitive's demonstrations in the order of their content: the choice's trials and
    # every sum of the fit do not depend on the files' names or the order they were read in.
    dataset = canonical_dataset(dataset)
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
    return dataset, dt
