"""The method's outputs on fixed trials, recorded to a file and compared with another record:
proof that a refactoring of ``promp`` changed no number.

``record OUT.npz`` runs, on the three shared lab sets, a faulty copy of each
(``tests/faults.py``: the three faulty demonstrations of every primitive added) and the
studio's simulated scenario (hand and head), a fixed set of trials and keeps every number the
method gives:

* the fitted model's settings and weights (what the automatic choice picked);
* per trial (three demonstrations of each primitive, the model learned from the whole set),
  at 20, 40, 60, 80 and 100 % observed, alpha ``ml`` and ``model`` (and the duration told at
  60 %): the recognition (probabilities, log-evidence, every node, log-likelihood and log
  prior), alpha, the timing (duration and observed share with their intervals), the posterior
  mean and blocks, the prior and posterior predictions, and the errors against the truth;
* the likelihood at three noise levels (the noise scale's choice reads it);
* a live movement through :class:`promp.live.predictor.OnlinePredictor`, every published
  number at each of ~20 updates;
* the studio's Infer path (:func:`app.live.inference.inferred`) with and without via-points:
  the shaped weights, the prediction, every position's region and future path.

``compare A.npz B.npz`` prints the largest absolute difference of each kind of number and
fails (exit code 1) when one exceeds ``--atol`` (1e-9), or when a key is in one record only.
Log-likelihoods (``log_likelihoods``, ``loglik``, ``scaled``) and log-evidences (sums of up to ~1e4
nats) are compared to ``--rtol-log``
(1e-11) of their size as well::

    .venv/bin/python bench/outputs.py record /work/evidence-baseline/outputs.npz
    .venv/bin/python bench/outputs.py compare /work/evidence-baseline/outputs.npz new.npz

The record written on the tree before :mod:`promp.evidence` (9d0abac, by this script as it was
then, reading ``promp.pipeline`` and ``promp._likelihood``) holds the same keys.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from promp.datasets import RECORD_COLUMNS, guess_layout, load_records_dataset  # noqa: E402
from promp.evidence import Evidence  # noqa: E402
from promp.evidence.pipeline import infer, log_likelihoods  # noqa: E402
from promp.inference import Observation  # noqa: E402
from promp.learn import fit  # noqa: E402

SHARED = REPO.parent / "shared" / "data"
SETS = ("lab-records-heights", "lab-records-flt", "lab-records-flt-shapes")
PERCENTS = (20, 40, 60, 80, 100)
LOG_KINDS = ("log_likelihoods", "log_evidence", "scaled", "loglik")


def record_inference(out: dict, key: str, result) -> None:
    """Every number of one :class:`promp.evidence.Inference` under ``key``."""
    reco = result.recognition
    out[f"{key}/index"] = np.array([reco.index])
    out[f"{key}/probabilities"] = reco.probabilities
    out[f"{key}/log_evidence"] = reco.log_evidence
    for k, (nodes, ll, lp) in enumerate(
        zip(reco.candidates, reco.log_likelihoods, reco.log_prior, strict=True)
    ):
        out[f"{key}/candidates/{k}"] = nodes
        out[f"{key}/log_likelihoods/{k}"] = ll
        out[f"{key}/log_prior/{k}"] = lp
    out[f"{key}/alpha"] = np.array([reco.alpha, result.alpha])
    t = result.timing
    out[f"{key}/timing"] = np.array([
        t.duration.value, t.duration.low, t.duration.high, t.observed_fraction.value,
        t.observed_fraction.low, t.observed_fraction.high, t.alpha, t.temperature,
    ])  # fmt: skip
    n_dims = result.prediction.mean.shape[1]
    out[f"{key}/posterior_mean"] = result.posterior.mean
    out[f"{key}/posterior_blocks"] = result.posterior.blocks(n_dims)
    for name in ("prior", "prediction", "natural"):
        prediction = getattr(result, name)
        if prediction is not None:
            out[f"{key}/{name}_times"] = prediction.times
            out[f"{key}/{name}_mean"] = prediction.mean
            out[f"{key}/{name}_std"] = prediction.std
    if result.errors is not None:
        e = result.errors
        out[f"{key}/errors"] = np.array(
            [e.position, e.goal, e.duration, float(e.duration_covered)]
        )


def trials(dataset: dict) -> list:
    """Three demonstrations of every primitive: its first, middle and last."""
    picked = []
    for name in sorted(dataset):
        demos = dataset[name]
        for i in sorted({0, len(demos) // 2, len(demos) - 1}):
            picked.append((name, i, demos[i]))
    return picked


def record_model(out: dict, key: str, model) -> None:
    s = model.settings
    out[f"{key}/settings"] = np.array([
        s.n_basis, s.width, s.noise_scale or 0.0, s.duration_temperature or 0.0,
    ])  # fmt: skip
    for k, prim in enumerate(model.primitives):
        out[f"{key}/primitive/{k}/mean"] = prim.mean
        out[f"{key}/primitive/{k}/cov"] = prim.cov
        out[f"{key}/primitive/{k}/noise_var"] = prim.noise_var


def record_set(out: dict, key: str, dataset: dict, tested: dict, layout, modalities) -> None:
    """The model learned from ``dataset``, and the trials of ``tested``."""
    model = fit(dataset, layout)
    record_model(out, f"{key}/model", model)
    for name, i, demo in trials(tested):
        for observed in modalities:
            for percent in PERCENTS:
                n = max(int(np.ceil(percent / 100 * demo.n_samples)), 2)
                obs = Observation.from_demo(model, demo, n, observed)
                trial = f"{key}/{name}/{i}/{'+'.join(observed)}/{percent}"
                for method in ("ml", "model"):
                    result = infer(model, obs, alpha_method=method, truth=demo)
                    record_inference(out, f"{trial}/{method}", result)
                if percent == 60:
                    result = infer(model, obs, duration=demo.duration, n_points=50)
                    record_inference(out, f"{trial}/duration", result)
                    for k, prim in enumerate(model.primitives):
                        out[f"{trial}/loglik/{k}"] = log_likelihoods(model, prim, obs, prim.alphas)
                        out[f"{trial}/scaled/{k}"] = scaled(model, prim, obs)
    record_live(out, f"{key}/live", model, tested, modalities[0])


def scaled(model, prim, obs) -> np.ndarray:
    """The likelihood at three noise levels."""
    factors = np.array([[0.5], [1.0], [2.0]]) * np.ones((1, model.n_dims))
    return Evidence(model, obs).log_likelihoods(prim, prim.alphas, factors)


def record_live(out: dict, key: str, model, dataset: dict, observed) -> None:
    """A movement of the first primitive fed to the online predictor as it grows."""
    from promp.live.predictor import OnlinePredictor

    demo = dataset[sorted(dataset)[0]][1]
    values = model.layout.extract(demo)
    columns, start = {}, 0
    for modality in model.layout.modalities:
        width = len(modality.columns)
        if modality.name in observed:
            columns[modality.name] = slice(start, start + width)
        start += width
    remainder = model.layout.modalities[0].name
    predictor = OnlinePredictor(model, columns, remainder=remainder, rate=40.0)
    n = demo.times.shape[0]
    for length in sorted({*range(3, n, max(n // 20, 1)), n}):
        p = predictor.predict(1, demo.times[:length] + 5.0, values[:length])
        k = f"{key}/{length}"
        record_inference(out, k, p.inference)
        out[f"{k}/published"] = np.array([
            p.phase.value, p.phase.low, p.phase.high, p.duration.value, p.duration.low,
            p.duration.high, p.remaining.value, p.remaining.low, p.remaining.high,
        ])  # fmt: skip
        out[f"{k}/remainder"] = np.column_stack(
            [p.remainder.after, p.remainder.mean, p.remainder.std]
        )


def record_studio(out: dict, key: str) -> None:
    """The studio's Infer path on its simulated scenario, with and without via-points."""
    from app.core.via_state import StudioViaPoint, by_primitive
    from app.live.inference import inferred
    from robots.icub.layout import STUDIO_LAYOUT
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=3, n_demos=6)
    model = fit(dataset, STUDIO_LAYOUT)
    record_model(out, f"{key}/model", model)
    vias = []
    for i, name in enumerate(sorted(dataset)):  # two points a primitive: a tight, a loose one
        hand = model.layout.extract(dataset[name][0])[:, model.layout.dims(["hand"])]
        for j, (phase, std) in enumerate(((0.7, 0.01), (0.9, 0.05))):
            at = hand[int(phase * (hand.shape[0] - 1))] + 0.02 * (1 - 2 * j)
            vias.append(StudioViaPoint(2 * i + j, name, phase, tuple(at.tolist()), std))
    for name, i, demo in trials(dataset):
        for observed in (("hand",), ("head",), ("hand", "head")):
            for percent in (30, 70):
                obs = Observation.first(model, demo, percent, observed)
                for label, points in (("plain", ()), ("via", tuple(vias))):
                    shaping = by_primitive(points, model.layout)
                    result = inferred(model, obs, "ml", truth=demo, via_points=shaping)
                    trial = f"{key}/{name}/{i}/{'+'.join(observed)}/{percent}/{label}"
                    record_inference(out, trial, result.inference)
                    out[f"{trial}/weights_mean"] = np.asarray(result.weights.mean)
                    out[f"{trial}/weights_cov"] = np.asarray(result.weights.cov)
                    out[f"{trial}/shaped_mean"] = result.prediction.mean
                    out[f"{trial}/shaped_std"] = result.prediction.std
                    out[f"{trial}/future"] = np.column_stack(
                        [result.future.times, result.future.hand]
                    )
                    for view in result.positions:
                        out[f"{trial}/region/{view.modality}/mean"] = view.region.mean
                        out[f"{trial}/region/{view.modality}/cov"] = view.region.cov
                        out[f"{trial}/region/{view.modality}/future"] = view.future


