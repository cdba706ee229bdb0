"""Model JSON and demonstration NPZ formats: exact round trips, strict validation, no pickle."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from promp.demo_npz import demo_from_npz_bytes, demo_to_npz_bytes
from promp.evidence.pipeline import condition, recognise
from promp.inference import Observation, predict
from promp.io import (
    load_model,
    model_from_dict,
    model_from_json,
    model_to_dict,
    save_model,
)
from promp.learn import fit
from promp.model import Settings
from tests.synthetic import LAYOUT, make_dataset


@pytest.fixture(scope="module")
def model():
    return fit(
        make_dataset(seed=8, n_demos=5), LAYOUT, Settings(n_basis=7, noise_std={"head": 0.1})
    )


def test_model_round_trip_is_exact(model, tmp_path: Path) -> None:
    path = tmp_path / "model.json"
    save_model(path, model)
    loaded = load_model(path)
    assert loaded.layout == model.layout
    assert loaded.settings == model.settings
    assert loaded.sample_period == model.sample_period
    for a, b in zip(model.primitives, loaded.primitives, strict=True):
        assert a.name == b.name
        assert_array_equal(a.shrinkage, b.shrinkage)
        for field in (
            "mean",
            "cov_diag",
            "cov_factor",
            "noise_var",
            "noise_tau",
            "alphas",
            "alpha_slope",
        ):
            assert_array_equal(getattr(a, field), getattr(b, field))
        assert sorted(a.stillness) == sorted(b.stillness) == ["hand", "head"]
        for name, parts in a.stillness.items():
            assert sorted(parts) == ["lead", "pause", "trail"]
            for part, value in parts.items():
                assert_array_equal(value, b.stillness[name][part])
        assert a.log_alpha_mean == b.log_alpha_mean
        for name, am in a.alpha_models.items():
            for key, value in am.to_arrays().items():
                assert_array_equal(value, b.alpha_models[name].to_arrays()[key])
    # The same inference (to rounding: BLAS may take another path for another memory layout).
    demo = make_dataset(seed=9, n_demos=1)["left"][0]
    obs = Observation.from_demo(model, demo, 40, ["head"])
    r1, r2 = recognise(model, obs), recognise(loaded, obs)
    assert r1.primitive == r2.primitive and r1.alpha == r2.alpha
    assert_allclose(r1.probabilities, r2.probabilities, rtol=1e-9)
    p1 = predict(model, condition(model, model.primitives[0], obs, r1.alpha), r1.alpha)
    p2 = predict(loaded, condition(loaded, loaded.primitives[0], obs, r2.alpha), r2.alpha)
    assert_allclose(p1.mean, p2.mean, rtol=1e-9, atol=1e-15)


def test_how_the_demonstrations_are_still_is_kept_in_the_file(tmp_path: Path) -> None:
    """A demonstration that holds still for 0.8 s halfway: its primitive's pause, per modality
    in m or rad (the hold less what the speed's window smears into it: at most SMOOTH_S);
    saved and loaded as learned."""
    from promp.data import Demonstration
    from promp.stillness import SMOOTH_S

    data = make_dataset(seed=8, n_demos=4)
    demo = data["left"][0]
    k = demo.n_samples // 2
    step = float(np.median(np.diff(demo.times)))
    hold = int(round(0.8 / step))
    times = np.concatenate([demo.times[:k], demo.times[k - 1] + step * np.arange(1, hold + 1),
                            demo.times[k:] + hold * step])  # fmt: skip
    values = np.vstack([demo.values[:k], np.repeat(demo.values[k - 1:k], hold, axis=0),
                        demo.values[k:]])  # fmt: skip
    data["left"][0] = Demonstration(times, values, demo.columns, demo.name)
    model = fit(data, LAYOUT, Settings(n_basis=7, noise_std={"head": 0.1}))
    left, right = model.primitives
    pauses = left.stillness["hand"]["pause"]
    held = int(np.argmax(pauses))  # the fit takes the demonstrations in content-key order
    assert 0.8 - SMOOTH_S <= pauses[held] <= 0.8 and np.sum(pauses >= 0.5) == 1
    assert left.pause(["hand", "head"]) == pytest.approx(pauses[held], abs=0.3)
    assert right.pause(["hand"]) < 0.5
    path = tmp_path / "model.json"
    save_model(path, model)
    assert_array_equal(load_model(path).primitives[0].stillness["hand"]["pause"], pauses)


def _mutated(model, change) -> dict:
    data = json.loads(json.dumps(model_to_dict(model)))
    change(data)
    return data


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d.update(version=6), "unsupported model version 6"),
        (lambda d: d["primitives"][0].update(residuals=[[0.0]]), r"residuals: expected shape"),
        (lambda d: d["primitives"][0]["residuals"][0].__setitem__(0, float("nan")), "NaN"),
        (lambda d: d["settings"].update(recognition="mixture:2"), "0 < H <= 1"),
        (lambda d: d["settings"].update(recognition="gmm"), "recognition must be"),
        (lambda d: (d["settings"].update(recognition="mixture:0.5"),
                    d["primitives"][1].update(residuals=None)), "needs every primitive's"),
        (lambda d: d["primitives"][0]["stillness"]["hand"].update(pause=[0.1]),
         r"stillness 'hand' pause.*shape"),
        (lambda d: d["primitives"][0]["stillness"]["hand"]["lead"].__setitem__(0, -1.0),
         "must be >= 0"),
        (lambda d: d["primitives"][0]["stillness"]["hand"].pop("trail"), "missing field 'trail'"),
        (lambda d: d["primitives"][0]["stillness"].update(emg={}), "not a modality in m"),
        (lambda d: d["primitives"][0].update(stillness=[1]), "stillness: expected an object"),
        (lambda d: d.update(report=[1]), "'report' must be a JSON object"),
        (lambda d: d.update(format="something"), "not a model file"),
        (lambda d: d.pop("layout"), "missing field 'layout'"),
        (lambda d: d["primitives"][0].update(mean=[1.0, 2.0]), r"mean: expected shape \(42,\)"),
        (lambda d: d["primitives"][0]["cov_diag"].__setitem__(0, float("nan")), "NaN"),
        (lambda d: d["primitives"][0]["cov_diag"].__setitem__(0, -1.0), "must be positive"),
        (lambda d: d["primitives"][0].update(alphas=[]), "alphas"),
        (lambda d: d["primitives"][0]["alpha_models"].pop("head"), "missing field 'head'"),
        (lambda d: d.update(primitives=[]), "non-empty list"),
        (lambda d: d["primitives"].append(d["primitives"][0]), "duplicate primitive"),
        (lambda d: d.update(sample_period=0), "sample_period must be positive"),
        (lambda d: d["settings"].update(n_basis=1), "n_basis"),
        (lambda d: d["primitives"][1].update(noise_var="abc"), "not an array of numbers"),
    ],
)
def test_loading_rejects_bad_models(model, change, message) -> None:
    with pytest.raises(ValueError, match=message):
        model_from_dict(_mutated(model, change))


def test_loading_rejects_non_json_and_non_objects(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="not valid JSON"):
        model_from_json(b"\x89PNG garbage")
    with pytest.raises(ValueError, match="JSON object"):
        model_from_json("[1, 2, 3]")
    missing = tmp_path / "missing.json"
    with pytest.raises(ValueError, match="missing.json"):
        load_model(missing)


def test_npz_demo_round_trip_is_exact() -> None:
    demo = make_dataset(seed=1, n_demos=1)["left"][0]
    back = demo_from_npz_bytes(demo_to_npz_bytes(demo))
    assert_array_equal(back.times, demo.times)
    assert_array_equal(back.values, demo.values)
    assert back.columns == demo.columns and back.name == demo.name


def test_npz_never_unpickles() -> None:
    buffer = io.BytesIO()
    np.savez(
        buffer,
        times=np.arange(3.0),
        values=np.zeros((3, 1)),
        columns=np.array([{"evil": 1}], dtype=object),
    )
    with pytest.raises(ValueError, match="object arrays are refused"):
        demo_from_npz_bytes(buffer.getvalue())
    with pytest.raises(ValueError, match="not an NPZ"):
        demo_from_npz_bytes(b"definitely not a zip")
    buffer = io.BytesIO()
    np.savez(buffer, times=np.arange(3.0))
    with pytest.raises(ValueError, match="lacks"):
        demo_from_npz_bytes(buffer.getvalue())
