"""A held-out trial's probabilities at every observed step: what ``--decide`` judges.

The fixed-share rows observe each held-out demonstration at a few percentages. To judge *when*
a method would act (:mod:`promp.decision`, :mod:`promp.evaluate.decisions`), every held-out
demonstration is also observed every 2 % (:data:`DECISION_PERCENTS`) by the model its fold
fitted once (:func:`promp.evaluate.sweep.run_sweep`'s ``decide_percents``): one
:class:`ProbabilityPath` per method, observed modalities and alpha method.

A method that has ``probabilities_at(demo, n_observed, observe, alpha_method)`` (ours, which
recognises without conditioning or predicting and reuses the likelihood's sums from one step
to the next) gives the whole path at once; any other is asked ``infer`` at every step. A step
the method cannot run (it raises ``ValueError``: e.g. a baseline given one sample) has no
probabilities (a row of NaN), and a decision rule cannot commit there.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from promp.data import Demonstration
from promp.timing import n_observed_for

__all__ = [
    "checked_percents", "DECISION_PERCENTS", "probability_paths", "ProbabilityPath", "step_times",
]  # fmt: skip

DECISION_PERCENTS = tuple(float(p) for p in range(2, 101, 2))  # every 2 % of the movement


@dataclass(frozen=True, eq=False)
class ProbabilityPath:
    """One held-out demonstration observed at every step, by one method.

    Attributes
    ----------
    method : str
    primitive : int
        The true primitive (index into the sweep's primitives).
    demo : str
    alpha_method : str
    observed : tuple of str
    percents : array, shape (n_steps,)
        The observed share at each step, % of the movement.
    times : array, shape (n_steps,)
        The latest observed sample's time at each step, seconds from the movement's start.
    probabilities : array, shape (n_steps, n_primitives)
        The method's probabilities at each step (a row of NaN where it gave none).
    error : str
        Why the method gave nothing at some step ('' when it always answered).
    """

    method: str
    primitive: int
    demo: str
    alpha_method: str
    observed: tuple[str, ...]
    percents: np.ndarray
    times: np.ndarray
    probabilities: np.ndarray
    error: str = ""


def checked_percents(percents: Sequence[float]) -> list[float]:
    """``percents`` as floats, checked: increasing, each in (0, 100].

    Raises
    ------
    ValueError
        Otherwise (the sweep's ``decide_percents``).
    """
    out = [float(p) for p in percents]
    if any(not 0.0 < p <= 100.0 for p in out) or out != sorted(set(out)):
        raise ValueError(f"decide_percents must increase within (0, 100], got {out}")
    return out


def step_times(demo: Demonstration, percents: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """The samples observed at each of ``percents`` (``ceil(p / 100 n)``, as the fixed-share
    rows) and the time of the last of them, seconds from the movement's start."""
    n_observed = np.array([n_observed_for(p, demo.n_samples) for p in percents], dtype=int)
    return n_observed, demo.times[n_observed - 1] - demo.times[0]


def probability_paths(
    method: object,
    method_name: str,
    primitive: int,
    demo: Demonstration,
    percents: Sequence[float],
    observe_sets: Sequence[Sequence[str]],
    alpha_methods: Sequence[str],
    n_primitives: int,
    fit_error: str = "",
) -> list[ProbabilityPath]:
    """The paths of held-out ``demo`` (of primitive index ``primitive``) by the fitted
    ``method``, one per observed set and alpha method; all NaN when its fit failed
    (``fit_error`` says why)."""
    n_observed, times = step_times(demo, percents)
    paths = []
    for observed in observe_sets:
        for alpha_method in alpha_methods:
            if fit_error:
                p, error = np.full((len(percents), n_primitives), np.nan), fit_error
            else:
                p, error = _probabilities(method, demo, n_observed, observed, alpha_method,
                                          n_primitives)  # fmt: skip
            paths.append(ProbabilityPath(method_name, primitive, demo.name, alpha_method,
                                         tuple(observed), np.asarray(percents, dtype=float),
                                         times, p, error))  # fmt: skip
    return paths


def _probabilities(
    method: object,
    demo: Demonstration,
    n_observed: np.ndarray,
    observed: Sequence[str],
    alpha_method: str,
    n_primitives: int,
) -> tuple[np.ndarray, str]:
    """(n_steps, n_primitives) probabilities of ``method`` at each step, and the first
    reason it gave none."""
    whole = getattr(method, "probabilities_at", None)
    if whole is not None:
        return whole(demo, n_observed, observed, alpha_method)
    out = np.full((n_observed.shape[0], n_primitives), np.nan)
    error = ""
    answered: dict[int, np.ndarray] = {}  # a short movement repeats a step's sample count
    for i, n in enumerate(n_observed.tolist()):
        if n not in answered:
            try:
                answered[n] = method.infer(demo, n, observed, alpha_method).probabilities
            except ValueError as exc:
                answered[n] = np.full(n_primitives, np.nan)
                error = error or str(exc)
        out[i] = answered[n]
    return out, error
