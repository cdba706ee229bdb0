"""``python -m promp.evaluate ... --rerun FILE.rrd --mcap FILE.mcap``: every trial of the sweep
read back with Rerun's and the mcap package's readers holds the evaluation's own numbers (its
--json report's trials), at its own path, on the observed-percent timeline; a file that cannot
be written is refused before the sweep."""

from __future__ import annotations

import json
import re

import pytest
from numpy.testing import assert_allclose

from promp.datasets import write_csv_dataset
from promp.evaluate.cli import main
from promp.timing import n_observed_for
from tests.synthetic import make_dataset
from tests.viewer_readers import json_series, points, read_mcap, read_rrd, scene_entities

PERCENTS = (20, 60)
ARGS = ["--format", "csv", "--modality", "hand=x,y,z", "--modality", "head=roll,pitch,yaw",
        "--percent", *map(str, PERCENTS), "--alpha", "ml", "model", "--jobs", "1",
        "--basis", "7", "--width", "1", "--noise-scale", "1.5"]  # fmt: skip


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("evaluate_viewers")
    dataset = make_dataset(seed=2, n_demos=4)
    write_csv_dataset(folder / "data", dataset)
    files = {name: folder / name for name in ("out.json", "trials.rrd", "trials.mcap")}
    code = main([str(folder / "data"), *ARGS, "--json", str(files["out.json"]),
                 "--rerun", str(files["trials.rrd"]), "--mcap", str(files["trials.mcap"])])
    assert code == 0
    report = json.loads(files["out.json"].read_text())
    return dataset, report, read_rrd(files["trials.rrd"]), read_mcap(files["trials.mcap"])


def _path(trial: dict) -> str:
    return f"trials/ours/hand/{trial['alpha_method']}/{trial['primitive']}/{trial['demo']}"


def test_every_trial_has_its_path_and_the_evaluation_s_probabilities(run) -> None:
    _, report, entities, (messages, _) = run
    names = report["primitives"]
    trials = report["trials"]
    assert len(trials) == 8 * 2 * len(PERCENTS)  # demonstrations x alpha methods x percents
    paths = {_path(t) for t in trials}
    assert {e.rsplit("/", 1)[0] for e in entities if e.endswith("/truth")} == paths
    for trial in trials:
        prefix, percent = _path(trial), int(trial["percent"])
        got = {}
        for name in names:
            times, values = entities[f"{prefix}/p/{name}"].series("observed_percent")
            assert list(times) == list(PERCENTS)
            m_times, m_values = json_series(messages, f"/{prefix}/p/{name}", "observed_percent")
            assert list(m_times) == list(PERCENTS)
            assert_allclose(m_values, values, rtol=0, atol=0)  # the same numbers in both files
            got[name] = values[PERCENTS.index(percent)]
        assert got[trial["primitive"]] == pytest.approx(trial["p_true"], rel=1e-12)
        assert max(got, key=got.get) == trial["recognised"]


def test_each_percent_shows_what_was_observed_and_the_prediction(run) -> None:
    dataset, report, entities, (messages, _) = run
    scene = scene_entities(messages)
    demos = {(p, d.name): d for p, items in dataset.items() for d in items}
    for trial in report["trials"]:
        prefix, percent = _path(trial), int(trial["percent"])
        demo = demos[(trial["primitive"], trial["demo"])]
        observed = entities[f"{prefix}/observed"].at("observed_percent", percent)
        [strip] = observed["LineStrips3D:strips"]
        want = demo.values[: n_observed_for(percent, demo.n_samples), :3]
        assert_allclose(strip, want, rtol=1e-6, atol=1e-7)
        predicted = entities[f"{prefix}/predicted"].at("observed_percent", percent)
        end = entities[f"{prefix}/end"].at("observed_percent", percent)
        assert_allclose(end["Points3D:positions"], predicted["LineStrips3D:strips"][0][-1:])
        region = entities[f"{prefix}/region"].at("observed_percent", percent)
        assert_allclose(region["Ellipsoids3D:centers"][0], predicted["LineStrips3D:strips"][0][0],
                        atol=1e-7)  # fmt: skip
        # MCAP: the same strip at that percent, stamped at that many seconds
        (at, entity), = [(t, e) for t, e in scene[f"{prefix}/observed"]
                         if t == percent * 1_000_000_000]  # fmt: skip
        assert_allclose(points(entity.lines[0].points), strip, rtol=1e-6)


def test_a_file_that_cannot_be_written_is_refused_before_the_sweep(tmp_path, capsys) -> None:
    write_csv_dataset(tmp_path / "data", make_dataset(seed=2, n_demos=3))
    (tmp_path / "old.rrd").write_bytes(b"mine")
    for extra, message in (
        (["--rerun", str(tmp_path / "old.rrd")], "already exists"),
        (["--mcap", str(tmp_path / "out.rrd")], r"\.mcap"),
        (["--rerun", str(tmp_path / "new.rrd"), "--percent", "12.5"], "whole percents"),
    ):
        assert main([str(tmp_path / "data"), *ARGS, *extra]) == 2
        err = capsys.readouterr().err
        assert "error:" in err and re.search(message, err), err
        assert "leave-one-out" not in err  # no sweep was started
    assert (tmp_path / "old.rrd").read_bytes() == b"mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data", "old.rrd"]
