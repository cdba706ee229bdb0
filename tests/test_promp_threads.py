"""promp shared between threads: the studio infers on its loop, on the recognition chart's
worker and in an evaluation at once, with the same models. Every inference made while four
threads infer on two models (their caches filled by all four at once) equals, bit for bit, the
one made alone, and the process's one BLAS thread (promp/_threads.py) holds throughout."""

from __future__ import annotations

import dataclasses
import random
import threading
import time

import numpy as np
import pytest

from promp._threads import promp_blas_threads
from promp.evidence.pipeline import infer
from promp.inference import Observation
from promp.learn import fit
from promp.model import Settings
from tests.synthetic import LAYOUT, make_dataset

SECONDS = 3.0  # how long the four threads infer together
SETTINGS = Settings(n_basis=7, width=1.0, noise_scale=1.5)


def flatten(value, prefix: str = "") -> dict[str, object]:
    """Every number and array of an inference, by its path (dataclasses, tuples, arrays)."""
    if dataclasses.is_dataclass(value):
        out = {}
        for f in dataclasses.fields(value):
            out.update(flatten(getattr(value, f.name), f"{prefix}.{f.name}"))
        return out
    if isinstance(value, tuple | list):
        out = {}
        for i, item in enumerate(value):
            out.update(flatten(item, f"{prefix}[{i}]"))
        return out
    if isinstance(value, np.ndarray | float | int | str | bool) or value is None:
        return {prefix: value}
    return {}  # the model a result refers to: the same object, not a result


def same_bits(a: dict, b: dict) -> list[str]:
    """The paths where ``a`` and ``b`` differ (arrays by value and dtype, NaN equal to NaN)."""
    differ = [k for k in a.keys() ^ b.keys()]
    for key in a.keys() & b.keys():
        x, y = a[key], b[key]
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            x, y = np.ascontiguousarray(x), np.ascontiguousarray(y)
            if x.dtype != y.dtype or x.shape != y.shape or not np.array_equal(
                x.view(np.uint8), y.view(np.uint8)
            ):
                differ.append(key)
        elif isinstance(x, float) and isinstance(y, float):
            if not (x == y or (np.isnan(x) and np.isnan(y))):
                differ.append(key)
        elif x != y:
            differ.append(key)
    return differ


def datasets():
    """Two workspaces: two primitives, and three with other targets."""
    three = {
        "up": np.array([0.1, 0.0, 0.3, 0.2, -0.2, 0.0]),
        "left": np.array([0.2, -0.25, 0.05, 0.0, 0.3, -0.6]),
        "right": np.array([0.2, 0.25, 0.05, 0.0, 0.3, 0.6]),
    }
    return make_dataset(seed=0, n_demos=8), make_dataset(seed=1, n_demos=6, targets=three)


def cases(models, tests) -> list[tuple]:
    """(model index, test demonstration, n_observed, modalities, alpha method)."""
    out = []
    for m, demos in enumerate(tests):
        for demo in demos:
            for n in (5, 20, 45, demo.n_samples - 5):
                for observed in (("hand",), ("head",), ("hand", "head")):
                    for alpha in ("ml", "model"):
                        out.append((m, demo, n, observed, alpha))
    return out


def run(model, demo, n, observed, alpha):
    obs = Observation.from_demo(model, demo, n, observed)
    return flatten(infer(model, obs, alpha, n_points=50, truth=demo))


@pytest.mark.slow
def test_four_threads_on_two_models_infer_what_one_thread_does_bit_for_bit() -> None:
    train, tests = [], []
    for dataset in datasets():
        held = {name: demos[-1] for name, demos in dataset.items()}
        train.append({name: demos[:-1] for name, demos in dataset.items()})
        tests.append(list(held.values()))
    # Alone, on models of their own (their caches filled by this thread only).
    alone_models = [fit(t, LAYOUT, SETTINGS) for t in train]
    todo = cases(alone_models, tests)
    expected = [run(alone_models[m], d, n, o, a) for m, d, n, o, a in todo]
    # Together: new models (cold caches, filled by four threads at once), each thread in its
    # own order, for SECONDS.
    models = [fit(t, LAYOUT, SETTINGS) for t in train]
    assert all(new is not old for new, old in zip(models, alone_models, strict=True))
    failures: list[str] = []
    counts = [0] * 4
    blas_seen: set[int] = set()
    start = threading.Barrier(4)

    def work(k: int) -> None:
        try:
            infer_for(k)
        except Exception as exc:  # a crash in a thread fails the test, with its reason
            failures.append(f"thread {k} raised {type(exc).__name__}: {exc}")

    def infer_for(k: int) -> None:
        order = list(range(len(todo)))
        random.Random(k).shuffle(order)
        start.wait()
        deadline = time.monotonic() + SECONDS
        i = 0
        while time.monotonic() < deadline or i < len(order):
            j = order[i % len(order)]
            m, d, n, o, a = todo[j]
            got = run(models[m], d, n, o, a)
            differ = same_bits(got, expected[j])
            if differ:
                failures.append(f"thread {k}, case {j}: {sorted(differ)[:5]}")
            blas_seen.update(promp_blas_threads())
            counts[k] += 1
            i += 1

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not failures, failures[:10]
    assert min(counts) >= len(todo), counts  # every thread ran every case at least once
    assert blas_seen == {1}, "promp's one BLAS thread (promp/_threads.py) changed meanwhile"
