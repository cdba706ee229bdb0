"""The early-classification baselines (promp.baselines, promp.evaluate.baselines): open-end DTW
and the prefix phase search on hand-made sequences with known answers, their nearest-neighbour
probabilities, the relative form and its scaling, the engines, and bad input refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.baselines.dtw import OpenEndDTW, open_end_dtw
from promp.baselines.nearest import nearest_primitive
from promp.baselines.prefix import FRACTIONS, prefix_search
from promp.baselines.relative import column_spread, relative_to_start
from promp.data import Demonstration, Layout, Modality
from promp.evaluate.baselines import DTWBaseline, PrefixBaseline, scale_groups
from promp.evaluate.registry import method_factories
from promp.evaluate.sweep import run_sweep
from tests.synthetic import COLUMNS, make_dataset
from tests.synthetic import LAYOUT as FULL


def _dtw_brute(query: np.ndarray, reference: np.ndarray) -> tuple[float, int]:
    """Open-end DTW by the textbook double loop: (min of the last row, where)."""
    n, m = len(query), len(reference)
    cost = np.full((n, m), np.inf)
    for i in range(n):
        for j in range(m):
            local = float(np.linalg.norm(query[i] - reference[j]))
            if i == 0 and j == 0:
                cost[i, j] = local
                continue
            before = [cost[i - 1, j - 1] if i and j else np.inf,
                      cost[i - 1, j] if i else np.inf, cost[i, j - 1] if j else np.inf]  # fmt: skip
            cost[i, j] = local + min(before)
    return float(cost[-1].min()), int(cost[-1].argmin())


def test_open_end_dtw_matches_the_textbook_recursion() -> None:
    rng = np.random.default_rng(3)
    for _ in range(30):
        query = rng.normal(size=(int(rng.integers(1, 10)), 2))
        references = [rng.normal(size=(int(rng.integers(1, 13)), 2)) for _ in range(4)]
        distances, ends = open_end_dtw(query, references)
        for k, reference in enumerate(references):
            expected, end = _dtw_brute(query, reference)
            assert_allclose(distances[k], expected, rtol=1e-12, atol=1e-12)
            assert ends[k] == end


def test_open_end_dtw_matches_a_slower_beginning_mid_way() -> None:
    """The observation is the first half of the reference played twice as slowly (every
    sample twice): the alignment costs nothing and ends mid-way, at the half's last sample,
    while a closed-end alignment would have to pay for the second half."""
    path = np.column_stack([np.linspace(0.0, 1.0, 21), np.linspace(0.0, 1.0, 21) ** 2])
    observed = np.repeat(path[:11], 2, axis=0)
    distances, ends = open_end_dtw(observed, [path, path[::-1] * 0.5])
    assert_allclose(distances[0], 0.0, atol=1e-12)
    assert ends[0] == 10
    assert distances[1] > 1.0


def test_a_growing_observation_costs_a_row_per_sample_and_answers_every_length() -> None:
    rng = np.random.default_rng(4)
    references = [rng.normal(size=(m, 3)) for m in (5, 17, 9)]
    query = rng.normal(size=(12, 3))
    dtw = OpenEndDTW(references).extend(query[:4]).extend(query[4:4]).extend(query[4:])
    assert dtw.n_observed == 12
    for n in (1, 4, 12):
        assert_allclose(dtw.distances[n - 1], open_end_dtw(query[:n], references)[0])
    assert_allclose(dtw.ends, open_end_dtw(query, references)[1])


def test_the_phase_search_matches_resampling_each_prefix_by_np_interp() -> None:
    """The closed form (a Gram matrix, no resampled array) against the plain recipe: each
    prefix [0, f (m - 1)] resampled column by column with np.interp."""
    rng = np.random.default_rng(5)
    for _ in range(15):
        query = rng.normal(size=(int(rng.integers(2, 30)), 3)).cumsum(axis=0)
        references = [rng.normal(size=(int(rng.integers(2, 60)), 3)).cumsum(axis=0)
                      for _ in range(4)]  # fmt: skip
        distances, best = prefix_search(query, references)
        for k, reference in enumerate(references):
            m = reference.shape[0]
            plain = []
            for f in FRACTIONS:
                at = np.linspace(0.0, f * (m - 1), query.shape[0])
                resampled = np.column_stack(
                    [np.interp(at, np.arange(m), reference[:, j]) for j in range(3)]
                )
                plain.append(np.linalg.norm(resampled - query))
            assert_allclose(distances[k], min(plain), rtol=1e-9, atol=1e-9)
            assert plain[int(np.argmin(plain))] == pytest.approx(
                plain[list(FRACTIONS).index(best[k])], rel=1e-9, abs=1e-9
            )


def test_the_phase_search_finds_a_slower_copy_of_a_beginning() -> None:
    """The observation is the first 40 % of a reference, played 2.5 times slower: the prefix
    search finds f = 0.4 and a near-zero distance; another reference is far."""
    t = np.linspace(0.0, 1.0, 101)
    reference = np.column_stack([np.sin(3 * t), t**2])
    slow = np.linspace(0.0, 0.4, 101)  # 101 samples over the first 40 %
    observed = np.column_stack([np.sin(3 * slow), slow**2])
    other = np.column_stack([t, -t])
    distances, best = prefix_search(observed, [reference, other])
    assert best[0] == pytest.approx(0.4)
    assert distances[0] < 1e-3 < 0.1 < distances[1]
    assert FRACTIONS.size == 50 and FRACTIONS[0] == pytest.approx(0.02) and FRACTIONS[-1] == 1.0


def test_nearest_probabilities_are_a_softmin_relative_to_the_nearest() -> None:
    index, p, per_primitive = nearest_primitive(np.array([3.0, 1.0, 2.0, 4.0]), [0, 1, 1, 2], 3)
    assert index == 1
    assert_allclose(per_primitive, [3.0, 1.0, 4.0])
    expected = np.exp([-3.0, -1.0, -4.0])
    assert_allclose(p, expected / expected.sum())
    # an exact match takes all the mass (shared between exact matches); still finite
    index, p, _ = nearest_primitive(np.array([0.0, 1.0, 0.0]), [0, 1, 2], 3)
    assert index == 0
    assert_allclose(p, [0.5, 0.0, 0.5])
    with pytest.raises(ValueError, match="finite and non-negative"):
        nearest_primitive(np.array([np.nan, 1.0]), [0, 1], 2)
    with pytest.raises(ValueError, match="labels must be in"):
        nearest_primitive(np.array([1.0, 1.0]), [0, 2], 2)


def test_the_relative_form_and_the_spread_that_scales_it() -> None:
    movement = np.array([[1.0, 5.0], [2.0, 5.0], [4.0, 5.0]])
    assert_allclose(relative_to_start(movement), [[0, 0], [1, 0], [3, 0]])
    assert_allclose(column_spread([movement]), [np.std([0, 1, 3]), 1.0])  # still: 1
    wide = np.column_stack([np.arange(5.0), 3 * np.arange(5.0)])
    spread = np.std(np.arange(5.0))
    assert_allclose(column_spread([wide]), [spread, 3 * spread])
    shared = math.sqrt((spread**2 + (3 * spread) ** 2) / 2)
    assert_allclose(column_spread([wide], groups=[0, 0]), [shared, shared])


def test_a_modality_of_one_unit_shares_a_scale_and_mixed_units_do_not() -> None:
    layout = Layout(
        (
            Modality("hand", ("x", "y", "z"), unit="m"),
            Modality("head", ("roll", "pitch", "yaw"), unit="rad", kind="angle"),
            Modality("wrench", ("fx", "fy", "mx"), unit="N|N m"),
            Modality("other", ("a", "b"), unit=""),
        )
    )
    assert scale_groups(layout, "modality") == [0, 0, 0, 3, 3, 3, 6, 7, 8, 9, 10]
    assert scale_groups(layout, "column") == list(range(11))


def _shifted(demo: Demonstration, offset: np.ndarray, name: str = "") -> Demonstration:
    return Demonstration(demo.times, demo.values + offset, demo.columns, name or demo.name)


@pytest.mark.parametrize("baseline", [DTWBaseline, PrefixBaseline])
def test_a_baseline_does_not_see_where_a_movement_starts(baseline) -> None:
    """Every demonstration moved by its own offset (a person standing elsewhere): the same
    answer and probabilities, to round-off."""
    dataset = make_dataset(seed=5, n_demos=5)
    rng = np.random.default_rng(6)
    moved = {name: [_shifted(d, rng.normal(size=len(COLUMNS))) for d in demos]
             for name, demos in dataset.items()}  # fmt: skip
    answers = []
    for data in (dataset, moved):
        engine = baseline(FULL)
        train = {name: demos[1:] for name, demos in data.items()}
        engine.fit(train, 0.02)
        answers.append([engine.infer(demos[0], 30, ["hand", "head"], "ml")
                        for demos in data.values()])  # fmt: skip
    for before, after in zip(*answers, strict=True):
        assert before.index == after.index
        assert_allclose(before.probabilities, after.probabilities, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("baseline", [DTWBaseline, PrefixBaseline])
def test_a_baseline_recognises_only_and_says_so_with_nan(baseline) -> None:
    dataset = make_dataset(seed=7, n_demos=5)
    engine = baseline(FULL)
    engine.fit({name: demos[1:] for name, demos in dataset.items()}, 0.02)
    for k, demos in enumerate(dataset.values()):
        inferred = engine.infer(demos[0], 60, ["hand"], "ml")
        assert inferred.index == k  # far-apart synthetic primitives
        assert inferred.probabilities[k] > 0.5
        assert inferred.probabilities.sum() == pytest.approx(1.0)
        assert math.isnan(inferred.alpha) and math.isnan(inferred.duration)
        assert np.isnan(inferred.posterior_mean).all() and np.isnan(inferred.prior_mean).all()
        # the speed is not theirs: every alpha row the same answer
        again = engine.infer(demos[0], 60, ["hand"], "model")
        assert again.index == inferred.index
        assert_allclose(again.probabilities, inferred.probabilities)


def test_units_do_not_matter_to_a_baseline_observing_two_modalities() -> None:
    """The hand in centimetres instead of metres: each modality is divided by its spread, so
    the answer to hand + head is the same."""
    dataset = make_dataset(seed=8, n_demos=5)
    in_cm = np.array([100.0, 100.0, 100.0, 1.0, 1.0, 1.0])
    scaled = {name: [Demonstration(d.times, d.values * in_cm, d.columns, d.name) for d in demos]
              for name, demos in dataset.items()}  # fmt: skip
    for baseline in (DTWBaseline, PrefixBaseline):
        answers = []
        for data in (dataset, scaled):
            engine = baseline(FULL)
            engine.fit({name: demos[1:] for name, demos in data.items()}, 0.02)
            answers.append([engine.infer(demos[0], 25, ["hand", "head"], "ml").probabilities
                            for demos in data.values()])  # fmt: skip
        assert_allclose(answers[0], answers[1], rtol=1e-9)


def test_bad_input_is_refused_with_the_reason() -> None:
    good = np.zeros((5, 2))
    with pytest.raises(ValueError, match="NaN or infinite"):
        open_end_dtw(np.array([[0.0, np.nan], [1.0, 1.0]]), [good])
    with pytest.raises(ValueError, match="NaN or infinite"):
        prefix_search(np.array([[0.0, 0.0], [1.0, np.inf]]), [good])
    with pytest.raises(ValueError, match="NaN or infinite"):
        open_end_dtw(good, [np.full((3, 2), np.nan)])
    with pytest.raises(ValueError, match="at least 2 are needed"):
        prefix_search(np.zeros((1, 2)), [good])
    with pytest.raises(ValueError, match="at least 2 are needed"):
        relative_to_start(np.zeros((1, 3)))
    with pytest.raises(ValueError, match="columns"):
        open_end_dtw(np.zeros((3, 3)), [good])
    with pytest.raises(ValueError, match="columns"):
        prefix_search(np.zeros((3, 3)), [good])
    with pytest.raises(ValueError, match="shape"):
        open_end_dtw(np.zeros(4), [good])
    with pytest.raises(ValueError, match="at least one reference"):
        prefix_search(good, [])
    with pytest.raises(ValueError, match="fractions"):
        prefix_search(good, [good], fractions=np.array([0.0, 0.5]))
    dataset = make_dataset(seed=9, n_demos=4)
    for baseline in (DTWBaseline, PrefixBaseline):
        engine = baseline(FULL)
        with pytest.raises(ValueError, match="fit the baseline"):
            engine.infer(dataset["left"][0], 10, ["hand"], "ml")
        engine.fit(dataset, 0.02)
        with pytest.raises(ValueError, match="1 sample"):
            engine.infer(dataset["left"][0], 1, ["hand"], "ml")
        with pytest.raises(ValueError, match="unknown modality"):
            engine.infer(dataset["left"][0], 10, ["gaze"], "ml")
    with pytest.raises(ValueError, match="scaling must be one of"):
        DTWBaseline(FULL, scaling="whitened")
    with pytest.raises(ValueError, match="unknown method 'knn'"):
        method_factories(["ours", "knn"], FULL)
    with pytest.raises(ValueError, match="each method once"):
        method_factories(["dtw", "dtw"], FULL)


def test_several_methods_run_on_the_same_trials_in_one_sweep() -> None:
    """ours, dtw and prefix-nn in one sweep: the same held-out demonstrations, percentages
    and settings for each, rows method by method; the baselines' position errors NaN, their
    log-loss finite; the failed one-sample trials are theirs only."""
    dataset = make_dataset(seed=2, n_demos=4)
    methods = method_factories(["dtw", "ours", "prefix-nn"], FULL)
    result = run_sweep(methods, dataset, FULL, [1, 50], ["ml"], [["hand"]], keep_trials=True)
    assert [r["method"] for r in result.rows] == ["dtw"] * 2 + ["ours"] * 2 + ["prefix-nn"] * 2
    tested = {m: sorted((t.primitive, t.demo, t.percent) for t in result.trials if t.method == m)
              for m in methods}  # fmt: skip
    assert tested["dtw"] == tested["ours"] == tested["prefix-nn"] and len(tested["ours"]) == 16
    for row in result.rows:
        assert row["trials"] == 8 and math.isfinite(row["log_loss"])
        assert math.isnan(row["position_error_m"]) == (row["method"] != "ours")
    one_sample = {t.demo for t in result.trials if t.method == "dtw" and t.percent == 1
                  and t.error}  # fmt: skip
    assert one_sample == {d.name for demos in dataset.values() for d in demos if d.n_samples <= 100}
    assert {f["method"] for f in result.failures} <= {"dtw", "prefix-nn"}
