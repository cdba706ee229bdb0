"""The studio's session: every mutation is on disk before it is in memory, a refused one changes
nothing, reopening restores the session exactly, typicality flags outliers, the learning
settings (shrinkage included) refit and persist, concurrent mutations stay consistent, a
folder that is not a workspace is refused byte for byte untouched, and what is deleted or
replaced comes back from the trash."""

from __future__ import annotations

import hashlib
import shutil
import threading

import numpy as np
import pytest

from app.core.session import Session
from app.io.workspace import Workspace, WorkspaceData
from app.io.workspace_index import PrimitiveEntry
from app.studio import default_workspace
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT

COLUMNS = LAYOUT.columns


@pytest.fixture(scope="module")
def default_folder(tmp_path_factory):
    """The default scenario written once (copied by each test)."""
    root = tmp_path_factory.mktemp("default") / "ws"
    Workspace.create(root, default_workspace())
    return root


@pytest.fixture
def session(default_folder, tmp_path) -> Session:
    root = tmp_path / "ws"
    shutil.copytree(default_folder, root)
    return Session.open(root)


def files(session: Session) -> dict[str, bytes]:
    root = session.workspace.root
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def assert_same_state(a: Session, b: Session) -> None:
    assert a.primitives == b.primitives
    assert a.settings == b.settings
    assert a.demos.keys() == b.demos.keys()
    for name in a.demos:
        assert [d.name for d in a.demos[name]] == [d.name for d in b.demos[name]]
        for x, y in zip(a.demos[name], b.demos[name], strict=True):
            np.testing.assert_array_equal(x.times, y.times)
            np.testing.assert_array_equal(x.select(COLUMNS), y.select(COLUMNS))


def test_an_empty_workspace_opens_on_the_default_scenario(tmp_path) -> None:
    session = Session.open(tmp_path / "ws", default=default_workspace)
    assert session.names() == ["curved", "direct"]
    assert [len(session.demos[n]) for n in session.names()] == [20, 20]
    assert session.model is not None and session.model.names == ("curved", "direct")
    assert session.fit_error is None and session.fit_ms > 0


def test_every_mutation_is_on_disk_and_reopening_restores_it_exactly(session) -> None:
    demo = session.demos["curved"][3]
    session.create_primitive("lift", (1, 2, 3))
    session.add_demo("lift", demo.times + 5.0, demo.select(COLUMNS))
    session.add_demo("lift", demo.times, demo.select(COLUMNS) + 0.01)
    session.rename_primitive("lift", "lift_2")
    session.recolor_primitive("lift_2", (9, 8, 7))
    session.delete_demo("curved", "curved_005")
    session.delete_primitive("direct")
    session.set_learning(12, 1.25, shrinkage=0.1)
    reopened = Session.open(session.workspace.root)
    assert_same_state(session, reopened)
    assert reopened.names() == ["curved", "lift_2"]
    assert reopened.color("lift_2") == (9, 8, 7)
    assert [d.name for d in reopened.demos["lift_2"]] == ["lift_000", "lift_001"]  # files kept
    assert reopened.demos["lift_2"][0].times[0] == 0.0  # times start at the first sample
    assert "curved_005" not in {d.name for d in reopened.demos["curved"]}
    assert not session.workspace.demo_dir("direct").exists()
    kinds = [e.kind for e in reopened.trash_entries()]
    assert kinds == ["primitive", "demo"]  # both deletions kept, newest first
    assert reopened.learning_settings().shrinkage == 0.1
    np.testing.assert_allclose(reopened.model.primitive("curved").shrinkage, 0.1)


@pytest.mark.parametrize(
    "mutation, message",
    [
        (lambda s: s.create_primitive("curved"), "already exists"),
        (lambda s: s.create_primitive("a/b"), "invalid primitive name"),
        (lambda s: s.create_primitive("ok", (0, 0, 300)), "0-255"),
        (lambda s: s.rename_primitive("curved", "direct"), "already exists"),
        (lambda s: s.rename_primitive("nope", "x"), "unknown primitive"),
        (lambda s: s.recolor_primitive("curved", (1, 2)), "three integers"),
        (lambda s: s.delete_primitive("nope"), "unknown primitive"),
        (lambda s: s.delete_demo("curved", "direct_000"), "no demonstration 'direct_000'"),
        (lambda s: s.add_demo("nope", np.arange(3.0), np.zeros((3, 6))), "unknown primitive"),
        (lambda s: s.add_demo("curved", np.arange(3.0), np.zeros((3, 5))), "column"),
        (lambda s: s.set_learning(0, 1.0), "n_basis"),
        (lambda s: s.set_learning(10, 1.0, shrinkage=0.0), "shrinkage"),
        (lambda s: s.set_learning(10, 1.0, shrinkage=1.5), "shrinkage"),
    ],
)
def test_a_refused_mutation_changes_nothing(session, mutation, message) -> None:
    before_files, before_version = files(session), session.version
    before_names, before_settings = session.names(), dict(session.settings)
    with pytest.raises(ValueError, match=message):
        mutation(session)
    assert files(session) == before_files
    assert session.version == before_version
    assert session.names() == before_names and session.settings == before_settings


