"""The settings every fit chooses from its training demonstrations (promp.selection)."""

from __future__ import annotations

import numpy as np
import pytest

from promp import selection
from promp.data import Demonstration, Layout, Modality
from promp.io import model_from_json, model_to_json
from promp.learn import fit
from promp.model import FALLBACK, Settings
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


def test_the_choice_is_the_lowest_inner_log_loss_and_is_recorded() -> None:
    model = fit(make_dataset(seed=1, n_demos=5), LAYOUT)
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
    assert set(report["chosen"]) == {"width"} and report["given"] == {"n_basis": 5,
                                                                      "noise_scale": 2.0}
    assert {c["n_basis"] for c in report["candidates"]} == {5}
    assert all(c["noise_scale"] == [2.0] for c in report["candidates"])


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
