"""The settings every fit chooses from its training demonstrations (promp.selection)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp import selection
from promp.data import Demonstration, Layout, Modality
from promp.io import model_from_json, model_to_json
from promp.learn import choose, fit
from promp.model import FALLBACK, Settings
from promp.selection import batches, candidates, loo, search
from tests.synthetic import LAYOUT, make_dataset

HAND = Layout((Modality("hand", ("x", "y", "z")),))


def wiggles(seed: int, n_demos: int = 6) -> dict[str, list[Demonstration]]:
    """Two primitives with the same smooth reach, told apart only by a wiggle of six periods
    (opposite signs): a basis of five or seven functions cannot represent it."""
    rng = np.random.default_rng(seed)
    dataset = {}
    for name, sign in (("plus", 1.0), ("minus", -1.0)):
        demos = []
        for i in range(n_demos):
            n = int(rng.integers(90, 130))
            z = np.linspace(0.0, 1.0, n)
            reach = np.outer(z, [0.3, 0.1, 0.2]) * (1 + 0.05 * rng.standard_normal(3))
            wiggle = sign * 0.01 * np.sin(2 * np.pi * 6 * z)
            values = reach + wiggle[:, None] + 1e-3 * rng.standard_normal((n, 3))
            demos.append(Demonstration(z * (n - 1) / 50.0, values, ("x", "y", "z"), f"{name}{i}"))
        dataset[name] = demos
    return dataset


def test_a_detail_only_many_basis_functions_represent_chooses_many() -> None:
    """The wiggle decides the primitive, so the rule leaves the reference M = 7 for more."""
    model = fit(wiggles(seed=0), HAND)
    report = model.report["settings"]
    assert model.settings.n_basis >= 10 and report["chosen"]["n_basis"] == model.settings.n_basis
    scores = {c["n_basis"]: min(c["log_loss"]) for c in report["candidates"]}
    assert scores[5] > 0.5 and min(scores.values()) < 0.1  # chance with 5, near-certain with more


def test_the_inner_folds_choice_is_the_lowest_inner_log_loss_and_is_recorded() -> None:
    model = fit(make_dataset(seed=1, n_demos=5), LAYOUT, Settings(select="cv"))
    report = model.report["settings"]
    assert report["rule"] == selection.RULE
    assert set(report["chosen"]) == {"n_basis", "width", "noise_scale"} and report["given"] == {}
    best = min(
        (loss, c["n_basis"], c["width"], scale)
        for c in report["candidates"]
        for scale, loss in zip(c["noise_scale"], c["log_loss"], strict=True)
    )
    assert report["log_loss"] == pytest.approx(best[0], abs=1e-6)
    s = model.settings
    assert (s.n_basis, s.width, s.noise_scale) == tuple(report["chosen"].values())
    assert s.n_basis in selection.BASIS_GRID and s.width in selection.WIDTH_GRID
    # M searched at width 1, then the width at the best M: 4 + 2 pairs, every noise scale each
    assert len(report["candidates"]) == len(selection.BASIS_GRID) + len(selection.WIDTH_GRID) - 1
    assert all(c["noise_scale"] == list(selection.NOISE_GRID) for c in report["candidates"])
    # the model file keeps the choice and its reasons
    again = model_from_json(model_to_json(model))
    assert again.report["settings"] == report and again.settings == model.settings


def test_the_leave_one_out_choice_is_the_lowest_loss_it_scored_and_is_recorded() -> None:
    model = fit(make_dataset(seed=1, n_demos=5), LAYOUT)
    report = model.report["settings"]
    assert model.settings.select == "loo" and report["rule"] == selection.LOO_RULE
    assert set(report["chosen"]) == {"n_basis", "width", "noise_scale"}
    scored = [
        (loss, c["n_basis"], c["width"], scale)
        for c in report["candidates"]
        for scale, loss in zip(c["noise_scale"], c["log_loss"], strict=True)
    ]
    assert report["log_loss"] == pytest.approx(min(scored)[0], abs=1e-6)
    s = model.settings
    assert (s.n_basis, s.width, s.noise_scale) == tuple(report["chosen"].values())
    # a coarse-to-fine walk from the reference: never the whole grid of 4 x 3 x 5
    assert (7, 1.0) in {(c["n_basis"], c["width"]) for c in report["candidates"]}
    assert len(scored) < len(selection.BASIS_GRID) * len(selection.WIDTH_GRID) * 5
    again = model_from_json(model_to_json(model))
    assert again.report["settings"] == report and again.settings == model.settings


def test_the_walk_scores_both_neighbours_then_goes_downhill_to_a_local_minimum() -> None:
    seen: list[int] = []

    def bowl(i: int) -> float:
        seen.append(i)
        return (i - 4) ** 2

    search.neighbours_walk(list(range(8)), 1, bowl)
    assert seen == [1, 0, 2, 3, 4, 5]  # right is downhill: on to 4, stopped by 5
    seen.clear()
    search.neighbours_walk(list(range(8)), 4, bowl)
    assert seen == [4, 3, 5]  # already at the bottom
    seen.clear()
    search.neighbours_walk(list(range(8)), 6, bowl, both_sides=False)
    assert seen == [6, 5, 4, 3]  # one side: downhill at once, the other never tried
    seen.clear()
    two_dips = {0: 0.3, 1: 0.5, 2: 0.2, 3: 0.4}.__getitem__  # 5, 7, 10, 14 functions
    search.neighbours_walk([5, 7, 10, 14], 1, lambda i: seen.append(i) or two_dips(i))
    assert seen == [1, 0, 2, 3]  # the walk does not stop at 5 when 10 beats both


def test_the_leave_one_out_downdates_equal_a_refit_without_the_demonstration() -> None:
    """The closed form of :class:`promp.fitting.FitParts`: the held-out prediction of the
    weights (the regression on log alpha refitted without it) and the residual scatter of
    the others, against :func:`promp.fitting._moments` run on the others."""
    from promp.data import sample_period_of
    from promp.fitting import _moments, fit_parts
    from promp.timing import alpha_from_duration

    dataset = make_dataset(seed=5, n_demos=6)
    settings = Settings(n_basis=6, width=1.0, noise_scale=1.0)
    dt = sample_period_of([d for demos in dataset.values() for d in demos])
    _, parts = fit_parts(dataset, LAYOUT, settings, dt, alpha_models=False)
    part, demos = parts[0], dataset["left"]
    assert part.slope_weight > 0  # the regression on log alpha is on
    logs = np.log([alpha_from_duration(d.duration, dt, settings.s_bar) for d in demos])
    for j in (0, 3):
        others = [d for i, d in enumerate(demos) if i != j]
        kept = np.delete(part.weights, j, axis=0)
        refit = _moments(others, kept, settings, dt)
        e, h = part.residuals[j], part.leverage[j]
        predicted = refit.mean + refit.slope * (logs[j] - refit.log_alpha_mean)
        assert np.allclose(part.weights[j] - e / (1.0 - h), predicted, rtol=1e-9, atol=1e-12)
        held = part.residuals.T @ part.residuals - np.outer(e, e) / (1.0 - h)
        assert np.allclose(held, refit.residuals.T @ refit.residuals, rtol=1e-8, atol=1e-14)
        assert refit.dof == part.dof - 1


def test_explicit_settings_override_the_choice() -> None:
    dataset = make_dataset(seed=1, n_demos=5)
    given = fit(dataset, LAYOUT, Settings(n_basis=5, width=1.5, noise_scale=2.0))
    assert (given.settings.n_basis, given.settings.width, given.settings.noise_scale) == (
        5, 1.5, 2.0,
    )  # fmt: skip
    assert given.report["settings"]["rule"].startswith("given")
    partly = fit(dataset, LAYOUT, Settings(n_basis=5, noise_scale=2.0))
    report = partly.report["settings"]
    assert partly.settings.n_basis == 5 and partly.settings.noise_scale == 2.0
    assert set(report["chosen"]) == {"width"} and report["given"] == {
        "n_basis": 5,
        "noise_scale": 2.0,
    }
    assert {c["n_basis"] for c in report["candidates"]} == {5}
    assert all(c["noise_scale"] == [2.0] for c in report["candidates"])


def test_a_fit_chooses_unless_every_setting_and_the_temperature_are_given() -> None:
    given = {"n_basis": 5, "width": 1.5, "noise_scale": 2.0, "duration_temperature": 0.5,
             "recognition": "promp"}  # fmt: skip
    assert not Settings(**given).to_choose
    for left in given:  # any one of them left to the data is a choice to make
        assert Settings(**{k: v for k, v in given.items() if k != left}).to_choose, left
    dataset = make_dataset(seed=1, n_demos=4)
    assert choose(dataset, LAYOUT, Settings(**given)) == Settings(**given)
    chosen = choose(dataset, LAYOUT, Settings(**{**given, "duration_temperature": None}))
    assert chosen.duration_temperature is not None and chosen.n_basis == 5


def test_nothing_to_score_falls_back_and_says_why() -> None:
    one = fit({"left": make_dataset(seed=2, n_demos=4)["left"]}, LAYOUT)
    assert "single primitive" in one.report["settings"]["rule"]
    assert one.report["settings"]["chosen"] == FALLBACK
    two_each = fit(make_dataset(seed=2, n_demos=2), LAYOUT)
    assert "three demonstrations" in two_each.report["settings"]["rule"]
    assert two_each.settings.n_basis == FALLBACK["n_basis"]


def test_the_inner_folds_keep_two_demonstrations_and_ignore_the_primitives_order() -> None:
    dataset = make_dataset(seed=3, n_demos=3)
    dataset["few"] = dataset["left"][:2]  # never held out: it would keep one
    trials = selection.plan_trials(dataset, LAYOUT)
    names = list(dataset)
    assert {names[t.primitive] for t in trials} == {"left", "right"}
    for fold in range(selection.INNER_FOLDS):
        held = {(t.primitive, t.demo) for t in trials if t.fold == fold}
        for k, demos in enumerate(dataset.values()):
            assert len(demos) - sum(1 for p, _ in held if p == k) >= 2
    assert len(trials) == min(selection.MAX_TRIALS, 6 * len(selection.PERCENTS) * 3)
    # every (percentage, modalities) combination is used, each demo at several of them
    assert {(t.percent, t.modalities) for t in trials} == {
        (float(p), m) for p in selection.PERCENTS for m in (("hand",), ("head",), ("hand", "head"))
    }
    reordered = dict(reversed(list(dataset.items())))
    again = selection.plan_trials(reordered, LAYOUT)
    back = list(reordered)
    key = [(names[t.primitive], t.demo, t.fold, t.percent, t.modalities) for t in trials]
    assert key == [(back[t.primitive], t.demo, t.fold, t.percent, t.modalities) for t in again]


@pytest.mark.parametrize("inverted", [False, True])
@pytest.mark.parametrize("one_at_a_time", [False, True])
@pytest.mark.parametrize("shrinkage", [None, 0.3])
def test_the_batched_leave_one_out_score_equals_the_engine_likelihood(
    monkeypatch, shrinkage, one_at_a_time, inverted
) -> None:
    """:func:`promp.selection.loo_score` (every trial of a modality set at once, padded,
    whitened, every primitive at every node) against the engine's own Eq. 6
    (:meth:`promp.evidence.Evidence.log_likelihoods` at each noise level) on a model whose
    true primitive is the downdated one, with the same nodes and quadrature weights, and those
    weights against :func:`promp.evidence.speed.quadrature_weights` over
    :meth:`AlphaPrior.span`. Both ways of
    factorising the bordered matrices: as one stack, and one at a time (many weights); the
    other primitives' precisions downdated by Sherman-Morrison, or (``inverted``, the path of
    an update that cancels) each inverted anew."""
    import dataclasses as dc
    import math

    from promp.data import sample_period_of
    from promp.evidence import Evidence
    from promp.evidence.speed import AlphaPrior, quadrature_weights
    from promp.fitting import fit_parts
    from promp.observation import Observation
    from promp.recognition import label_noise
    from promp.timing import n_observed_for

    monkeypatch.setattr(batches, "LOO_ROWS", 10_000)  # every sample: the engine's input
    monkeypatch.setattr(loo, "_LOOP_WEIGHTS", 1 if one_at_a_time else 10_000)
    monkeypatch.setattr(loo, "_LEAST_DENOMINATOR", 2.0 if inverted else 1e-6)  # (it is <= 1)
    dataset = make_dataset(seed=7, n_demos=5)
    dt = sample_period_of([d for demos in dataset.values() for d in demos])
    settings = Settings(n_basis=6, width=1.0, noise_scale=1.0, shrinkage=shrinkage)
    fitted = fit_parts(dataset, LAYOUT, settings, dt, alpha_models=False)
    model, parts = fitted
    trials = selection.plan_trials(dataset, LAYOUT, max_trials=12)
    laid_out = batches.make_batches(dataset, LAYOUT, trials, dt, settings.s_bar)
    scales = (1.0, 2.0)
    losses = selection.loo_score(fitted, laid_out, len(trials), scales, None)
    names = list(dataset)
    checked = 0
    for batch in laid_out:
        for row, i in enumerate(batch.index):
            trial = trials[i]
            demo = dataset[names[trial.primitive]][trial.demo]
            n_o = n_observed_for(trial.percent, demo.n_samples)
            obs = Observation.from_demo(model, demo, n_o, trial.modalities)
            # every primitive without the demonstration, as Primitives of the engine
            k, j = trial.primitive, trial.demo
            prims = list(model.primitives)
            for kk, sigma in enumerate(_covariances_without(model, parts, k, j)):
                prim, part = model.primitives[kk], parts[kk]
                floor = 1e-9 * float(np.linalg.eigvalsh(sigma).min())
                vals, vecs = np.linalg.eigh(sigma - floor * np.eye(sigma.shape[0]))
                changes = {
                    "cov_diag": np.full_like(prim.cov_diag, floor),
                    "cov_factor": vecs * np.sqrt(np.maximum(vals, 0.0)),
                }
                if kk == k:
                    e, h, n = part.residuals[j], part.leverage[j], part.residuals.shape[0]
                    changes["mean"] = prim.mean - e / (n * (1.0 - h))
                    changes["alpha_slope"] = (
                        prim.alpha_slope
                        - part.slope_weight * part.centred_log_alphas[j] / (1.0 - h) * e
                    )
                prims[kk] = dc.replace(prim, **changes)
            reference = dc.replace(model, primitives=tuple(prims))
            nodes = batch.log_alphas[row]
            for level, scale in enumerate(scales):
                factors = np.full((1, model.n_dims), scale**2)
                evidence = np.array([
                    np.logaddexp.reduce(
                        Evidence(reference, obs).log_likelihoods(p, np.exp(nodes), factors)[0]
                        + batch.log_weights[row, kk]
                    )
                    for kk, p in enumerate(reference.primitives)
                ])  # fmt: skip
                p_all = np.exp(evidence - np.logaddexp.reduce(evidence))
                eps = label_noise(model)
                expected = -math.log((1 - eps) * p_all[k] + eps / len(p_all))
                assert losses[level, i] == pytest.approx(expected, rel=1e-6, abs=1e-8)
            # the quadrature weights of the held-out primitive's prior (without j)
            own = np.delete(model.primitives[k].alphas, j)
            prior = AlphaPrior.from_alphas(own, settings.s_bar)
            bound = math.log(settings.s_bar / (obs.elapsed[-1] / dt + 1.0))
            assert nodes[0] <= prior.span(bound)[0] + 1e-12 and nodes[-1] <= bound + 1e-12
            weights = quadrature_weights(nodes, prior.logpdf(nodes), prior.logcdf(bound))
            assert np.allclose(batch.log_weights[row, k], weights, rtol=1e-9, atol=1e-9)
            checked += 1
    assert checked == len(trials) == 12


def _covariances_without(model, parts, k: int, j: int) -> list[np.ndarray]:
    """Every primitive's Sigma_w once demonstration ``j`` of primitive ``k`` is left out:
    its scatter, and the pooled one, lose ``e e^T / (1 - h)``; with a fixed shrinkage only its
    own primitive's sample part changes (``(1 - lambda) / dof``, one degree of freedom less)."""
    e, h = parts[k].residuals[j], parts[k].leverage[j]
    drop = np.outer(e, e) / (1.0 - h)
    prior = parts[0].prior
    out = []
    if prior is None:
        for kk, (part, prim) in enumerate(zip(parts, model.primitives, strict=True)):
            if kk != k:
                out.append(prim.cov)
                continue
            scatter = part.residuals.T @ part.residuals
            _, b = part.weights_of(part.residuals.shape[0], part.dof)
            _, b_loo = part.weights_of(part.residuals.shape[0] - 1, part.dof - 1)
            out.append(prim.cov - b * scatter + b_loo * (scatter - drop))
        return out
    sigma0 = (
        np.diag(prior.target_part)
        + prior.keep[:, None] * ((prior.scatter - drop) / (prior.dof - 1.0)) * prior.keep[None, :]
    )
    for kk, part in enumerate(parts):
        n, dof, scatter = part.residuals.shape[0], part.dof, part.residuals.T @ part.residuals
        if kk == k:
            n, dof, scatter = n - 1, dof - 1, scatter - drop
        a, b = part.weights_of(n, dof)
        out.append(a * sigma0 + b * scatter)
    return out