def test_a_failed_write_keeps_the_demonstration_out_of_the_session(session, monkeypatch) -> None:
    demo = session.demos["curved"][0]

    def full_disk(primitive, demo, layout):
        raise OSError("No space left on device")

    monkeypatch.setattr(session.workspace, "write_demo", full_disk)
    with pytest.raises(OSError, match="No space"):
        session.add_demo("curved", demo.times, demo.select(COLUMNS))
    assert len(session.demos["curved"]) == 20


def test_typicality_flags_an_outlier_and_not_a_typical_demonstration(session) -> None:
    rng = np.random.default_rng(1)
    typical = session.demos["curved"][7]
    values = typical.select(COLUMNS).copy()  # the head angles re-measured (0.5 deg noise);
    values[:, 3:] += rng.normal(scale=np.radians(0.5), size=(len(values), 3))  # the hand is exact
    normal = session.add_demo("curved", typical.times, values)
    odd = session.demos["direct"][2]  # a direct movement filed under curved
    outlier = session.add_demo("curved", odd.times, odd.select(COLUMNS))
    good, bad = (
        session.typicality[("curved", normal.name)],
        session.typicality[("curved", outlier.name)],
    )
    assert good.label == "typical" and good.percentile > 0.2
    assert bad.label == "outlier" and bad.percentile < 0.05
    assert bad.score < good.score


def test_typicality_needs_three_other_demonstrations(session) -> None:
    session.create_primitive("new")
    demo = session.demos["curved"][0]
    for _ in range(4):
        session.add_demo("new", demo.times, demo.select(COLUMNS))
    scored = [d.name for d in session.demos["new"] if ("new", d.name) in session.typicality]
    assert scored == ["new_003"]


def test_hiding_redraws_without_refitting_and_listeners_hear_every_change(session) -> None:
    heard = []
    session.on_change(lambda: heard.append(session.version))
    model = session.model
    session.set_hidden("curved", "curved_000", True)
    assert session.model is model and ("curved", "curved_000") in session.hidden
    session.set_hidden("curved", "curved_000", False)
    session.set_learning(8, 1.0)
    session.wait_for_model()
    assert session.model is not model and session.model.basis.n_basis == 8
    assert heard == [1, 2, 3]


def test_shrinkage_settings(session) -> None:
    # The default workspace starts on the engine's defaults (automatic covariance prior).
    assert session.settings == {}
    assert session.model.report["covariance"]["strength"] > 0
    session.set_learning(10, 1.0, shrinkage=1e-6)
    session.wait_for_model()
    np.testing.assert_allclose(session.model.primitive("curved").shrinkage, 1e-6)
    session.set_learning(10, 1.0, shrinkage=None)  # the pooled prior
    assert session.settings["shrinkage"] is None
    session.wait_for_model()
    loo = session.model.primitive("curved").shrinkage
    hand, head = LAYOUT.dims(["hand"]), LAYOUT.dims(["head"])
    assert len(set(loo[hand])) == 1 and len(set(loo[head])) == 1  # one per modality
    session.set_learning(11, 1.0)  # keeps the shrinkage
    assert session.settings["shrinkage"] is None
    session.set_learning(11, 1.0, shrinkage=0.3)
    session.wait_for_model()
    np.testing.assert_allclose(session.model.primitive("direct").shrinkage, 0.3)


def test_automatic_settings_are_chosen_by_the_fit_and_can_be_given_back(session) -> None:
    model = session.wait_for_model()
    chosen = model.report["settings"]["chosen"]
    assert set(chosen) == {"n_basis", "width", "noise_scale"}
    resolved = session.resolved_settings()  # what typicality fits with: no new choice
    assert not resolved.automatic
    assert (resolved.n_basis, resolved.width) == (model.settings.n_basis, model.settings.width)
    session.set_learning(9, 1.2)
    assert session.wait_for_model().settings.n_basis == 9
    assert session.resolved_settings().n_basis == 9
    assert '"n_basis": 9' in session.workspace.index_path.read_text()
    session.set_learning(None, None)  # back to automatic: absent from studio.json
    assert "n_basis" not in session.settings and "width" not in session.settings
    assert '"n_basis"' not in session.workspace.index_path.read_text()
    assert session.wait_for_model().report["settings"]["chosen"] == chosen


