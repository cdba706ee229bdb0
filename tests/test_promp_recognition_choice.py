"""The recognition variant chosen by the data (promp/selection/recognition_choice.py): its
leave-one-out scorer against the ProMP's and the engine's, the trial's own demonstration out of
its mixture, and the choice on data made for each variant."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.data import Demonstration
from promp.evidence import Evidence, mixture
from promp.inference import Observation
from promp.learn import choose, fit
from promp.model import Settings
from promp.selection import recognition_choice as rc
from promp.selection.candidates import Candidates
from promp.selection.region import data_region
from promp.selection.trials import LOO_MAX_TRIALS, plan_trials
from promp.timing import duration_from_alpha
from tests.synthetic import COLUMNS, LAYOUT, make_dataset, make_demo, smooth_profile

DT = 0.02
GIVEN = Settings(n_basis=6, width=1.0, noise_scale=1.5, duration_temperature=1.0)


def _scorer(dataset, n_basis=6, width=1.0):
    trials = plan_trials(dataset, LAYOUT, max_trials=LOO_MAX_TRIALS)
    inner = Settings(n_basis=n_basis, width=width, noise_scale=1.0)
    return Candidates(dataset, LAYOUT, inner, DT, trials, data_region(dataset, LAYOUT))(
        n_basis, width
    )


def _families(seed: int = 0, n: int = 8) -> dict:
    """"split" reaches one of two goals far apart, "middle" the goal between them: one
    Gaussian per primitive puts split's mass on middle's goal."""
    rng = np.random.default_rng(seed)
    a = np.array([0.3, -0.3, 0.1, 0.0, 0.3, -0.6])
    b = np.array([0.3, 0.3, 0.1, 0.0, 0.3, 0.6])
    split = [make_demo(rng, a if i % 2 else b, duration=2.0 * rng.uniform(0.8, 1.2),
                       name=f"split{i}") for i in range(n)]  # fmt: skip
    middle = [make_demo(rng, 0.5 * (a + b), duration=2.0 * rng.uniform(0.8, 1.2),
                        name=f"middle{i}") for i in range(n)]  # fmt: skip
    return {"split": split, "middle": middle}


@pytest.fixture(scope="module")
def scorer():
    return _scorer(make_dataset(seed=1, n_demos=6))


def test_at_bandwidth_one_the_mixture_scorer_is_the_promps(scorer) -> None:
    promp = scorer((1.5,))[0]
    got = rc.mixture_losses(scorer, 1.5, [1.0])[1.0]
    assert np.isfinite(promp).all()
    assert_allclose(got, promp, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("h", [0.4, 0.8])
@pytest.mark.parametrize(
    ("n_demos", "n_basis", "observed"),
    [(6, 6, ["hand", "head"]), (12, 3, ["head"])],
    ids=["fewer-components-than-weights", "more"],
)
def test_the_scorers_component_likelihoods_are_the_engines(h, n_demos, n_basis, observed):
    """The batch form of the scorer (one primitive, its whole fit, no trial left out) gives
    the engine's :func:`promp.evidence.mixture.log_likelihoods` less the terms every
    primitive shares."""
    settings = dataclasses.replace(GIVEN, n_basis=n_basis)
    model = fit(make_dataset(seed=1, n_demos=n_demos), LAYOUT, settings)
    demo = make_demo(np.random.default_rng(7), np.array([0.2, -0.2, 0.1, 0.0, 0.3, -0.6]))
    obs = Observation.from_demo(model, demo, 17, observed)
    evidence = Evidence(model, obs)
    prim, dims, m = model.primitives[0], evidence.dims, model.basis.n_basis
    alphas = prim.alphas[:4]
    durations = duration_from_alpha(alphas, model.sample_period, model.settings.s_bar)
    sums = evidence._sums(prim, alphas, durations)
    noise = prim.noise_var[dims]
    engine = mixture.log_likelihoods(sums, prim, dims, noise, h)  # (A, J)
    from promp.evidence.weight_space import observed_precision

    padded, logdet_sigma = observed_precision(prim, dims)
    p = dims.shape[0] * m
    cols = (dims[:, None] * m + np.arange(m)).reshape(-1)
    got = rc._component_log_likelihoods(
        padded[None, :p, :p], np.array([logdet_sigma]), sums.gram[:, sums.group][None],
        sums.proj[None], sums.rr[None], prim.residuals[:, cols].reshape(1, -1, dims.shape[0], m),
        1.0 / noise, (h,),
    )[0, 0]  # (J, A)  # fmt: skip
    shared = -0.5 * (float((sums.n * np.log(noise) + sums.logdet_k).sum())
                     + sums.n * dims.shape[0] * math.log(2 * math.pi))  # fmt: skip
    assert_allclose(got.T + shared, engine, rtol=1e-10, atol=1e-8)


def test_a_trials_own_demonstration_is_out_of_its_mixture(scorer) -> None:
    """A trial's own primitive's components are its other demonstrations, placed by the
    regression without its demonstration (their weights less the held-out mean): moving one
    demonstration's weights far away changes the loss of the trials of its primitive that
    hold out another one, and not of those that hold it out."""
    before = rc.mixture_losses(scorer, 1.5, [0.5])[0.5]
    kept = scorer.parts
    moved = np.array(kept[0].weights)
    moved[2] += 5.0 * np.abs(kept[0].residuals).max()
    try:  # (the scorer's terms of the trials, computed above, keep the whole fit's)
        scorer.parts = [dataclasses.replace(kept[0], weights=moved), *kept[1:]]
        after = rc.mixture_losses(scorer, 1.5, [0.5])[0.5]
    finally:
        scorer.parts = kept
    own, siblings = (np.zeros(scorer.n_trials, dtype=bool) for _ in range(2))
    for batch in scorer.batches:
        demos = np.array(batch.demos)
        own[batch.index] = (batch.truth == 0) & (demos == 2)
        siblings[batch.index] = (batch.truth == 0) & (demos != 2)
    assert own.any() and siblings.any()
    assert_allclose(after[own], before[own], rtol=1e-12)
    assert np.abs(after[siblings] - before[siblings]).max() > 1e-3


def test_two_families_in_one_primitive_choose_the_mixture() -> None:
    dataset = _families()
    chosen = choose(dataset, LAYOUT, dataclasses.replace(GIVEN, recognition=None),
                    sample_period=DT)  # fmt: skip
    assert chosen.recognition.startswith("mixture:")
    model = fit(dataset, LAYOUT, dataclasses.replace(GIVEN, recognition=None))
    why = model.report["settings"]["recognition"]
    assert why["value"] == model.settings.recognition == chosen.recognition
    assert why["log_loss"][why["value"]] < why["log_loss"]["promp"]
    assert why["rule"] == rc.RECOGNITION_RULE


def _gaussian(seed: int, spread: float, noise: float, n: int = 8) -> dict:
    """Each primitive one Gaussian over the weights (the amplitudes vary, the profile does
    not): the ProMP is the true model."""
    rng = np.random.default_rng(seed)
    times = np.arange(101) / 50.0
    targets = {"left": np.array([0.2, -0.2, 0.1, 0.0, 0.3, -0.6]),
               "right": np.array([0.2, 0.2, 0.1, 0.0, 0.3, 0.6])}  # fmt: skip
    return {name: [Demonstration(times, smooth_profile(times / times[-1],
                                                       t * (1 + spread * rng.standard_normal(6)),
                                                       0.5)
                                 + noise * rng.standard_normal((101, 6)), COLUMNS,
                                 name=f"{name}{i}") for i in range(n)]
            for name, t in targets.items()}  # fmt: skip


@pytest.mark.parametrize(
    "gains, chosen",
    [
        ({0.85: 0.0, 0.7: 0.0, 0.5: 0.0}, "promp"),  # a tie: the simplest
        ({0.85: -0.02, 0.7: -0.05, 0.5: -0.06}, "mixture:0.5"),  # clearly lower each time
        ({0.85: -0.05, 0.7: -0.051, 0.5: -0.053}, "mixture:0.85"),  # within one error of it
        ({0.85: +0.1, 0.7: +0.2, 0.5: -0.002}, "promp"),  # lower by less than the noise
    ],
)
def test_the_simplest_variant_within_one_standard_error_is_chosen(scorer, monkeypatch, gains,
                                                                  chosen) -> None:  # fmt: skip
    """The one-standard-error rule on the trials' paired losses: each mixture's loss is the
    ProMP's plus its ``gain`` and its own noise of mean 0 and standard deviation 0.05 (the
    error of a mean difference with the ProMP 0.05 / sqrt(n), 0.0037 here; between two
    mixtures sqrt(2) times that)."""
    promp = scorer((1.5,))[0]
    n = promp.shape[0]
    rng = np.random.default_rng(0)

    def noise():
        z = rng.standard_normal(n)
        return 0.05 * (z - z.mean()) / z.std(ddof=1)

    fake = {h: promp + g + (noise() if g else 0.0) for h, g in gains.items()}
    monkeypatch.setattr(rc, "mixture_losses", lambda *_: fake)
    name, why = rc.choose_recognition(scorer, 1.5)
    assert name == chosen == why["value"]
    assert why["log_loss"]["promp"] == pytest.approx(promp.mean(), abs=1e-6)


def test_a_tie_is_the_promp() -> None:
    """Every trial recognised with certainty whatever the variant: the simplest."""
    model = fit(_gaussian(0, 0.05, 1e-3), LAYOUT, dataclasses.replace(GIVEN, recognition=None))
    why = model.report["settings"]["recognition"]
    assert len({round(v, 6) for v in why["log_loss"].values()}) == 1
    assert model.settings.recognition == "promp"


def test_a_given_variant_is_kept_and_nothing_is_scored() -> None:
    forced = dataclasses.replace(GIVEN, recognition="mixture:0.7")
    model = fit(_families(), LAYOUT, forced)
    assert model.settings.recognition == "mixture:0.7"
    assert "recognition" not in model.report.get("settings", {})


def test_nothing_held_out_is_the_promp() -> None:
    dataset = {k: v[:2] for k, v in make_dataset(seed=2, n_demos=4).items()}
    model = fit(dataset, LAYOUT, dataclasses.replace(GIVEN, recognition=None))
    assert model.settings.recognition == "promp"


@pytest.mark.parametrize("h", [0.5, 0.85])
def test_the_scorers_speed_kernels_are_the_engines(scorer, h) -> None:
    """Each trial's components' quadrature weights at its nodes, in batch form, are
    :func:`promp.evidence.mixture.speed_kernels` of the trial's prior of that primitive."""
    from promp.evidence.speed import AlphaPrior
    from promp.quality import winsorized

    batch = scorer.batches[0]
    for k, prim in enumerate(scorer.model.primitives):
        got = rc._kernels(batch, k, winsorized(np.log(prim.alphas)), h)  # (T, J, A)
        for t in range(0, batch.truth.shape[0], 7):
            loc, scale, dof = batch.priors[:, t, k]
            prior = AlphaPrior((float(loc),), (float(scale),), (float(dof),), (1.0,))
            want = mixture.speed_kernels(prim, prior, batch.log_alphas[t],
                                         float(batch.bounds[t]), h)  # fmt: skip
            assert_allclose(got[t], want, rtol=1e-12, atol=1e-12)


