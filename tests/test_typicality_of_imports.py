"""Imported demonstrations are scored for typicality like taught takes, once, and every score
stays with its workspace: in studio.json, through a restart, an export and an import. The
command line that imports a dataset prints the checks' findings of its bad takes, in units.
(Before: an imported dataset's demonstrations had no score at all, and a take's score was
gone when the studio restarted.)"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from app.cli import build_parser, prepare_workspace
from app.core.session import Session
from app.core.store_state import workspace_data
from app.io.dataset_import import extract_dataset_zip
from app.io.exchange import read_upload, workspace_zip
from tests.bad_takes import BAD, write_bad_takes
from tests.conftest import FITS, wait_until
from tests.test_dataset_import import zip_folder


def scored(session: Session, timeout: float = 240.0) -> dict:
    """The session's scores once no demonstration waits for one."""
    wait_until(lambda: not session.store.state.checks.scores.pending, timeout=timeout,
               what=lambda: f"the scores of {sorted(session.store.state.checks.scores.pending)}")
    return dict(session.snapshot().typicality)


def imported(tmp_path: Path) -> Session:
    """A session that has imported the bad takes as the Data tab does, into
    ``tmp_path / "imported"``."""
    upload = extract_dataset_zip(zip_folder(write_bad_takes(tmp_path / "recordings")), "r.zip")
    try:
        data, _ = upload.read()
    finally:
        upload.close()
    session = Session.open(tmp_path / "ws", fits=FITS)
    session.store.switch(tmp_path / "imported", data)
    return session


def every_key(session: Session) -> set:
    return {(p, d.name) for p, items in session.store.state.demos.items() for d in items}


def test_an_imported_dataset_is_scored_and_keeps_its_scores(tmp_path, capsys) -> None:
    source = write_bad_takes(tmp_path / "recordings")
    new = tmp_path / "workspace"
    prepare_workspace(build_parser().parse_args(
        ["--workspace", str(new), "--import-dataset", str(source)]))  # fmt: skip
    printed = capsys.readouterr().out
    # the command line names each bad take and says what is wrong, in centimetres
    assert "Checks: 5 finding(s) in 3 demonstration(s)" in printed
    for primitive, demo in BAD:
        assert f"{primitive}/{demo}.csv: hand " in printed
    assert "a round trip" in printed and " cm from where it started" in printed
    assert "hand starts 7." in printed and " cm from where base_to_front_goal's other" in printed
    index = json.loads((new / "studio.json").read_text())
    assert len(index["checks"]["typicality"]["pending"]) == 30  # to score, all of them

    session = Session.open(new, fits=FITS)
    scores = scored(session)
    assert set(scores) == every_key(session)  # every one, the flagged ones too
    for key in BAD:  # left out of learning, scored against the others: unlike all of them
        assert scores[key].label == "outlier", (key, scores[key])
    kept = json.loads((new / "studio.json").read_text())["checks"]["typicality"]
    assert kept["pending"] == [] and len(kept["given"]) == 30
    session.close()

    again = Session.open(new, fits=FITS)  # a restart scores nothing anew
    assert dict(again.snapshot().typicality) == scores and not again.learner.state.scores
    archive = workspace_zip(workspace_data(again.store.state), again.snapshot().model)
    again.close()
    upload = read_upload("workspace.zip", archive)
    assert dict(upload.data.checks.scores.given) == scores
    other = Session.open(tmp_path / "other", fits=FITS)
    other.store.replace(upload.data, "replaced by workspace.zip")
    assert dict(other.snapshot().typicality) == scores
    assert not other.store.state.checks.scores.pending
    other.close()


def test_a_dataset_imported_in_the_data_tab_is_scored(tmp_path) -> None:
    """The Data tab reads an uploaded zip (app.io.dataset_import) and switches to the new
    workspace (Store.switch): what it writes waits for its scores, which then come."""
    source = write_bad_takes(tmp_path / "recordings")
    upload = extract_dataset_zip(zip_folder(source, "recordings/"), "recordings.zip")
    try:
        data, summary = upload.read()
    finally:
        upload.close()
    assert {f.key for f in summary.findings} == BAD
    assert data.checks.scores.pending == {(p, d.name) for p, ds in data.demos.items() for d in ds}
    session = Session.open(tmp_path / "current", fits=FITS)
    session.store.switch(tmp_path / "imported", data)
    scores = scored(session)
    assert set(scores) == every_key(session)
    assert json.loads((tmp_path / "imported" / "studio.json").read_text())[
        "checks"]["typicality"]["pending"] == []  # fmt: skip
    session.close()


def test_a_takes_score_stays_and_a_new_take_under_a_deleted_name_is_scored_anew(tmp_path):
    session = imported(tmp_path)
    before = scored(session)
    store = session.store
    top = store.state.demos["base_to_top_goal"]
    take = store.add_demo("base_to_top_goal", top[3].times, top[3].values)
    key = ("base_to_top_goal", take.name)
    assert key in store.state.checks.scores.pending  # to score, until the learner has
    score = scored(session)[key]
    # deleted (its score kept for Undo), then a new take takes its name: scored anew
    store.delete_demo(*key)
    assert store.state.checks.scores.given[key] == score
    values = top[5].values + np.array([0.0, 0.08, 0.0, 0.0, 0.0, 0.0])  # 8 cm aside
    again = store.add_demo("base_to_top_goal", top[5].times, values)
    assert again.name == take.name and key not in store.state.checks.scores.given
    fresh = scored(session)[key]
    assert fresh != score and fresh.label == "outlier"
    session.close()
    reopened = Session.open(tmp_path / "imported", fits=FITS)
    assert dict(reopened.snapshot().typicality) == {**before, key: fresh}
    reopened.close()


@pytest.mark.parametrize("entry", [
    {"given": [{"primitive": "a", "demo": "d", "score": 0.1, "percentile": -1}]},
    {"given": [{"primitive": "a", "score": 0.1, "percentile": 0.5}]},
    {"pending": [["a"]]},
    [],
])  # fmt: skip
def test_a_workspace_index_with_malformed_scores_is_refused(tmp_path, entry) -> None:
    from app.io.workspace_index import check_index, index_json

    index = json.loads(index_json([], {}))
    index["checks"] = {"typicality": entry}
    with pytest.raises(ValueError, match=r"^studio\.json: .*typicality"):
        check_index(index, "studio.json")


def test_the_scores_follow_a_renamed_primitive(tmp_path: Path) -> None:
    session = imported(tmp_path)
    before = scored(session)
    session.store.rename_primitive("base_to_top_goal", "reach_up")
    renamed = {("reach_up" if p == "base_to_top_goal" else p, d): s
               for (p, d), s in before.items()}  # fmt: skip
    assert dict(session.snapshot().typicality) == renamed
    session.close()
    reopened = Session.open(tmp_path / "imported", fits=FITS)  # as the workspace keeps them
    assert dict(reopened.snapshot().typicality) == renamed
    reopened.close()