def test_the_parts_of_a_fit_give_its_covariances_and_downdate_like_a_refit() -> None:
    """``a Sigma_0 + b E^T E`` is each primitive's Sigma_w, and the pooled scatter without a
    demonstration is that of the residual rows refitted without it."""
    from promp.data import sample_period_of
    from promp.fitting import _moments, fit_parts

    dataset = make_dataset(seed=8, n_demos=5)
    settings = Settings(n_basis=5, width=1.0, noise_scale=1.0)
    dt = sample_period_of([d for demos in dataset.values() for d in demos])
    model, parts = fit_parts(dataset, LAYOUT, settings, dt, alpha_models=False)
    for part, prim in zip(parts, model.primitives, strict=True):
        a, b = part.weights_of(part.residuals.shape[0], part.dof)
        prior = part.prior
        sigma0 = (
            np.diag(prior.target_part)
            + prior.keep[:, None] * (prior.scatter / prior.dof) * prior.keep[None, :]
        )
        expected = a * sigma0 + b * part.residuals.T @ part.residuals
        assert np.allclose(prim.cov, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())
    k, j = 1, 2
    demos = dataset["right"]
    others = [d for i, d in enumerate(demos) if i != j]
    refit = _moments(others, np.delete(parts[k].weights, j, axis=0), settings, dt)
    rows = np.concatenate([parts[0].residuals, refit.residuals])
    e, h = parts[k].residuals[j], parts[k].leverage[j]
    assert np.allclose(parts[0].prior.scatter - np.outer(e, e) / (1.0 - h), rows.T @ rows,
                       rtol=1e-8, atol=1e-14)  # fmt: skip


