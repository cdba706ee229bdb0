"""The model file format (promp/io.py): versioned, and every file an earlier writer wrote
loads as that writer meant it.

``tests/data/model_format/`` holds one small model written by the code of each commit that
changed the format (see its README), and the prior trajectory that code predicted from it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.evidence.pipeline import infer
from promp.inference import predict
from promp.io import MODEL_VERSION, READABLE_VERSIONS, load_model, model_to_dict, save_model
from promp.observation import Observation

FOLDER = Path(__file__).parent / "data" / "model_format"
FILES = sorted(p for p in FOLDER.glob("v*.json") if not p.name.endswith(".prior.json"))


def test_there_is_a_file_of_every_readable_version_and_of_the_current_writer() -> None:
    versions = {json.loads(p.read_text())["version"] for p in FILES}
    assert versions == set(READABLE_VERSIONS)
    assert MODEL_VERSION == max(READABLE_VERSIONS)
    assert len(FILES) == 9  # the nine writers of the README: none may go missing


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_a_file_of_each_writer_predicts_the_prior_its_writer_predicted(path: Path) -> None:
    """The mean, the covariance, the basis, the time modulation and the layout read as the
    writer meant them: the prior trajectory of every primitive at a speed off its mean is the
    one the writer's own code predicted from the file."""
    model = load_model(path)
    expected = json.loads(path.with_suffix(".prior.json").read_text())
    assert sorted(expected) == sorted(model.names)
    for primitive in model.primitives:
        want = expected[primitive.name]
        prior = predict(model, primitive, want["alpha"], n_points=len(want["times"]))
        assert_allclose(prior.times, want["times"], rtol=1e-12)
        assert_allclose(prior.mean, want["mean"], rtol=1e-9, atol=1e-12)
        assert_allclose(prior.std, want["std"], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_a_model_of_any_version_infers_and_is_written_in_the_current_version(
    path: Path, tmp_path: Path
) -> None:
    """An old file is a whole model: it recognises, conditions and predicts (both speed
    rules), and saving it writes the current version, which loads back the same."""
    model = load_model(path)
    primitive = model.primitives[1]
    mean = predict(model, primitive, float(np.exp(primitive.log_alpha_mean)), n_points=13)
    obs = Observation(mean.times[:6], mean.mean[:6], ("hand",))
    for alpha_method in ("ml", "model"):
        result = infer(model, obs, alpha_method=alpha_method)
        assert result.primitive == primitive.name
        assert_allclose(result.probabilities.sum(), 1.0, rtol=1e-12)
        assert np.all(np.isfinite(result.prediction.mean))
    assert model_to_dict(model)["version"] == MODEL_VERSION
    again = tmp_path / "again.json"
    save_model(again, model)
    reloaded = load_model(again)
    for a, b in zip(model.primitives, reloaded.primitives, strict=True):
        assert_allclose(b.cov, a.cov, rtol=1e-15, atol=0)


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_a_file_before_version_3_learned_no_pause_and_its_movements_end_as_before(
    path: Path,
) -> None:
    """Version 3 keeps how each primitive's demonstrations are still; an older file has
    nothing of it, and a live session on it cuts movements as before this was learned (ended
    after MIN_STILL_S of stillness, MARGIN_S kept on each side)."""
    from promp.live.segmenter import Segmenter, StillRule
    from promp.stillness import MARGIN_S, MIN_STILL_S

    model = load_model(path)
    version = json.loads(path.read_text())["version"]
    for primitive in model.primitives:
        assert (primitive.stillness == {}) == (version < 3)
        assert primitive.pause(["hand"]) == 0.0
    rule = StillRule.of(model, ["hand"])
    segmenter = Segmenter("still", 3, [(slice(0, 3), "m")], rule=rule)
    assert segmenter.allowed_pause() == MIN_STILL_S
    if version < 3:
        assert (rule.before, rule.after) == (MARGIN_S, MARGIN_S)


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_a_file_before_version_4_has_no_calibrated_region(path: Path) -> None:
    """Version 4 keeps each primitive's region factor per modality; an older file has none
    (its regions are the Gaussian's, as its writer drew them)."""
    model = load_model(path)
    version = json.loads(path.read_text())["version"]
    for primitive in model.primitives:
        assert (primitive.region_scale == {}) == (version < 4)
        assert all(c > 0 for c in primitive.region_scale.values())
