"""Leave-one-out sweep: the protocol behind the paper's curves.

Every demonstration of every primitive is held out in turn; the method is fitted on all the
others (weights, covariance, noise, alpha models: nothing sees the held-out demonstration).
The first ``n_o = ceil(p / 100 * n)`` samples of the observed modalities are shown, the
primitive is recognised, the weights are conditioned on the recognised primitive, and the rest
is predicted. Results are averaged per (percent, alpha method, observed modalities).

Several methods run in one sweep (``method_factory`` a mapping of names to factories): every
fold fits each of them on the same training demonstrations and tests the same held-out one at
the same settings, so their rows (one per method, percent, alpha method and observed
modalities) compare trial for trial.

Folds are independent: ``jobs`` runs them on several processes (joblib; ``-1`` = every core)
and ``scheduler`` on a Dask cluster (``dask.distributed``, the ``cluster`` extra), with results
identical to one process (:mod:`promp.evaluate.folds`, which also says what a fold holds out).

``held_out`` restricts the sweep to some demonstrations (:func:`spread_subset`: a few per
primitive, evenly spread from its shortest to its longest, the same for every method): each is
still tested by a model fitted on every other demonstration, so a quick run measures the same
thing on fewer trials.

``groups`` holds out a whole group at a time instead (a subject's or a session's
demonstrations, :mod:`promp.evaluate.groups`): every demonstration of the group is tested by a
model fitted on the demonstrations of every other group. Leave-one-out is the case of groups of
one.

Nothing depends on the demonstrations' names or order: every fold's training demonstrations
are given to the methods in the order of their content (:mod:`promp.content_key`), and the
rows' means are exact sums (``math.fsum``), the same in any order.

A trial the method cannot run (it raises ``ValueError``: e.g. an observation it has no
explanation for) does not end the sweep: it counts as a recognition error, is left out of the
trajectory metrics, and is listed by primitive, demonstration and reason in the row's
``failed`` and in :attr:`SweepResult.failures`.

``decide_percents`` (``--decide``): each held-out demonstration also observed at each of them
by its fold's model, the probabilities kept in :attr:`SweepResult.paths`
(:mod:`promp.evaluate.paths`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from promp import metrics
from promp.content_key import content_key
from promp.data import Demonstration, Layout, sample_period_of
from promp.evaluate.folds import (  # noqa: F401  (MIN_TRAINING, check_groups re-exported)
    CHOICE_BLOCKS,
    MIN_TRAINING,
    Fold,
    Pair,
    check_groups,
    chosen_settings,
    planned_folds,
    run_folds,
    without,
)
from promp.evaluate.methods import ALPHA_ROWS, ProMPEngine, TrialAnswer
from promp.evaluate.paths import ProbabilityPath, checked_percents, probability_paths
from promp.metrics import position_modality  # (also re-exported)
from promp.model import Settings
from promp.timing import n_observed_for  # noqa: F401  (re-exported)

__all__ = [
    "CONFIDENT_MISTAKE", "Factory", "LEAVE_ONE_OUT", "MIN_TRAINING", "Pair", "Progress",
    "SweepResult", "Trial", "check_groups", "leave_one_out", "run_sweep", "spread_subset",
]  # fmt: skip

Progress = Callable[[int, int], None]
Factory = Callable[[], object]
LEAVE_ONE_OUT = "leave-one-out"  # the protocol of a sweep without groups
# A trial whose true primitive got p < 0.01 is a confident mistake (-ln 0.01 = 4.6 nats).
CONFIDENT_MISTAKE = -math.log(0.01)


@dataclass
class Trial:
    """One held-out demonstration at one setting; ``inferred`` is None (and ``error`` says
    why) when the method failed on it."""

    primitive: int
    demo: str
    percent: float
    alpha_method: str
    observed: tuple[str, ...]
    inferred: TrialAnswer | None
    position_error_m: float = math.nan
    goal_error_m: float = math.nan
    duration_error_s: float = math.nan
    duration_covered: float = math.nan  # 1 if the duration's interval holds the truth, else 0
    nrmse_prior: float = math.nan
    nrmse_posterior: float = math.nan
    error: str = ""
    method: str = ""  # the method's name (its key in the sweep's methods)

    @property
    def correct(self) -> bool:
        return self.inferred is not None and self.inferred.index == self.primitive

    def log_loss(self, n_primitives: int) -> float:
        """``-ln p(true primitive)``; a failed trial counts as a uniform guess, ``ln K``."""
        if self.inferred is None:
            return math.log(n_primitives)
        p_true = float(self.inferred.probabilities[self.primitive])
        return -math.log(min(max(p_true, 1e-300), 1.0))


@dataclass
class SweepResult:
    """What a leave-one-out sweep gives (:func:`run_sweep`, :func:`leave_one_out`).

    Attributes
    ----------
    rows : list of dict
        One per (percent, alpha method, observed set): ``recognition_errors``, ``trials``,
        ``log_loss`` (mean ``-ln p(true primitive)``), ``confident_mistakes``, position,
        goal and duration errors, ``duration_coverage``, ``nrmse_prior``,
        ``nrmse_posterior``, ``failed``.
    trials : list of Trial
        Every trial, when kept.
    failures : list of dict
        The trials the method could not run, and why.
    partial : bool
        Stopped before every demonstration was held out (``stop``).
    paths : list of ProbabilityPath
        With ``decide_percents``: the probabilities at each, per trial, method, observed set.
    chosen : dict
        The settings each method chose per block (:func:`promp.evaluate.folds.chosen_settings`).
    """

    rows: list[dict] = field(default_factory=list)
    trials: list[Trial] = field(default_factory=list)
    failures: list[dict] = field(default_factory=list)  # trials the method failed on
    partial: bool = False  # stopped before every demonstration was held out (``stop``)
    paths: list[ProbabilityPath] = field(default_factory=list)  # with ``decide_percents``
    chosen: dict = field(default_factory=dict)


def _run_fold(
    methods: Mapping[str, Factory],
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    fold: tuple[tuple[Pair, ...], tuple[Pair, ...]],
    dt: float,
    percents: Sequence[float],
    alpha_methods: Sequence[str],
    observe_sets: Sequence[Sequence[str]],
    decide_percents: Sequence[float] = (),
    choices: Mapping[Pair, Mapping[str, object]] | None = None,
) -> list[Trial | ProbabilityPath]:
    """Fit every method without the demonstrations ``fold[0]`` (a set of (primitive index,
    demonstration index) pairs), on the others in the order of their content, then infer each
    of ``fold[1]`` at every setting (and, with ``decide_percents``, at each of them: its
    probability paths). ``choices``: {held-out pair: {method name: its settings chosen
    without that pair's block}} (:func:`promp.evaluate.folds.block_choices`), given to the
    methods' fits."""
    tested = fold[1]
    chosen = (choices or {}).get(fold[0][0], {}) if len(fold[0]) == 1 else {}
    names = list(dataset)
    pos_dims = layout.dims([position_modality(layout)])
    train = without(dataset, fold[0])
    fitted = []
    for method_name, factory in methods.items():
        method = factory()
        try:
            if chosen.get(method_name) is not None:
                method.fit(train, dt, chosen=chosen[method_name])
            else:
                method.fit(train, dt)
            fit_error = ""
        except ValueError as exc:
            fit_error = f"fit without it failed: {exc}"
        fitted.append((method_name, method, fit_error))
    trials = []
    for k, j in tested:
        demo = dataset[names[k]][j]
        truth = layout.extract(demo)[:, pos_dims]
        for method_name, method, fit_error in fitted:
            for percent in percents:
                n_o = n_observed_for(percent, demo.n_samples)
                for observed in observe_sets:
                    for alpha_method in alpha_methods:
                        trial = Trial(k, demo.name, float(percent), alpha_method,
                                      tuple(observed), None, method=method_name)  # fmt: skip
                        try:
                            if fit_error:
                                raise ValueError(fit_error)
                            inferred = method.infer(demo, n_o, observed, alpha_method)
                        except ValueError as exc:
                            trial.error = str(exc)
                        else:
                            _measure(trial, inferred, truth, demo.duration, n_o, pos_dims)
                        trials.append(trial)
            if decide_percents:  # the same fitted method, every step of the held-out movement
                trials.extend(probability_paths(
                    method, method_name, k, demo, decide_percents, observe_sets,
                    alpha_methods, len(names), fit_error,
                ))  # fmt: skip
    return trials


def spread_subset(
    dataset: Mapping[str, Sequence[Demonstration]], per_primitive: int
) -> list[Pair]:
    """``per_primitive`` demonstrations of every primitive, evenly spread over its
    demonstrations ordered by duration (the shortest, the longest and equal steps between;
    equal durations by their content, :func:`promp.content_key.content_key`): deterministic,
    every primitive represented, the same whatever the files' names and order. As (primitive
    index, demonstration index) pairs, by primitive then index; all of a primitive that has
    fewer."""
    if per_primitive < 1:
        raise ValueError(f"hold out at least one demonstration per primitive, got {per_primitive}")
    out = []
    for k, demos in enumerate(dataset.values()):
        n = len(demos)
        ranked = sorted(range(n), key=lambda i: (demos[i].duration, content_key(demos[i])))
        picks = np.unique(np.round(np.linspace(0, n - 1, min(per_primitive, n))).astype(int))
        out.extend((k, j) for j in sorted(ranked[int(p)] for p in picks))
    return out


def run_sweep(
    method_factory: Factory | Mapping[str, Factory],
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    percents: Sequence[float],
    alpha_methods: Sequence[str],
    observe_sets: Sequence[Sequence[str]],
    method_name: str = "",
    progress: Progress | None = None,
    keep_trials: bool = False,
    jobs: int = 1,
    scheduler: str | None = None,
    held_out: Sequence[Pair] | None = None,
    stop: Callable[[], bool] | None = None,
    decide_percents: Sequence[float] = (),
    groups: Mapping[str, Sequence[Pair]] | None = None,
    choice_blocks: int = CHOICE_BLOCKS,
    choosing: Progress | None = None,
) -> SweepResult:
    """Run the leave-one-out protocol (or the grouped one, ``groups``); one result row per
    (method, percent, alpha, observed).

    ``method_factory`` makes a fresh method (``fit``, ``infer``), named ``method_name``; or a
    mapping of names to such factories: the methods then run on the same folds and settings,
    and the rows come method by method, in the mapping's order.

    ``jobs`` processes run the folds (-1: every core); ``scheduler`` (a Dask scheduler's
    address) runs them on that cluster instead. The results do not depend on either.
    ``held_out``: the (primitive index, demonstration index) pairs to test, each with a model
    fitted on all the others (default: every demonstration; see :func:`spread_subset`).
    ``groups``: {group name: its (primitive index, demonstration index) pairs}, every
    demonstration in one group (:func:`promp.evaluate.groups.group_pairs`): each fold holds
    out a whole group and tests those of its demonstrations in ``held_out``; ValueError when
    a fold would leave a primitive fewer than :data:`MIN_TRAINING` demonstrations to learn
    from. ``stop()`` is asked after every fold (and every block's choice of the settings):
    once true, the sweep ends there and its rows hold the folds done (the result says it is
    ``partial``).
    ``decide_percents``: each trial's probabilities at each, too (:attr:`SweepResult.paths`).
    ``choice_blocks``: without ``groups``, a method that chooses its settings (``choose``)
    does so once per block of that many (:func:`promp.evaluate.folds.choice_blocks`); 0:
    every fold's fit chooses its own. ``choosing`` is called with (blocks chosen, blocks) as
    they are, before any fold (``progress`` then counts the folds).
    """
    names = list(dataset)
    if isinstance(method_factory, Mapping):
        methods = dict(method_factory)
        if not methods:
            raise ValueError("name at least one method to evaluate")
    else:
        methods = {method_name: method_factory}
    held_out = _held_out(dataset, held_out)
    dt = sample_period_of([d for demos in dataset.values() for d in demos])
    decide_percents = checked_percents(decide_percents)
    folds, choices = planned_folds(methods, dataset, held_out, groups, dt, (jobs, scheduler),
                                   choice_blocks, stop, choosing)  # fmt: skip
    if choices is None:  # stopped while choosing: no fold done
        return SweepResult(partial=True)
    fold = functools.partial(
        _run_fold,
        methods,
        dataset,
        layout,
        dt=dt,
        percents=list(percents),
        alpha_methods=list(alpha_methods),
        observe_sets=[list(o) for o in observe_sets],
        decide_percents=decide_percents,
        choices=choices,
    )
    acc: dict[tuple, list[Trial]] = {}
    result = SweepResult(chosen=chosen_settings(choices))
    for done, trials in enumerate(run_folds(fold, folds, jobs, scheduler, progress), 1):
        for trial in trials:
            if isinstance(trial, ProbabilityPath):
                result.paths.append(trial)
                continue
            key = (trial.method, trial.percent, trial.alpha_method, trial.observed)
            acc.setdefault(key, []).append(trial)
        if stop is not None and done < len(folds) and stop():
            result.partial = True
            break
    for key, trials in acc.items():
        result.rows.append(_row(key, trials, names))
        result.failures.extend(
            {
                "method": key[0],
                "primitive": names[t.primitive],
                "demo": t.demo,
                "percent": t.percent,
                "alpha_method": t.alpha_method,
                "observed": list(t.observed),
                "error": t.error,
            }
            for t in trials
            if t.inferred is None
        )
        if keep_trials:
            result.trials.extend(trials)
    order = {name: i for i, name in enumerate(methods)}
    result.rows.sort(
        key=lambda r: (order[r["method"]], r["observed"], r["alpha_method"], r["percent"])
    )
    return result


def _held_out(
    dataset: Mapping[str, Sequence[Demonstration]], held_out: Sequence[tuple[int, int]] | None
) -> list[tuple[int, int]]:
    """The (primitive index, demonstration index) pairs to test, checked: every
    demonstration by default.

    Raises
    ------
    ValueError
        A primitive with fewer than 3 demonstrations, an unknown or repeated pair, none.
    """
    for name, demos in dataset.items():
        if len(demos) < 3:
            raise ValueError(
                f"leave-one-out needs at least 3 demonstrations per primitive; "
                f"{name!r} has {len(demos)}"
            )
    everyone = [(k, j) for k, name in enumerate(dataset) for j in range(len(dataset[name]))]
    if held_out is None:
        return everyone
    held_out = [(int(k), int(j)) for k, j in held_out]
    unknown = sorted(set(held_out) - set(everyone))
    if unknown:
        raise ValueError(f"no demonstration (primitive index, index) {unknown[0]} to hold out")
    if len(set(held_out)) != len(held_out) or not held_out:
        raise ValueError("held_out must name distinct demonstrations, at least one")
    return held_out


def _row(key: tuple, trials: list[Trial], names: list[str]) -> dict:
    """The result row of the ``trials`` of one (method, percent, alpha method, observed)."""
    method, percent, alpha_method, observed = key
    losses = [t.log_loss(len(names)) for t in trials]
    return {
        "percent": percent,
        "alpha_method": alpha_method,
        "observed": list(observed),
        "method": method,
        "recognition_errors": int(sum(not t.correct for t in trials)),
        "trials": len(trials),
        "log_loss": math.fsum(losses) / len(losses),  # exact: the same in any order
        "confident_mistakes": int(sum(loss > CONFIDENT_MISTAKE for loss in losses)),
        "worst_log_loss": float(max(losses)),
        "position_error_m": _nanmean([t.position_error_m for t in trials]),
        "goal_error_m": _nanmean([t.goal_error_m for t in trials]),
        "duration_error_s": _nanmean([t.duration_error_s for t in trials]),
        "duration_coverage": _nanmean([t.duration_covered for t in trials]),
        "nrmse_prior": _nanmean([t.nrmse_prior for t in trials]),
        "nrmse_posterior": _nanmean([t.nrmse_posterior for t in trials]),
        "failed": [f"{names[t.primitive]}/{t.demo}" for t in trials if t.inferred is None],
    }


def leave_one_out(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    percents: Sequence[float],
    settings: Settings | None = None,
    alpha_methods: Sequence[str] = ("ml", "model"),
    observe: Sequence[Sequence[str]] | None = None,
    jobs: int = 1,
    progress: Progress | None = None,
) -> SweepResult:
    """The leave-one-out evaluation of the method on ``dataset``: what
    ``python -m promp.evaluate`` runs, the protocol of the paper's curves (module docstring).

    Every demonstration is held out in turn; :func:`promp.learn.fit` learns from all the
    others (with ``settings``: by default its basis, width and noise are chosen without the
    held-out demonstration, once per block of a tenth of the set:
    :func:`promp.evaluate.folds.choice_blocks`); the first ``p`` % of the held-out one's samples
    (``n_o = ceil(p / 100 n)``) in the ``observe`` modalities are recognised, conditioned on
    and the rest predicted (:func:`promp.evidence.infer`), and measured against it.

    Parameters
    ----------
    dataset : mapping of str to sequence of Demonstration
        ``{primitive name: demonstrations}``, at least 3 per primitive.
    layout : Layout
        The modalities the model learns (:func:`promp.read_dataset` gives one).
    percents : sequence of float
        The observed shares p, each in (0, 100].
    settings : Settings, optional
        The learning settings of every fold (default ``Settings()``: chosen per block).
    alpha_methods : sequence of str
        How the speed is found, rows of the result: ``"ml"`` (integrated over the
        primitive's speed prior), ``"model"`` (Eq. 7 from the early motion), ``"true"`` (the
        held-out movement's true duration told: the oracle row).
    observe : sequence of sequences of str, optional
        The observed modality sets, one row each (default: the position modality alone,
        ``hand`` when the layout has it).
    jobs : int
        Processes running the folds (-1: every core); the results do not depend on it.
    progress : callable, optional
        Called with (folds done, folds) after every fold.

    Returns
    -------
    SweepResult
        ``rows``: one dict per (percent, alpha method, observed set): recognition errors,
        ``log_loss`` (mean ``-ln p(true primitive)``), position, goal and duration errors,
        NRMSE...; ``trials``: every trial; ``failures``: the trials the method could not run.

    Raises
    ------
    ValueError
        A percent outside (0, 100], an unknown alpha method or modality, ``jobs`` 0 or below
        -1, a primitive with fewer than 3 demonstrations.
    """
    percents = [float(p) for p in percents]
    if not percents or any(not 0.0 < p <= 100.0 for p in percents):
        raise ValueError(f"percents must be in (0, 100], at least one; got {percents}")
    unknown = sorted(set(alpha_methods) - set(ALPHA_ROWS))
    if unknown or not alpha_methods:
        raise ValueError(f"alpha_methods must be some of {list(ALPHA_ROWS)}, got "
                         f"{list(alpha_methods)}")  # fmt: skip
    observe = [list(names) for names in observe] if observe else [[position_modality(layout)]]
    for names in observe:
        layout.observed(names)  # an unknown modality is a ValueError before any work
    if jobs == 0 or jobs < -1:
        raise ValueError(f"jobs must be a positive number or -1, got {jobs}")
    settings = settings if settings is not None else Settings()
    return run_sweep(
        functools.partial(ProMPEngine, layout, settings),
        dataset,
        layout,
        percents=percents,
        alpha_methods=list(alpha_methods),
        observe_sets=observe,
        method_name=ProMPEngine.name,
        progress=progress,
        keep_trials=True,
        jobs=jobs,
    )


def _measure(
    trial: Trial,
    inferred: TrialAnswer,
    truth: np.ndarray,
    true_duration: float,
    n_observed: int,
    pos_dims: np.ndarray,
) -> None:
    """Fill ``trial`` with ``inferred`` and its errors against ``truth`` (the true values of
    the measured modality, shape (n, len(pos_dims)))."""
    posterior = inferred.posterior_mean[:, pos_dims]
    trial.inferred = inferred
    trial.position_error_m = metrics.remainder_error(truth, posterior, n_observed)
    trial.goal_error_m = metrics.goal_error(truth, posterior)
    trial.duration_error_s = abs(inferred.duration - true_duration)
    if math.isfinite(inferred.duration_low) and math.isfinite(inferred.duration_high):
        slack = 1e-9 * true_duration  # round-off of the duration's trip through alpha
        trial.duration_covered = float(
            inferred.duration_low - slack <= true_duration <= inferred.duration_high + slack
        )
    trial.nrmse_prior = metrics.nrmse(truth, inferred.prior_mean[:, pos_dims])
    trial.nrmse_posterior = metrics.nrmse(truth, posterior)


def _nanmean(values: list[float]) -> float:
    """The mean of the finite values (NaN without any), summed exactly: the same in any
    order."""
    finite = [float(v) for v in values if math.isfinite(v)]
    return math.fsum(finite) / len(finite) if finite else float("nan")