def test_a_refit_keeps_the_previous_choice_while_it_beats_the_runner_up(monkeypatch) -> None:
    """One demonstration added: the previous choice and the previous runner-up are scored on
    the new trials, and the choice kept while it still wins; a runner-up that now wins, ten
    refits kept in a row, or a choice off the grid run the search again."""
    from robots.icub.layout import STUDIO_LAYOUT
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=0, n_demos=8)  # the studio's experiment, small
    first = next(iter(dataset))
    fewer = {name: demos[:-1] if name == first else demos for name, demos in dataset.items()}
    before = fit(fewer, STUDIO_LAYOUT).report["settings"]
    assert before["rule"] == selection.LOO_RULE and before["runner_up"] != before["chosen"]
    assert round(before["runner_up_log_loss"], 9) >= round(before["log_loss"], 9)
    calls: list = []
    real = candidates.fit_parts

    def counting(*args, **kwargs):
        calls.append(args[2])
        return real(*args, **kwargs)

    monkeypatch.setattr(candidates, "fit_parts", counting)
    kept = fit(dataset, STUDIO_LAYOUT, previous=before).report["settings"]
    assert kept["rule"] == selection.KEPT_RULE and kept["kept"] == 1
    assert kept["chosen"] == before["chosen"] and kept["runner_up"] == before["runner_up"]
    assert round(kept["log_loss"], 9) <= round(kept["runner_up_log_loss"], 9)
    assert len(calls) <= 2
    # the runner-up as the choice: it loses the paired comparison, so the search runs again
    swapped = {**before, "chosen": before["runner_up"], "runner_up": before["chosen"]}
    off_grid = {**before, "chosen": {"n_basis": 9, "width": 1.0, "noise_scale": 1.0}}
    for stale in (swapped, {**before, "kept": selection.KEEP_LIMIT}, off_grid):
        calls.clear()
        again = fit(dataset, STUDIO_LAYOUT, previous=stale).report["settings"]
        assert again["rule"] == selection.LOO_RULE, stale
        assert len(calls) >= 3  # searched