def test_primitives_with_fewer_than_two_demonstrations_are_not_learned(session) -> None:
    session.create_primitive("alone")
    demo = session.demos["curved"][0]
    session.add_demo("alone", demo.times, demo.select(COLUMNS))
    assert "alone" not in session.wait_for_model().names
    session.delete_primitive("curved")
    session.delete_primitive("direct")
    session.wait_for_model()
    assert session.model is None and "at least two" in session.fit_error


def test_concurrent_recordings_get_distinct_names_and_files(session) -> None:
    demo = session.demos["curved"][0]
    errors = []

    def record() -> None:
        try:
            session.add_demo("curved", demo.times, demo.select(COLUMNS))
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=record) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    names = [d.name for d in session.demos["curved"]]
    assert len(names) == len(set(names)) == 24
    assert len(list(session.workspace.demo_dir("curved").glob("*.csv"))) == 24


def without_trash(state: dict) -> dict:
    return {k: v for k, v in state.items() if not k.startswith("trash")}


def checksums(root) -> dict[str, str]:
    return {
        p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def test_a_folder_of_recordings_is_refused_and_left_byte_identical(tmp_path, heights_dir) -> None:
    mine = tmp_path / "my_recordings"
    shutil.copytree(heights_dir, mine)
    (mine / "notes").mkdir()
    (mine / "notes" / "session.csv").write_text("t,x,y,z\n0,0,0,0\n1,1,1,1\n")
    before = checksums(mine)
    with pytest.raises(ValueError, match="is not a studio workspace") as info:
        Session.open(mine, default=default_workspace)
    assert f"holds {len(before)} file(s)" in str(info.value)
    assert "--import-dataset" in str(info.value)
    assert checksums(mine) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["my_recordings"]


def test_deleting_and_undoing_restores_the_files_and_the_session(session) -> None:
    before = files(session)
    curved = session.demos["curved"][4]
    entry = session.delete_demo("curved", curved.name)
    assert curved.name not in {d.name for d in session.demos["curved"]}
    session.delete_primitive("direct")
    assert [e.name for e in session.deleted][-1] != entry.name
    session.undo_delete()  # the primitive first
    assert session.names() == ["curved", "direct"] and len(session.demos["direct"]) == 20
    restored = session.undo_delete()
    assert restored.name == entry.name
    assert without_trash(files(session)) == before  # byte for byte
    assert [d.name for d in session.demos["curved"]] == [f"curved_{i:03d}" for i in range(20)]
    session.wait_for_model()
    assert session.model is not None and session.model.names == ("curved", "direct")
    with pytest.raises(ValueError, match="nothing deleted"):
        session.undo_delete()


def test_replacing_and_switching_workspaces(session, tmp_path) -> None:
    before = files(session)
    demo = session.demos["curved"][0]
    data = WorkspaceData(
        primitives=[PrimitiveEntry("wave", (1, 2, 3)), PrimitiveEntry("rest", (3, 2, 1))],
        demos={"wave": session.demos["curved"][:3], "rest": session.demos["direct"][:3]},
        layout=LAYOUT,
    )
    version = session.version
    entry = session.replace(data, "replaced by a test")
    assert session.names() == ["wave", "rest"] and session.version > version
    session.wait_for_model()
    assert session.model.names == ("wave", "rest")
    session.restore(entry.name)
    assert without_trash(files(session)) == before
    old_root = session.workspace.root
    session.switch(tmp_path / "other", data)
    assert session.workspace.root == tmp_path / "other" and session.names() == ["wave", "rest"]
    assert session.deleted == []
    assert without_trash(files(Session.open(old_root))) == before
    with pytest.raises(ValueError, match="already a studio workspace"):
        session.switch(old_root, data)
    session.add_demo("wave", demo.times, demo.select(COLUMNS))
    assert (tmp_path / "other" / "demos" / "wave" / "wave_003.csv").exists()


def test_refits_run_in_the_background_and_only_the_latest_is_adopted(session, monkeypatch):
    """A change returns at once; the previous model stays in use until the refit of the latest
    change is done; a refit superseded while it ran is never adopted."""
    import app.core.session as module

    real, learned = module.learn, []
    started, release = threading.Event(), threading.Event()

    def gated(training, reuse=True):
        result = real(training, reuse)
        learned.append(training.settings.n_basis)
        if training.settings.n_basis == 8:
            started.set()
            release.wait(60)
        return result

    monkeypatch.setattr(module, "learn", gated)
    before, version = session.model, session.version
    session.set_learning(8, 1.0)
    assert started.wait(60), "the refit did not start"
    assert session.model is before and session.refitting  # the previous model meanwhile
    session.set_learning(9, 1.0)  # supersedes the refit in flight
    release.set()
    model = session.wait_for_model()
    assert model.basis.n_basis == 9 and session.model is model and not session.refitting
    assert learned == [8, 9]  # the first ran to its end, and was dropped
    assert session.version == version + 3  # two changes, one model adopted
    session.close()


def _with_a_gap(demo, name: str):
    """``demo`` with a 20 s pause of the timestamps after its middle sample."""
    from promp.data import Demonstration

    times = demo.times.copy()
    times[demo.n_samples // 2 :] += 20.0
    return Demonstration(times, demo.select(COLUMNS), COLUMNS, name=name)


def test_a_flagged_demonstration_is_left_out_until_kept_and_the_choice_persists(session) -> None:
    gap = _with_a_gap(session.demos["curved"][3], "gap")
    added = session.add_demo("curved", gap.times, gap.select(COLUMNS))
    key = ("curved", added.name)
    (finding,) = session.findings_of(*key)
    assert finding.kind == "gap" and finding.file == f"demos/curved/{added.name}.csv"
    assert list(session.left_out()) == [key]
    model = session.wait_for_model()
    assert model.primitive("curved").n_demos == 20  # learned without it
    assert key in session.typicality  # scored against the others that are learned from
    path = session.workspace.demo_path(*key)
    before = path.read_bytes()
    session.set_kept(*key, True)
    assert session.left_out() == {} and session.wait_for_model().primitive("curved").n_demos == 21
    reopened = Session.open(session.workspace.root)
    assert reopened.checks.kept == {key} and reopened.left_out() == {}
    session.rename_primitive("curved", "arc")
    assert session.checks.kept == {("arc", added.name)} and session.left_out() == {}
    session.set_kept("arc", added.name, False)
    assert list(session.left_out()) == [("arc", added.name)]
    assert session.workspace.demo_path("arc", added.name).read_bytes() == before  # untouched
    with pytest.raises(ValueError, match="has no demonstration"):
        session.set_kept("arc", "nowhere", True)


def test_an_imports_timestamp_findings_travel_with_the_workspace(tmp_path) -> None:
    from app.io.dataset_import import read_folder
    from promp.datasets import write_csv_dataset
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=1, n_demos=4)
    write_csv_dataset(tmp_path / "data", dataset)
    path = tmp_path / "data" / "direct" / f"{dataset['direct'][1].name}.csv"
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:5] + [lines[4]] + lines[5:]) + "\n")  # a repeated sample
    data, summary = read_folder(tmp_path / "data", "csv")
    assert "timestamps not increasing" in " ".join(summary.findings_lines())
    Workspace.create(tmp_path / "ws", data)
    session = Session.open(tmp_path / "ws")
    key = ("direct", data.demos["direct"][1].name)
    assert [f.kind for f in session.findings_of(*key)] == ["timestamps"]
    assert list(session.left_out()) == [key]
    assert session.wait_for_model().primitive("direct").n_demos == 3


def test_a_repaired_gap_makes_new_demonstrations_and_overwrites_nothing(session) -> None:
    gap = _with_a_gap(session.demos["direct"][1], "gap")
    added = session.add_demo("direct", gap.times, gap.select(COLUMNS))
    folder = session.workspace.demo_dir("direct")
    squatter = folder / f"{added.name}-cut.csv"
    squatter.write_text("not a demonstration\n")  # a file the session could not read
    before = session.workspace.demo_path("direct", added.name).read_bytes()
    (cut,) = session.repair_gap("direct", added.name, "cut")
    assert cut.name == f"{added.name}-cut-2" and squatter.read_text() == "not a demonstration\n"
    assert cut.n_samples == gap.n_samples // 2
    assert session.workspace.demo_path("direct", added.name).read_bytes() == before
    assert [f.kind for f in session.findings_of("direct", cut.name)] == []
    with pytest.raises(ValueError, match="has no gap"):
        session.repair_gap("direct", cut.name, "split")
