"""bench/live.py's paired run gives its baseline the model it can read: the same file where the
baseline's code reads this version (the pair then times the code, not two models), the
version-2 file only for a baseline that reads no later one."""

from __future__ import annotations

from pathlib import Path

from bench.live import baseline_model
from promp.io import MODEL_VERSION, model_to_dict
from promp.learn import fit
from promp.model import Settings
from tests.synthetic import LAYOUT, make_dataset

GIVEN = Settings(n_basis=6, width=1.0, noise_scale=1.5, duration_temperature=1.0,
                 recognition="promp")  # fmt: skip


def _repo(tmp_path: Path, readable: str) -> Path:
    (tmp_path / "promp").mkdir()
    (tmp_path / "promp" / "io.py").write_text(f"READABLE_VERSIONS = {readable}\n")
    return tmp_path


def test_a_baseline_that_reads_this_version_gets_the_same_model(tmp_path: Path) -> None:
    model = fit(make_dataset(seed=1, n_demos=4), LAYOUT, GIVEN)
    versions = "(" + ", ".join(str(v) for v in range(1, MODEL_VERSION + 1)) + ")"
    assert baseline_model(model, _repo(tmp_path, versions)) == model_to_dict(model)


def test_an_older_baseline_gets_the_version_2_file(tmp_path: Path) -> None:
    model = fit(make_dataset(seed=1, n_demos=4), LAYOUT, GIVEN)
    data = baseline_model(model, _repo(tmp_path, "(1, 2)"))
    assert data["version"] == 2
    assert all("stillness" not in p for p in data["primitives"])