def test_the_priors_without_each_demonstration_match_the_speed_prior() -> None:
    """:func:`promp.selection.batches.priors_without_each` (every demonstration left out at
    once) against :meth:`AlphaPrior.from_alphas` of the others, a far-out speed among them."""
    from promp.evidence.speed import AlphaPrior

    rng = np.random.default_rng(0)
    for n in (3, 4, 10, 40):
        alphas = np.exp(rng.normal(0.0, 0.3, n))
        alphas[0] *= 30.0  # winsorized away, except where it is left out
        table = batches.priors_without_each(alphas, 100.0)
        for j in range(n):
            prior = AlphaPrior.from_alphas(np.delete(alphas, j), 100.0)
            expected = [prior.locs[0], prior.scales[0], prior.dofs[0]]
            assert np.allclose(table[:, j], expected, rtol=1e-12, atol=1e-14)


def test_the_speed_prior_is_the_predictive_of_the_winsorized_sample() -> None:
    """:func:`promp.evidence.speed.speed_prior` (the one both paths call) against its definition
    written out: the far-out speed brought to the nearest ordinary one, the sample's mean,
    its standard deviation inflated by sqrt(1 + 1/n), n - 1 degrees of freedom; the floor of
    one sample's worth of duration when the sample hardly spreads."""
    from promp.evidence.speed import speed_prior

    logs = np.log([0.9, 1.0, 1.1, 1.05, 30.0])
    loc, scale, dof = speed_prior(logs, 100.0)
    kept = np.minimum(logs, np.log(1.1))  # 30 is far out: brought to the largest ordinary one
    assert_allclose(loc, kept.mean(), rtol=1e-15)
    assert_allclose(scale, kept.std(ddof=1) * np.sqrt(1.0 + 1.0 / 5), rtol=1e-15)
    assert dof == 4.0
    loc, scale, dof = speed_prior(np.log([2.0, 2.0, 2.0]), 100.0)
    assert_allclose([loc, scale, dof], [np.log(2.0), 2.0 / 100.0, 2.0], rtol=1e-15)
    rows = np.stack([logs, logs[::-1], logs + 1.0])  # three priors at once, each its own row
    for row, (l_i, s_i, d_i) in zip(rows, zip(*speed_prior(rows, 100.0), strict=True),
                                     strict=True):  # fmt: skip
        assert_allclose([l_i, s_i, d_i], speed_prior(row, 100.0), rtol=1e-15)


