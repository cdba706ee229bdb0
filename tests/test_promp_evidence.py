"""promp.evidence: the evidence of a growing observation, extended by its new samples
(Evidence.extended), gives what promp.evidence.infer gives on the same samples from scratch,
within 1e-9, on the three shared sets (and a faulty copy) at many prefixes; the speed nodes it
keeps; threads extending one evidence."""

from __future__ import annotations

import dataclasses
import math
import threading

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.datasets import RECORD_COLUMNS, guess_layout, load_records_dataset
from promp.evidence import Evidence
from promp.evidence.pipeline import infer, recognise
from promp.evidence.speed import N_NODES, N_REFINE, AlphaPrior, anchored_nodes
from promp.evidence.weight_space import equilibrated_precision
from promp.inference import Observation
from promp.learn import fit
from tests.conftest import shared_set
from tests.faults import inject

CLOSE = {"rtol": 0.0, "atol": 1e-9}
LAYOUT = guess_layout(RECORD_COLUMNS[1:])


def same(online, offline, n_samples: int = 0) -> None:
    """The published numbers within 1e-9; the log-likelihoods (up to ~4e4 nats, sums of
    thousands of terms in another order) to 1e-11 of their size per thousand samples summed
    (the round-off of a sum grows with its number of terms: a 22 s still take of 2,200 samples
    differs by 1.04e-11 of 40,219 nats at one speed node with the settings flt chooses)."""
    rtol = 1e-11 * max(1.0, n_samples / 1000.0)
    assert online.recognition.index == offline.recognition.index
    assert_allclose(online.probabilities, offline.probabilities, **CLOSE)
    assert_allclose(online.recognition.log_evidence, offline.recognition.log_evidence,
                    rtol=rtol, atol=1e-9)  # fmt: skip
    for a, b in zip(online.recognition.log_likelihoods, offline.recognition.log_likelihoods,
                    strict=True):  # fmt: skip
        assert_allclose(a, b, rtol=rtol, atol=1e-9)
    assert_allclose(online.alpha, offline.alpha, **CLOSE)
    assert_allclose(online.posterior.mean, offline.posterior.mean, **CLOSE)


def grow(model, demo, step: int) -> Evidence:
    """Infer on every ``step``-th prefix of ``demo``, each an extension of the evidence of the
    one before; compare each with the inference from scratch. Returns the last evidence."""
    times, values = demo.times - demo.times[0], LAYOUT.extract(demo)
    evidence = None
    for n in list(range(3, times.shape[0], step)) + [times.shape[0]]:
        obs = Observation(times[:n], values[:n], LAYOUT.names)
        evidence = Evidence(model, obs) if evidence is None else evidence.extended(obs)
        same(evidence.infer(), infer(model, obs), n)
    return evidence


@pytest.fixture(scope="module", params=["lab-records-heights", "lab-records-flt",
                                        "lab-records-flt-shapes"])  # fmt: skip
def shared(request):
    dataset = load_records_dataset(shared_set(request.param))
    return dataset, fit(dataset, LAYOUT)


