"""The choice itself: the settings a fit leaves to the data (None), chosen by the rule of
``Settings.select`` over the trial plan (:mod:`promp.selection.trials`), the lowest mean
log-loss among the candidates inside the data region, a tie to the reference settings; and
the report of the choice, which a later refit may keep (:mod:`promp.selection.keep`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from promp.data import Demonstration, Layout
from promp.duration import choose_temperature
from promp.model import FALLBACK, Settings
from promp.selection.candidates import (
    BASIS_GRID,
    NOISE_GRID,
    WIDTH_GRID,
    Candidates,
    preference,
)
from promp.selection.cv import RULE, cv_search
from promp.selection.keep import KEPT_RULE, keep_previous
from promp.selection.recognition_choice import (
    BANDWIDTHS,
    KEPT_RECOGNITION_RULE,
    choose_recognition,
    kept_bandwidths,
)
from promp.selection.region import data_region
from promp.selection.search import LOO_RULE, walk
from promp.selection.trials import LOO_MAX_TRIALS, MAX_TRIALS, plan_trials

__all__ = ["TEMPERATURE_RULE", "choose_settings"]


TEMPERATURE_RULE = (
    "the largest power of the likelihood in the speed's posterior (of 1, 1/sqrt 2, ..., 1/256) "
    "whose 90 % intervals hold the true speed of at least ceil(0.9 (n + 1)) / n of the n "
    "held-out training demonstrations (nested conformal; the same trials, closed-form "
    "leave-one-out, at the chosen settings)"
)


def choose_settings(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
    previous: Mapping | None = None,
) -> tuple[Settings, dict]:
    """``settings`` with every automatic one (None) chosen from ``dataset``, and the report of
    the choice (JSON-ready: the rule, the values chosen, the score of every candidate).

    Parameters
    ----------
    dataset : mapping of str to list of Demonstration
        The training demonstrations of every primitive.
    dt : float
        The sample period (s) the model will use.
    previous : mapping, optional
        The report of the choice made for nearly the same demonstrations (the studio's last
        fit, before a demonstration was added or deleted). With the leave-one-out rule the
        search runs again only when the evidence says the choice may have changed: the
        previous choice and the previous runner-up are scored on ``dataset``'s trials (a
        paired comparison) and the choice is kept while it still wins
        (:data:`promp.selection.keep.KEPT_RULE`), at most
        :data:`~promp.selection.keep.KEEP_LIMIT` times in a row. The recognition variant is
        then kept with them while it still beats the ProMP
        (:func:`~promp.selection.recognition_choice.kept_bandwidths`): a kept ProMP costs no
        mixture's scoring, a kept mixture one bandwidth's instead of every one's.
    """
    chosen, report, candidates = _choose(dataset, layout, settings, dt, previous)
    report = dict(report)
    scorer, scale = None, 1.0
    if candidates is not None:
        scale = chosen.noise_scale / candidates.inner.noise_scale
        scorer = candidates(chosen.n_basis, chosen.width)
    if settings.duration_temperature is None:
        tau, scores = 1.0, {}
        if scorer is not None:
            tau, scores = choose_temperature(scorer.speed_trials(scale))
        chosen = dataclasses.replace(chosen, duration_temperature=tau)
        report["duration_temperature"] = {
            "value": tau,
            "rule": TEMPERATURE_RULE if scores else "1 (no demonstration could be held out)",
            "coverage": {str(t): round(v, 4) for t, v in scores.items()},
        }
    if settings.recognition is None:
        if scorer is None:
            name, why = "promp", {"value": "promp", "rule": "the ProMP (no demonstration could "
                                  "be held out)", "log_loss": {}}  # fmt: skip
        else:
            kept = None
            if report.get("rule") == KEPT_RULE and isinstance(previous, Mapping):
                kept = kept_bandwidths(previous.get("recognition"))
            name, why = choose_recognition(scorer, scale, BANDWIDTHS if kept is None else kept)
            if kept is not None:
                why["rule"] = KEPT_RECOGNITION_RULE
        chosen = dataclasses.replace(chosen, recognition=name)
        report["recognition"] = why
    return chosen, report


def _choose(
    dataset: Mapping[str, Sequence[Demonstration]],
    layout: Layout,
    settings: Settings,
    dt: float,
    previous: Mapping | None,
) -> tuple[Settings, dict, Candidates | None]:
    """:func:`choose_settings` without the temperature, and the candidates' scorers (None
    when nothing can be held out)."""
    automatic = settings.automatic
    given = {name: getattr(settings, name) for name in FALLBACK if name not in automatic}
    loo = settings.select == "loo" or not automatic  # (only the temperature: the leave-one-out
    # scorer gives it)
    trials = plan_trials(dataset, layout, max_trials=LOO_MAX_TRIALS if loo else MAX_TRIALS)
    if not trials:
        reason = (
            "a single primitive: nothing to recognise"
            if len(dataset) < 2
            else "no primitive has three demonstrations: none can be held out"
        )
        chosen = settings.with_fallback()
        return chosen, {
            "rule": f"fallback values ({reason})",
            "chosen": {name: getattr(chosen, name) for name in automatic},
            "given": given,
        }, None
    fixed_scale = settings.noise_scale
    inner = dataclasses.replace(settings, noise_scale=fixed_scale or 1.0)
    scales = NOISE_GRID if fixed_scale is None else (1.0,)
    basis_grid = BASIS_GRID if settings.n_basis is None else (settings.n_basis,)
    width_grid = WIDTH_GRID if settings.width is None else (settings.width,)
    start_width = 1.0 if settings.width is None else settings.width
    region = data_region(dataset, layout)
    candidates = Candidates(dataset, layout, inner, dt, trials, region)
    if not automatic:
        return settings, {"rule": "given", "chosen": {}, "given": given}, candidates
    if loo and previous is not None:
        kept = keep_previous(candidates, settings, previous)
        if kept is not None:
            return (*kept, candidates)
    # every candidate scored: {(n_basis, width): {noise scale: losses per trial}}
    scores: dict[tuple[int, float], dict[float, np.ndarray]] = {}
    if loo:
        walk(candidates, scales, basis_grid, width_grid, scores)
    else:
        cv_search(dataset, layout, inner, dt, trials, scales, (basis_grid, width_grid),
                  start_width, region, scores)  # fmt: skip
    chosen, report = _lowest(settings, scores, inner.noise_scale, LOO_RULE if loo else RULE,
                             len(trials))  # fmt: skip
    return chosen, report, candidates


def _lowest(
    settings: Settings, scores: dict, scale_unit: float, rule: str, n_trials: int
) -> tuple[Settings, dict]:
    """The candidate of the lowest mean loss among ``scores`` ({(n_basis, width): {noise
    scale in units of ``scale_unit``: losses per trial}}), and the report of the choice
    (``rule``, the runner-up, every candidate's loss); the fallback values when every
    candidate left the demonstrations' region."""
    automatic = settings.automatic
    given = {name: getattr(settings, name) for name in FALLBACK if name not in automatic}
    table = [
        (m, w, s * scale_unit, losses)
        for (m, w), by_scale in scores.items()
        for s, losses in by_scale.items()
    ]
    if not any(np.isfinite(c[3]).all() for c in table):
        chosen = settings.with_fallback()
        return chosen, {
            "rule": "fallback values (every candidate's mean trajectory left the region the "
            "demonstrations span)",
            "chosen": {name: getattr(chosen, name) for name in automatic},
            "given": given,
        }
    # the lowest mean loss; a tie (e.g. every candidate perfect) goes to the reference
    n_basis, width, noise_scale, losses = min(
        table, key=lambda c: (round(float(c[3].mean()), 9), preference(*c[:3]))
    )
    chosen = dataclasses.replace(settings, n_basis=n_basis, width=width, noise_scale=noise_scale)
    others = [
        c for c in table
        if c[:3] != (n_basis, width, noise_scale) and np.isfinite(c[3]).all()
    ]  # fmt: skip
    margin: dict = {"kept": 0}
    if others:  # the best of the others: what a later refit checks the choice against
        m, w, scale, runner_losses = min(
            others, key=lambda c: (round(float(c[3].mean()), 9), preference(*c[:3]))
        )
        runner = dataclasses.replace(settings, n_basis=m, width=w, noise_scale=scale)
        margin["runner_up"] = {name: getattr(runner, name) for name in automatic}
        margin["runner_up_log_loss"] = float(runner_losses.mean())
    return chosen, {
        "rule": rule,
        "chosen": {name: getattr(chosen, name) for name in automatic},
        "given": given,
        "log_loss": float(losses.mean()),
        "trials": n_trials,
        **margin,
        "candidates": [
            {"n_basis": m, "width": w,
             "noise_scale": [s * scale_unit for s in sorted(by_scale)],
             "log_loss": [round(float(by_scale[s].mean()), 6)
                          if np.isfinite(by_scale[s]).all() else None
                          for s in sorted(by_scale)]}
            for (m, w), by_scale in scores.items()
        ],
    }  # fmt: skip