def test_the_speeds_of_a_trials_components_are_winsorized_without_its_demonstration(
    scorer,
) -> None:
    """With one demonstration far slower than the others, the trial that holds out the
    slowest ordinary one scores its siblings' speeds as the engine does for the refit without
    it: the far-out take is clipped to the next slowest, not to the held-out one's speed (over
    every demonstration, the trial under test would have set its own score's clipping)."""
    from promp.evidence.speed import AlphaPrior

    batch, prim, h = scorer.batches[0], scorer.model.primitives[0], 0.5
    alphas = np.array(prim.alphas, dtype=float)
    demos = np.array(batch.demos)
    mine = batch.truth == 0
    held = demos[mine]
    slowest = int(held[np.argmin(alphas[held])])  # a held-out demonstration, the slowest
    far = int(np.setdiff1d(np.arange(alphas.size), [slowest])[0])
    alphas[far] = alphas[slowest] / 20.0  # 20x slower than the slowest: far out
    own = rc._own_speeds(np.log(alphas), mine, demos)
    got = rc._kernels(batch, 0, own, h)
    checked = 0
    for t in np.flatnonzero(mine):
        j = int(demos[t])
        loc, scale, dof = batch.priors[:, t, 0]
        prior = AlphaPrior((float(loc),), (float(scale),), (float(dof),), (1.0,))
        refit = dataclasses.replace(
            prim, alphas=np.delete(alphas, j), residuals=np.delete(prim.residuals, j, axis=0)
        )
        want = mixture.speed_kernels(refit, prior, batch.log_alphas[t], float(batch.bounds[t]), h)
        assert_allclose(np.delete(got[t], j, axis=0), want, rtol=1e-12, atol=1e-12)
        checked += j == slowest
    assert checked  # the trial whose clipping differs is among them
    assert not np.allclose(own[mine & (demos == slowest), far], np.log(alphas[slowest]))