def record(path: Path) -> None:
    from tests.faults import inject

    layout = guess_layout(RECORD_COLUMNS[1:])
    out: dict[str, np.ndarray] = {}
    for name in SETS:
        folder = SHARED / name
        if not folder.is_dir():
            raise SystemExit(f"the shared set {folder} is missing")
        clean = load_records_dataset(folder)
        record_set(out, name, clean, clean, layout, [("hand",)])
        faulty, _ = inject(clean, layout, seed=0)
        only_faults = {k: v[-3:] for k, v in faulty.items()}
        record_set(out, f"{name}-faulty", faulty, only_faults, layout, [("hand",)])
        print(f"{name}: {len(out)} arrays", flush=True)
    record_studio(out, "studio")
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **{k: np.asarray(v, dtype=float) for k, v in out.items()})
    print(f"{len(out)} arrays written to {path}")


def kind(key: str) -> str:
    """What a key holds, without the trial: its last word that is not a number."""
    words = [w for w in key.split("/") if not w.lstrip("-").isdigit()]
    return words[-1]


def compare(a_path: Path, b_path: Path, atol: float, rtol_log: float) -> int:
    with np.load(a_path, allow_pickle=False) as a, np.load(b_path, allow_pickle=False) as b:
        a_keys, b_keys = set(a.files), set(b.files)
        only = sorted(a_keys ^ b_keys)
        worst: dict[str, tuple[float, str]] = {}
        failed = []
        for key in sorted(a_keys & b_keys):
            x, y = a[key], b[key]
            if x.shape != y.shape:
                failed.append(f"{key}: shapes {x.shape} and {y.shape}")
                continue
            same_inf = np.array_equal(np.isinf(x), np.isinf(y)) and np.array_equal(
                np.isnan(x), np.isnan(y)
            )
            finite = np.isfinite(x) & np.isfinite(y)
            diff = float(np.max(np.abs(x[finite] - y[finite]), initial=0.0))
            k = kind(key)
            tol = atol
            if any(word in key for word in LOG_KINDS):
                tol = max(atol, rtol_log * float(np.max(np.abs(x[finite]), initial=0.0)))
            if diff > worst.get(k, (-1.0, ""))[0]:
                worst[k] = (diff, key)
            same_rest = np.array_equal(x[~finite], y[~finite], equal_nan=True)
            if not same_inf or not same_rest or diff > tol:
                failed.append(f"{key}: differs by {diff:.3g} (tolerance {tol:.3g})")
    for k, (diff, key) in sorted(worst.items()):
        print(f"{k:>20}: max |difference| {diff:.3g}  ({key})")
    print(f"{len(a_keys & b_keys)} arrays compared")
    for line in only[:20]:
        print(f"in one record only: {line}")
    for line in failed[:40]:
        print(f"FAIL {line}")
    ok = not failed and not only
    print("SAME" if ok else f"DIFFERENT: {len(failed)} arrays, {len(only)} keys in one only")
    return 0 if ok else 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="record this tree's outputs")
    rec.add_argument("out", type=Path)
    cmp_ = sub.add_parser("compare", help="compare two records")
    cmp_.add_argument("a", type=Path)
    cmp_.add_argument("b", type=Path)
    cmp_.add_argument("--atol", type=float, default=1e-9)
    cmp_.add_argument("--rtol-log", type=float, default=1e-11)
    args = parser.parse_args(argv)
    if args.command == "record":
        record(args.out)
        return 0
    return compare(args.a, args.b, args.atol, args.rtol_log)


if __name__ == "__main__":
    sys.exit(main())