def test_the_batched_logsumexp_is_the_single_one_row_by_row() -> None:
    """One logsumexp: :func:`promp.evidence.speed.logsumexp` is :func:`logsumexp_rows` of one
    row; rows with -inf entries, all -inf, +inf, and an empty last axis; against scipy."""
    from scipy.special import logsumexp as reference

    from promp.evidence.speed import logsumexp, logsumexp_rows

    rng = np.random.default_rng(1)
    values = rng.normal(0.0, 300.0, (6, 4, 9))
    values[0, 0, :3] = -np.inf
    values[1, 2] = -np.inf
    values[2, 1, 4] = np.inf
    rows = logsumexp_rows(values)
    assert rows.shape == (6, 4)
    with np.errstate(divide="ignore", invalid="ignore"):
        assert_allclose(rows, reference(values, axis=-1), rtol=1e-14)
    for index in np.ndindex(rows.shape):
        assert_allclose(rows[index], logsumexp(values[index]), rtol=1e-15)
    assert rows[1, 2] == -np.inf and rows[2, 1] == np.inf
    assert_allclose(logsumexp_rows(np.empty((3, 0))), np.full(3, -np.inf))
    assert logsumexp(np.empty(0)) == -np.inf


def test_the_batched_student_t_and_quadrature_are_recognitions() -> None:
    """One Student-t, one quadrature: the leave-one-out scorer's grid (every trial and
    primitive at once, :func:`promp.selection.batches._quadrature_grid`) against
    recognition's prior of each pair alone (:meth:`AlphaPrior.logpdf`, ``logcdf``, ``span``,
    :func:`quadrature_weights`), a trial whose bound lies below every prior among them; and
    :func:`t_logpdf` against scipy's Student-t."""
    from scipy import stats

    from promp.evidence.speed import AlphaPrior, quadrature_weights, t_logpdf
    from promp.selection.batches import LOO_NODES, _quadrature_grid

    rng = np.random.default_rng(2)
    n_trials, n_prims = 5, 3
    locs = rng.normal(0.0, 0.5, (n_trials, n_prims))
    scales = rng.uniform(0.05, 0.4, (n_trials, n_prims))
    dofs = rng.integers(1, 12, (n_trials, n_prims)).astype(float)
    bounds = locs.max(axis=1) + rng.uniform(-0.2, 1.0, n_trials)
    bounds[3] = locs[3].min() - 3.0  # every plausible speed of trial 3 ends too early
    nodes, log_w = _quadrature_grid(locs, scales, dofs, bounds)
    assert nodes.shape == (n_trials, LOO_NODES) and log_w.shape == (n_trials, n_prims, LOO_NODES)
    for t in range(n_trials):
        assert nodes[t, -1] <= bounds[t] + 1e-12
        spans = []
        for k in range(n_prims):
            prior = AlphaPrior((locs[t, k],), (scales[t, k],), (dofs[t, k],), (1.0,))
            single = quadrature_weights(nodes[t], prior.logpdf(nodes[t]), prior.logcdf(bounds[t]))
            assert_allclose(log_w[t, k], single, rtol=1e-13, atol=1e-13)
            spans.append(prior.span(bounds[t]))
        if t != 3:  # the grid spans every primitive's range, as recognition's quadrature does
            assert_allclose(nodes[t, [0, -1]], [min(s[0] for s in spans),
                                                max(s[1] for s in spans)], rtol=1e-14)  # fmt: skip
    z = rng.normal(0.0, 3.0, (4, 7))
    dof = rng.uniform(0.5, 30.0, (4, 1))
    assert_allclose(t_logpdf(z, dof), stats.t.logpdf(z, dof), rtol=1e-12)
    for i in range(4):
        assert_allclose(t_logpdf(z[i], float(dof[i, 0])), t_logpdf(z, dof)[i], rtol=1e-15)