def test_a_refit_that_keeps_the_settings_keeps_the_variant_while_it_beats_the_promp(
    monkeypatch,
) -> None:
    """One demonstration added and the settings kept (:data:`promp.selection.KEPT_RULE`): a
    kept ProMP scores no mixture, a kept mixture only its own bandwidth against the ProMP, by
    the same rule; a variant off the grid, or settings searched again, score every one."""
    from promp.selection import KEEP_LIMIT, KEPT_RULE
    from robots.icub.layout import STUDIO_LAYOUT
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=0, n_demos=8)
    first = next(iter(dataset))
    fewer = {name: demos[:-1] if name == first else demos for name, demos in dataset.items()}
    before = fit(fewer, STUDIO_LAYOUT).report["settings"]
    scored: list = []
    real = rc.mixture_losses

    def counting(scorer, noise_scale, bandwidths):
        scored.append(tuple(bandwidths))
        return real(scorer, noise_scale, bandwidths)

    monkeypatch.setattr(rc, "mixture_losses", counting)

    def refit(previous_variant, **extra):
        scored.clear()
        previous = {**before, **extra, "recognition": {**before["recognition"],
                                                       "value": previous_variant}}  # fmt: skip
        return fit(dataset, STUDIO_LAYOUT, previous=previous).report["settings"]

    kept = refit("promp")
    assert kept["rule"] == KEPT_RULE and scored == [()]
    assert kept["recognition"]["rule"] == rc.KEPT_RECOGNITION_RULE
    assert kept["recognition"]["value"] == "promp" and set(kept["recognition"]["log_loss"]) == {
        "promp"
    }
    kept = refit("mixture:0.7")
    assert scored == [(0.7,)]
    assert set(kept["recognition"]["log_loss"]) == {"promp", "mixture:0.7"}
    losses = kept["recognition"]["log_loss"]
    assert kept["recognition"]["value"] in losses  # the rule between the two
    if losses["mixture:0.7"] > losses["promp"]:
        assert kept["recognition"]["value"] == "promp"
    for stale, extra in (("mixture:0.3", {}), ("mixture:0.7", {"kept": KEEP_LIMIT})):
        again = refit(stale, **extra)
        assert scored == [rc.BANDWIDTHS], (stale, extra)
        assert again["recognition"]["rule"] == rc.RECOGNITION_RULE