def test_a_growing_movement_is_inferred_as_from_scratch(shared) -> None:
    dataset, model = shared
    for klass in list(dataset)[:2]:
        demo = dataset[klass][len(dataset[klass]) // 2]
        step = max(demo.times.shape[0] // 25, 1)
        evidence = grow(model, demo, step)
        assert evidence.observation.n_observed == demo.times.shape[0]
        assert evidence.n_kept > 0  # it kept sums: the path under test is the incremental one


def test_a_faulty_copy_is_inferred_as_from_scratch() -> None:
    """The faulty demonstrations (still 22 s, a 20 s timestamp gap, 3x slower than any):
    long observations, out of the speed prior, where recognition's nodes move each update."""
    clean = load_records_dataset(shared_set("lab-records-flt"))
    dataset, _ = inject(clean, LAYOUT, seed=0)
    model = fit(clean, LAYOUT)
    for demo in dataset[next(iter(dataset))][-3:]:  # the three added (inject's order)
        grow(model, demo, max(demo.times.shape[0] // 12, 1))


def test_the_truncated_nodes_stay_where_they_were() -> None:
    """Once the observation outlasts a primitive's fastest plausible speeds, its speed nodes
    past the bound are dropped, never moved: each node of a later (shorter) bound, but the
    bound itself, is a node of the earlier one bit for bit, so its sums are kept."""
    for prior in (AlphaPrior((0.1,), (0.3,), (9.0,), (1.0,)),
                  AlphaPrior((0.0, 0.4), (0.2, 0.1), (4.0, 4.0), (0.5, 0.5))):  # fmt: skip
        lo, hi = prior.span(np.inf)
        assert_allclose(anchored_nodes(prior, hi + 1.0), np.linspace(lo, hi, N_NODES), rtol=0)
        bounds = np.linspace(hi + 0.2, lo - 2.0, 400)  # the bound falls as the movement grows
        before = anchored_nodes(prior, bounds[0])
        for bound in bounds[1:]:
            nodes = anchored_nodes(prior, bound)
            assert nodes[-1] == min(bound, hi)
            assert np.all(np.diff(nodes) > 0) and nodes.size >= 2
            if bound > lo:
                assert np.isin(nodes[:-1], before).all()
                lattice, step = np.linspace(lo, hi, N_NODES), (hi - lo) / (N_NODES - 1)
                kept = lattice[lattice < bound - 0.5 * step]  # the last gap over half a step
                if bound >= hi:
                    assert_allclose(nodes, lattice, rtol=0)
                else:
                    assert_allclose(nodes[:-1], kept if kept.size else lattice[:1], rtol=0)
            else:  # the tail below the bound: a lattice of half the step, within 4 scales
                assert nodes[0] >= bound - 4.0 * max(prior.scales) - 1e-12
                assert np.isin(nodes[1:-1], before).all() or before[-2] >= lo  # one may enter
                step = 0.5 * (hi - lo) / (N_NODES - 1)
                assert_allclose(np.diff(nodes[:-1]), step, rtol=1e-9)
            before = nodes


def test_a_long_movement_scores_few_new_speeds_an_update() -> None:
    """flt's longest demonstration as it is and stretched 3x (slower than any plausible
    speed), one sample an update: past the fastest plausible speed each primitive scores anew
    only the node at the bound, a lattice node entering below (the 3x case) and the refined
    nodes, but once, when the bound leaves the prior's central mass (the lattice continued
    below it); before, every node moved with every sample and each cost every sample again."""
    dataset = load_records_dataset(shared_set("lab-records-flt"))
    model = fit(dataset, LAYOUT)
    demo = max((d for ds in dataset.values() for d in ds), key=lambda d: d.times[-1])
    for stretch in (1.0, 3.0):
        times, values = stretch * (demo.times - demo.times[0]), LAYOUT.extract(demo)
        previous, cut, scored, new_total = None, 0, 0, 0
        switched = np.zeros(len(model.primitives), dtype=int)
        for n in range(times.shape[0] // 2, times.shape[0]):
            rec = recognise(model, Observation(times[:n], values[:n], LAYOUT.names))
            if previous is not None:
                for k, (now, then) in enumerate(zip(rec.candidates, previous.candidates,
                                                    strict=True)):  # fmt: skip
                    new = np.setdiff1d(now, then)
                    # once a movement, the bound leaves the prior's central mass: the tail
                    switched[k] += new.size > 2 + N_REFINE
                    cut += now.max() < then.max()  # the top node is the bound, falling
                    scored, new_total = scored + now.size, new_total + new.size
            previous = rec
        assert cut > 0  # the bound cut into some primitive's nodes: the case under test
        assert switched.max() <= 1, (stretch, switched)
        assert new_total < 0.25 * scored, (stretch, new_total, scored)


def test_another_observation_starts_again(shared) -> None:
    """An evidence extended by an observation that does not extend its own forgets the sums
    it kept: the inference is still the one from scratch (a wrong one costs time, never a
    wrong number)."""
    dataset, model = shared
    first, second = (d for ds in list(dataset.values())[:2] for d in ds[:1])
    evidence = None
    for demo in (first, second, first):
        times, values = demo.times - demo.times[0], LAYOUT.extract(demo)
        n = times.shape[0] // 2
        obs = Observation(times[:n], values[:n], LAYOUT.names)
        evidence = Evidence(model, obs) if evidence is None else evidence.extended(obs)
        same(evidence.infer(), infer(model, obs))
    # a shorter prefix of the one seen: its first samples, the sums kept of them reused or not
    obs = Observation(times[:n - 5], values[:n - 5], LAYOUT.names)
    same(evidence.extended(obs).infer(), infer(model, obs))


def test_threads_extending_one_evidence_get_the_numbers_from_scratch(shared) -> None:
    dataset, model = shared
    demo = next(iter(dataset.values()))[0]
    times, values = demo.times - demo.times[0], LAYOUT.extract(demo)
    lengths = np.linspace(5, times.shape[0], 8).astype(int).tolist()
    expected = {n: infer(model, Observation(times[:n], values[:n], LAYOUT.names))
                for n in lengths}  # fmt: skip
    base = Evidence(model, Observation(times[:3], values[:3], LAYOUT.names))
    failures: list[BaseException] = []

    def worker(order: list[int]) -> None:
        try:
            for n in order:
                obs = Observation(times[:n], values[:n], LAYOUT.names)
                same(base.extended(obs).infer(), expected[n])
        except BaseException as error:  # noqa: BLE001 - reported by the main thread
            failures.append(error)

    threads = [threading.Thread(target=worker, args=(order,))
               for order in (lengths, lengths[::-1], lengths[1::2] + lengths[::2])]  # fmt: skip
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=600)
    assert not any(thread.is_alive() for thread in threads)
    assert not failures, failures[0]


# ---------------------------------------------------------------------- what an Inference holds


def test_an_inference_holds_the_via_points_posterior_and_every_positions_region() -> None:
    """``Evidence.infer(via_points)``: the posterior conditioned on the observation, then on the
    via-points (:func:`promp.via_points.condition_on_via_points` of it), the prediction drawn
    from that, each position modality's region (:func:`promp.region.sample_distribution` of
    it with the samples' noise) and future from the observed phase, and how far the
    prediction passes from each point; the errors stay those of the method's own posterior."""
    from promp.data import Layout, Modality
    from promp.inference import predict
    from promp.model import Settings
    from promp.region import sample_distribution, sample_noise_var
    from promp.via_points import ViaPoint, condition_on_via_points
    from tests.synthetic import HAND, HEAD, make_dataset

    partner = Modality("partner", ("px", "py", "pz"), unit="m")
    layout = Layout((HEAD, HAND, partner))  # the hand not first: the layout's order is kept

    def with_partner(demo):
        values = np.column_stack([demo.values, 0.5 - demo.values[:, :3]])
        return dataclasses.replace(demo, values=values, columns=(*demo.columns, "px", "py", "pz"))

    dataset = {k: [with_partner(d) for d in v]
               for k, v in make_dataset(seed=3, n_demos=6).items()}  # fmt: skip
    model = fit(dataset, layout, Settings(n_basis=6, width=1.0, noise_scale=1.5))
    demo = dataset[model.names[0]][0]
    obs = Observation.from_demo(model, demo, 40, ["hand"])
    evidence = Evidence(model, obs)
    plain = evidence.infer(n_points=30, truth=demo)
    target = plain.mean_at("hand", 0.8) + [0.0, 0.01, 0.0]  # 1 cm off the plain prediction
    points = (ViaPoint.isotropic(("x", "y", "z"), target, 0.001, phase=0.8),
              ViaPoint.isotropic(("pz",), [0.1], 0.05, time=0.5 * demo.duration))  # fmt: skip
    shaped = evidence.infer(points, 30, demo)
    assert shaped.posterior is plain.posterior is evidence.posterior
    expected = condition_on_via_points(model, plain.posterior, points, plain.alpha)
    assert_allclose(shaped.weights.mean, expected.mean, rtol=0, atol=1e-12)
    assert_allclose(shaped.weights.cov, expected.cov, rtol=0, atol=1e-12)
    drawn = predict(model, expected, plain.alpha, 30)
    assert_allclose(shaped.prediction.mean, drawn.mean, rtol=0, atol=1e-12)
    assert_allclose(shaped.errors.position, plain.errors.position, rtol=0, atol=0)
    assert shaped.prior.times.shape == shaped.prediction.times.shape == (30,)  # n_points
    assert_allclose(shaped.prior.mean, predict(model, model.primitives[shaped.index],
                                               plain.alpha, 30).mean, rtol=0, atol=0)  # fmt: skip
    assert evidence.infer(path_points=7).path_points == 7
    natural = evidence.infer(points, truth=demo)  # at the predicted number of samples too
    assert_allclose(natural.errors.position, evidence.infer(truth=demo).errors.position,
                    rtol=0, atol=0)  # fmt: skip
    assert [p.modality for p in shaped.positions] == ["hand", "partner"]
    noise = sample_noise_var(model, model.primitives[shaped.index])
    phase = shaped.observed_until / shaped.duration
    for position, dims in zip(shaped.positions, ([3, 4, 5], [6, 7, 8]), strict=True):
        region = sample_distribution(model, expected, dims, np.linspace(0, 1, 30), noise)
        assert_allclose(position.region.mean, region.mean, rtol=0, atol=1e-12)
        assert_allclose(position.region.cov, region.cov, rtol=0, atol=1e-12)
        assert_allclose(position.future[0], shaped.mean_at(position.modality, phase), atol=1e-12)
        assert_allclose(position.times[[0, -1]], [shaped.observed_until, shaped.duration])
    hand_at = shaped.mean_at("hand", 0.8)
    partner_at = shaped.mean_at("partner", 0.5 * demo.duration / shaped.duration)
    assert_allclose(shaped.via_errors, [np.linalg.norm(hand_at - target),
                                        abs(partner_at[2] - 0.1)], rtol=1e-12)  # fmt: skip
    assert shaped.via_errors[0] < 0.005  # a tight point 1 cm off: more than half way to it
    # by primitive: the recognised primitive's via-points shape it, another's are not used
    other = next(name for name in model.names if name != shaped.primitive)
    mapped = evidence.infer({shaped.primitive: points, other: points[:1]}, 30, demo)
    assert_allclose(mapped.weights.mean, expected.mean, rtol=0, atol=0)
    assert mapped.via_points == points
    unshaped = evidence.infer({other: points}, 30, demo)
    assert unshaped.weights is plain.posterior and unshaped.via_points == ()
    assert plain.via_errors.shape == (0,) and plain.weights is plain.posterior


def test_an_evidence_refuses_what_it_cannot_answer() -> None:
    """Bad input is a ValueError naming it, before any work: an unknown alpha method, a
    duration shorter than the observation, a modality the model does not have."""
    from promp.model import Settings
    from tests.synthetic import LAYOUT as SYNTHETIC
    from tests.synthetic import make_dataset

    model = fit(make_dataset(seed=3, n_demos=5), SYNTHETIC, Settings(n_basis=6, width=1.0,
                                                                      noise_scale=1.5))  # fmt: skip
    demo = make_dataset(seed=4, n_demos=3)[model.names[0]][0]
    obs = Observation.from_demo(model, demo, 30, ["hand"])
    with pytest.raises(ValueError, match="alpha_method"):
        Evidence(model, obs, "fastest")
    with pytest.raises(ValueError, match="at least the observation"):
        Evidence(model, obs, duration=0.1)
    with pytest.raises(ValueError, match="gaze"):
        Evidence(model, Observation(obs.times, obs.values, ("gaze",)))


@pytest.mark.parametrize("size", [6, 70])
def test_the_equilibrated_precision_of_a_stack_is_each_covariances_inverse(size: int) -> None:
    """``equilibrated_precision`` of a (2, 3, P, P) stack whose dimensions' units are nine
    orders of magnitude apart: each precision is its covariance's inverse, exactly symmetric,
    and the log determinant numpy's; the stack is left as it was."""
    rng = np.random.default_rng(size)
    units = np.exp(rng.uniform(np.log(1e-6), np.log(1e3), size))
    factors = rng.standard_normal((2, 3, size, 2 * size)) * units[:, None]
    sigma = factors @ factors.swapaxes(-1, -2) / (2 * size)
    before = sigma.copy()
    precision, logdet = equilibrated_precision(sigma)
    assert precision.shape == sigma.shape and logdet.shape == (2, 3)
    assert np.array_equal(precision, precision.swapaxes(-1, -2))
    scaled = units[:, None] * (precision @ sigma) / units[None, :]  # the identity, unit-free
    assert_allclose(scaled, np.broadcast_to(np.eye(size), scaled.shape), atol=1e-8)
    assert_allclose(logdet, np.linalg.slogdet(sigma)[1], rtol=1e-12, atol=1e-9)
    assert np.array_equal(sigma, before)


def test_kept_sums_give_each_candidate_its_longest_sums_within_the_observation() -> None:
    """KeptSums.take: each candidate's sums from the latest length that holds it and is not
    longer than the observation, whether the candidates' rows are in one stored batch or in
    several, or as long as the observation; none for an observation replaced since (not those
    stored for the one that replaced it), and the sums computed for an observation replaced
    since are not stored."""
    from promp.evidence.sums import KeptSums, WhitenedSums

    def sums(n: int, alphas: list[float]) -> WhitenedSums:
        a = np.array(alphas)  # each number says its candidate and its length
        return WhitenedSums(gram=(a * 10 + n)[:, None, None, None] * np.ones((1, 1, 2, 2)),
                            group=np.zeros(1, dtype=int), proj=(a * 10 + n)[:, None, None]
                            * np.ones((1, 1, 2)), rr=(a * 10 + n)[:, None], logdet_k=np.zeros(1),
                            n=n)  # fmt: skip

    kept = KeptSums()
    assert kept.n_observed == len(kept) == 0
    generation = kept.adopt(np.arange(9.0), np.zeros((9, 1)))
    kept.store(generation, ("k",), np.array([1.0, 2.0, 3.0]), sums(4, [1.0, 2.0, 3.0]))
    kept.store(generation, ("k",), np.array([2.0, 5.0]), sums(6, [2.0, 5.0]))
    kept.store(generation, ("j",), np.array([7.0]), sums(6, [7.0]))  # the same length again
    assert kept.take(generation, ("j",), np.array([7.0]), n=8).starts.tolist() == [6]
    found = kept.take(generation, ("k",), np.array([3.0, 2.0, 7.0, 5.0, 1.0]), n=8)
    assert found.starts.tolist() == [4, 6, 0, 6, 4]
    assert found.rr[:, 0].tolist() == [34.0, 26.0, 56.0, 14.0]  # the rows of the found, in order
    assert found.gram[:, 0, 0, 0].tolist() == found.proj[:, 0, 0].tolist() == [34, 26, 56, 14]
    one = kept.take(generation, ("k",), np.array([5.0, 2.0]), n=8)  # one batch
    assert one.starts.tolist() == [6, 6] and one.rr[:, 0].tolist() == [56.0, 26.0]
    shorter = kept.take(generation, ("k",), np.array([2.0, 5.0]), n=5)  # not the length-6 rows
    assert shorter.starts.tolist() == [4, 0] and shorter.rr[:, 0].tolist() == [24.0]
    same = kept.take(generation, ("k",), np.array([5.0]), n=6)  # as long as the observation
    assert same.starts.tolist() == [6] and same.rr[:, 0].tolist() == [56.0]
    assert kept.take(generation, ("other",), np.array([2.0]), n=8).starts.tolist() == [0]
    replaced = kept.adopt(np.arange(9.0), np.ones((9, 1)))
    assert kept.take(replaced, ("k",), np.array([2.0]), n=8).starts.tolist() == [0]
    kept.store(replaced, ("k",), np.array([2.0]), sums(3, [2.0]))  # the new observation's
    assert kept.take(replaced, ("k",), np.array([2.0]), n=8).starts.tolist() == [3]
    stale = kept.take(generation, ("k",), np.array([2.0]), n=8)  # a sums of the one replaced
    assert stale.starts.tolist() == [0] and stale.rr.size == 0
    kept.store(generation, ("late",), np.array([2.0]), sums(8, [2.0]))  # computed for it
    assert kept.take(replaced, ("late",), np.array([2.0]), n=8).starts.tolist() == [0]


def test_a_known_duration_scores_every_primitive_at_its_speed_alone() -> None:
    """``Evidence(duration=...)`` (the evaluation's oracle row): each primitive's evidence is its
    likelihood at the one speed of that duration, no prior; the recognition is the best of
    them, at that speed. A duration the observation reaches within round-off is the
    observation's own; a shorter or non-finite one is refused."""
    from promp.recognition import label_noise, with_label_noise
    from promp.timing import alpha_from_duration

    model, demo = synthetic()
    obs = Observation.from_demo(model, demo, 30, ["hand"])
    dt, s_bar, elapsed = model.sample_period, model.settings.s_bar, float(obs.elapsed[-1])
    for duration, at in ((demo.duration, demo.duration), (1.7 * demo.duration, 1.7 * demo.duration),
                         (elapsed * (1.0 - 1e-12), elapsed)):  # fmt: skip
        evidence = Evidence(model, obs, duration=duration)
        reco = evidence.recognition
        alpha = alpha_from_duration(at, dt, s_bar)
        each = np.array([evidence.log_likelihoods(p, np.array([alpha]))[0]
                         for p in model.primitives])  # fmt: skip
        assert np.all(np.isfinite(each)) and len(set(each.tolist())) == len(each)
        assert_allclose(reco.log_evidence, each, rtol=1e-12, atol=0)
        assert reco.index == int(np.argmax(each)) and reco.primitive == model.names[reco.index]
        assert reco.alpha == pytest.approx(alpha, rel=1e-12)
        assert reco.alpha_method == "duration given"
        for nodes, table, prior, ll in zip(reco.candidates, reco.log_likelihoods, reco.log_prior,
                                           each, strict=True):  # fmt: skip
            assert_allclose(nodes, [alpha], rtol=1e-12)
            assert_allclose(table, [ll], rtol=1e-12)
            assert prior.tolist() == [0.0]
        want = with_label_noise(np.exp(each - each.max()) / np.exp(each - each.max()).sum(),
                                label_noise(model))  # fmt: skip
        assert_allclose(reco.probabilities, want, rtol=1e-9, atol=1e-15)
    assert Evidence(model, obs, duration=demo.duration).recognition.index == 1  # its own
    shorter = Observation.from_demo(model, demo, 20, ["hand"])
    grown = Evidence(model, shorter, "model", duration=demo.duration).extended(obs)
    assert grown.duration == demo.duration and grown.alpha_method == "model"  # both kept
    assert grown.recognition.alpha_method == "duration given"
    assert_allclose(grown.recognition.log_evidence,
                    Evidence(model, obs, duration=demo.duration).recognition.log_evidence,
                    rtol=1e-11)  # fmt: skip
    for bad in (elapsed * (1.0 - 1e-6), math.nan, math.inf):
        with pytest.raises(ValueError):
            Evidence(model, obs, duration=bad)


def test_an_extended_evidence_shares_the_sums_kept() -> None:
    """The evidence of the movement observed longer adds its candidates' sums to the same
    store as the evidence it extends (``n_kept`` of both), and its numbers are those of an
    evidence from scratch."""
    model, demo = synthetic()
    primitive = model.primitives[0]
    first = Evidence(model, Observation.from_demo(model, demo, 20, ["hand"]))
    alphas = np.exp(primitive.log_alpha_mean) * np.array([0.8, 1.0, 1.2])
    first.log_likelihoods(primitive, alphas[:2])
    assert first.n_kept == 2
    obs = Observation.from_demo(model, demo, 30, ["hand"])
    grown = first.extended(obs)
    longer = grown.log_likelihoods(primitive, alphas[1:])
    assert grown.n_kept == first.n_kept == 3  # one store: the first speed at 20, two at 30
    assert_allclose(longer, Evidence(model, obs).log_likelihoods(primitive, alphas[1:]),
                    rtol=1e-12)  # fmt: skip


def synthetic():
    """A small model of the synthetic demonstrations, and a demonstration of its second
    primitive not among those it learned from."""
    from promp.model import Settings
    from tests.synthetic import LAYOUT as SYNTHETIC
    from tests.synthetic import make_dataset

    model = fit(make_dataset(seed=3, n_demos=5), SYNTHETIC,
                Settings(n_basis=6, width=1.0, noise_scale=1.5, recognition="promp"))
    return model, make_dataset(seed=4, n_demos=3)[model.names[1]][0]


def test_the_sums_of_one_sample_extended_over_two_noise_groups_are_those_from_scratch() -> None:
    """An evidence of the first sample alone, extended twice, with the hand's noise correlated
    in time and the head's white (two noise groups): at the same speeds, the likelihoods from
    the kept sums are those of evidences from scratch."""
    model, demo = synthetic()
    taus = np.array([0.05, 0.05, 0.05, 0.0, 0.0, 0.0])
    model = dataclasses.replace(model, primitives=tuple(
        dataclasses.replace(p, noise_tau=taus) for p in model.primitives))  # fmt: skip
    primitive = model.primitives[1]
    alphas = np.exp(primitive.log_alpha_mean) * np.array([0.7, 0.9, 1.1])
    evidence = None
    for n in (1, 12, 25):
        obs = Observation.from_demo(model, demo, n, ["hand", "head"])
        evidence = Evidence(model, obs) if evidence is None else evidence.extended(obs)
        assert_allclose(evidence.log_likelihoods(primitive, alphas),
                        Evidence(model, obs).log_likelihoods(primitive, alphas),
                        rtol=1e-12, atol=1e-9)  # fmt: skip
    assert evidence.n_kept == 3
    from tests import dense_reference as dense  # the white head's log det K is 0, not more

    assert_allclose(evidence.log_likelihoods(primitive, alphas),
                    [dense.log_likelihood(model, primitive, obs, a) for a in alphas],
                    rtol=1e-9, atol=1e-6)  # fmt: skip


def test_the_sums_are_read_only() -> None:
    """What :class:`promp.evidence.sums.ObservationSums` gives is kept and shared by later
    evidences: every array of it is read-only."""
    from promp.evidence.sums import ObservationSums
    from promp.timing import duration_from_alpha

    model, demo = synthetic()
    obs = Observation.from_demo(model, demo, 20, ["hand"])
    alphas = np.array([0.8, 1.0])
    durations = duration_from_alpha(alphas, model.sample_period, model.settings.s_bar)
    sums = ObservationSums(model, obs, np.arange(3))(model.primitives[0], alphas, durations)
    for array in (sums.gram, sums.proj, sums.rr, sums.group, sums.logdet_k):
        assert not array.flags.writeable


def test_the_sums_of_a_longer_observation_add_its_new_samples_to_those_kept(monkeypatch) -> None:
    """:class:`promp.evidence.sums.ObservationSums` sharing the store of a shorter observation
    of the movement: at the speeds kept, only the new samples' terms are computed (from the
    sample before them), the numbers those from every sample; another primitive at the same
    speeds, or the same samples read as other dimensions, get their own sums."""
    from promp.evidence.sums import ObservationSums
    from promp.timing import duration_from_alpha

    model, demo = synthetic()
    dims, alphas = np.arange(3), np.array([0.8, 1.0])
    durations = duration_from_alpha(alphas, model.sample_period, model.settings.s_bar)
    first, second = model.primitives[:2]
    short = Observation.from_demo(model, demo, 20, ["hand"])
    obs = Observation.from_demo(model, demo, 30, ["hand"])
    kept = ObservationSums(model, short, dims)
    kept(first, alphas, durations)
    calls = []

    def spying(name: str):
        original = getattr(ObservationSums, name)

        def spy(self, primitive, *args):  # which primitive, and from which sample
            calls.append((name, primitive.name, *args[2:]))
            return original(self, primitive, *args)

        return spy

    for name in ("dense", "rows"):
        monkeypatch.setattr(ObservationSums, name, spying(name))
    grown = ObservationSums(model, obs, dims, kept.kept)
    for primitive, want in ((first, [("rows", first.name, 20)]),
                            (second, [("dense", second.name)])):  # fmt: skip
        calls.clear()
        sums = grown(primitive, alphas, durations)
        assert calls == want
        scratch = ObservationSums(model, obs, dims)(primitive, alphas, durations)
        for field in ("gram", "proj", "rr"):
            assert_allclose(getattr(sums, field), getattr(scratch, field), rtol=1e-11, atol=1e-9)
    other = ObservationSums(model, obs, dims + 3, kept.kept)  # the same samples as the head's
    scratch = ObservationSums(model, obs, dims + 3)(first, alphas, durations)
    assert_allclose(other(first, alphas, durations).rr, scratch.rr, rtol=1e-11, atol=1e-9)


def test_the_refined_speeds_surround_the_best_coarse_node() -> None:
    """Recognition's quadrature refines around the coarse node of the largest likelihood
    times prior density: every node it adds lies within one coarse step of it."""
    from promp.evidence.speed import alpha_prior, longest_alpha

    model, demo = synthetic()
    obs = Observation.from_demo(model, demo, 30, ["hand"])
    evidence = Evidence(model, obs)
    bound = math.log(longest_alpha(model, obs))
    for k, primitive in enumerate(model.primitives):
        prior = alpha_prior(model, primitive, obs, "ml")
        coarse = anchored_nodes(prior, bound)
        score = evidence.log_likelihoods(primitive, np.exp(coarse)) + prior.logpdf(coarse)
        best, step = coarse[int(np.argmax(score))], coarse[1] - coarse[0]
        x = np.log(evidence.recognition.candidates[k])
        fine = x[~np.isclose(x[:, None], coarse[None, :], rtol=0, atol=1e-12).any(axis=1)]
        assert fine.size > 0 and np.all(np.abs(fine - best) < step * (1 + 1e-9))


def test_the_weight_space_form_is_chosen_from_a_rank_of_a_fifth_of_the_observed_weights() -> None:
    """``cheaper_than_woodbury``: the Woodbury form while the factor's rank is under a fifth
    of the observed weights (bench/likelihood_forms.py), the weight-space form from there on."""
    from promp.evidence.weight_space import cheaper_than_woodbury

    assert [cheaper_than_woodbury(100, r) for r in (1, 19, 20, 21, 100)] == [
        False, False, True, True, True]  # fmt: skip
    assert cheaper_than_woodbury(5, 1) and not cheaper_than_woodbury(6, 1)


def test_the_observed_precision_is_the_observed_weights_inverse_bordered_and_read_only() -> None:
    """``observed_precision``: the inverse of the observed dimensions' block of the prior
    covariance, bordered by a zero row and column, with its log determinant; read-only (the
    threads of one evidence share it) and computed once per primitive and dimensions."""
    from promp.evidence.weight_space import observed_precision

    model, _ = synthetic()
    primitive = model.primitives[0]
    dims = np.array([3, 5])
    m = model.settings.n_basis
    rows = np.concatenate([np.arange(d * m, (d + 1) * m) for d in dims])
    sigma = primitive.cov[np.ix_(rows, rows)]
    padded, logdet = observed_precision(primitive, dims)
    assert padded.shape == (2 * m + 1, 2 * m + 1) and not padded.flags.writeable
    inverse = np.linalg.inv(sigma)  # (a condition number of ~3e10: compared to its size)
    assert_allclose(padded[:-1, :-1], inverse, rtol=0, atol=1e-8 * np.abs(inverse).max())
    assert not padded[-1].any() and not padded[:, -1].any()
    assert_allclose(logdet, np.linalg.slogdet(sigma)[1], rtol=1e-12)
    assert observed_precision(primitive, dims)[0] is padded


def test_the_diagonal_blocks_are_a_writable_view_of_each_matrix() -> None:
    """``diagonal_blocks``: the leading ``size x size`` blocks of the diagonal of every matrix
    of a stack, shape (A, n_blocks, size, size), written through to the stack."""
    from promp.evidence.weight_space import diagonal_blocks

    matrices = np.arange(3 * 7 * 7, dtype=float).reshape(3, 7, 7)
    blocks = diagonal_blocks(matrices, 2, 3)
    assert blocks.shape == (3, 2, 3, 3)
    for a in range(3):
        for b in range(2):
            assert np.array_equal(blocks[a, b], matrices[a, 3 * b:3 * b + 3, 3 * b:3 * b + 3])
    blocks[1, 1] += 1000.0
    assert matrices[1, 4, 5] == 1 * 49 + 4 * 7 + 5 + 1000.0 and matrices[1, 6, 6] < 1000.0


def test_an_inference_says_its_primitive_speed_duration_and_the_share_observed() -> None:
    """``Inference``'s properties: the recognition's primitive and probabilities, the timing's
    speed, the prediction's duration, the observation's length, the seconds left (none once
    the observation is as long as the prediction) and the share observed (at most 1; 1 for
    a prediction of no duration)."""
    model, demo = synthetic()
    first = Observation.from_demo(model, demo, 30, ["hand"])
    obs = Observation(first.times + 5.0, first.values, first.modalities)  # a clock's seconds
    result = Evidence(model, obs).infer()
    assert result.index == result.recognition.index and result.index in (0, 1)
    assert result.primitive == model.names[result.index] == result.recognition.primitive
    assert result.alpha == result.timing.alpha and result.probabilities is not None
    assert result.probabilities is result.recognition.probabilities
    assert result.observed_until == obs.times[-1] - obs.times[0] > 0
    assert result.duration == result.prediction.times[-1] > result.observed_until
    assert result.remaining == result.duration - result.observed_until
    assert result.observed_phase == result.observed_until / result.duration < 1.0
    whole = Observation.from_demo(model, demo, demo.n_samples, ["hand"])
    longer = dataclasses.replace(result, observation=Observation(
        whole.times * 2.0 * result.duration / whole.elapsed[-1], whole.values, whole.modalities))
    assert longer.observed_until > longer.duration
    assert longer.remaining == 0.0 and longer.observed_phase == 1.0
    instant = dataclasses.replace(result, prediction=dataclasses.replace(
        result.prediction, times=np.zeros(1)))
    assert instant.duration == 0.0 and instant.observed_phase == 1.0
    assert instant.remaining == 0.0


def test_the_equilibrated_precision_of_float32_covariances_is_computed_in_float64() -> None:
    """``equilibrated_precision`` of a float32 stack: the numbers of the same values in float64
    (scales, logarithms and all), not float32's seven digits."""
    rng = np.random.default_rng(2)
    factors = rng.standard_normal((2, 5, 9))
    sigma = (factors @ factors.swapaxes(-1, -2)).astype(np.float32)
    precision, logdet = equilibrated_precision(sigma)
    expected, expected_logdet = equilibrated_precision(sigma.astype(float))
    assert precision.dtype == logdet.dtype == np.float64
    assert np.array_equal(precision, expected) and np.array_equal(logdet, expected_logdet)


def test_an_inferences_regions_carry_the_recognised_primitives_sample_noise() -> None:
    """Each primitive may have its own noise (a model file, an older fit): the region drawn
    is the recognised primitive's weights with *its* samples' noise, not the first one's."""
    from promp.model import Settings
    from promp.region import sample_distribution, sample_noise_var
    from tests.synthetic import LAYOUT, make_dataset

    dataset = make_dataset(seed=3, n_demos=6)
    model = fit(dataset, LAYOUT, Settings(n_basis=6, width=1.0, noise_scale=1.5))
    demo = dataset[model.names[1]][0]
    louder = dataclasses.replace(model.primitives[1], noise_var=9.0 * model.primitives[1].noise_var)
    model = dataclasses.replace(model, primitives=(model.primitives[0], louder))
    inference = Evidence(model, Observation.from_demo(model, demo, 40, ["hand"])).infer()
    assert inference.index == 1
    noise = sample_noise_var(model, louder)
    (hand,) = [p for p in inference.positions if p.modality == "hand"]
    dims = model.layout.dims(["hand"])
    phases = np.linspace(0.0, 1.0, hand.region.mean.shape[0])
    region = sample_distribution(model, inference.weights, dims, phases, noise)
    assert_allclose(hand.region.cov, region.cov, rtol=0, atol=1e-12)
    first = sample_distribution(model, inference.weights, dims, phases,
                                sample_noise_var(model, model.primitives[0]))  # fmt: skip
    assert not np.allclose(hand.region.cov, first.cov, rtol=1e-6, atol=0)


def test_an_extended_evidence_scores_the_refined_nodes_before_with_its_coarse_ones(
    monkeypatch,
) -> None:
    """While a primitive's best coarse node stays, an extended evidence scores its refined
    nodes in the same call as its coarse ones (those of the evidence it extends: one call of
    the likelihood per primitive instead of two), with the numbers from scratch; a node that
    is no longer a refined node is left out of its recognition."""
    from promp.evidence import weight_space, woodbury

    model, demo = synthetic()
    first = Evidence(model, Observation.from_demo(model, demo, 20, ["hand"]))
    before = first.recognition
    obs = Observation.from_demo(model, demo, 21, ["hand"])
    calls = []
    for form in (weight_space, woodbury):
        original = form.log_likelihoods
        monkeypatch.setattr(form, "log_likelihoods",
                            lambda *a, f=original: calls.append(a[0].proj.shape[0]) or f(*a))
    grown = first.extended(obs).recognition
    assert len(calls) == len(model.primitives)  # one call each
    fresh = Evidence(model, obs).recognition
    for k in range(len(model.primitives)):
        assert_allclose(grown.candidates[k], fresh.candidates[k], rtol=0, atol=0)
        assert_allclose(grown.candidates[k], before.candidates[k], rtol=0, atol=0)  # stayed
        assert_allclose(grown.log_likelihoods[k], fresh.log_likelihoods[k], rtol=1e-12)
    assert_allclose(grown.probabilities, fresh.probabilities, rtol=0, atol=1e-12)
    # a guess that is not a refined node now: scored, but left out of the recognition
    odd = Evidence(model, obs, _refined={p: np.log(c[1:2]) + 1e-3 for p, c in
                                         zip(model.primitives, before.candidates, strict=True)})
    assert_allclose(odd.recognition.log_evidence, fresh.log_evidence, rtol=1e-12)
    for k in range(len(model.primitives)):
        assert_allclose(odd.recognition.candidates[k], fresh.candidates[k], rtol=0, atol=0)
