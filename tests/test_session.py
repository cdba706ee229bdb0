"""The studio's session (store, learner, view state): every mutation is on disk before it is in
the store's state, a refused one changes nothing, reopening restores the workspace exactly,
typicality (scored by the learner, in the background) flags outliers, the learning settings
(shrinkage included) refit and persist, concurrent mutations stay consistent, a folder that is
not a workspace is refused byte for byte untouched, and what is deleted or replaced comes back
from the trash."""

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
from tests.conftest import FITS, PATIENCE_S, wait_until

COLUMNS = LAYOUT.columns


@pytest.fixture(scope="module")
def default_folder(tmp_path_factory):
    """The default scenario written once (copied by each test)."""
    root = tmp_path_factory.mktemp("default") / "ws"
    Workspace.create(root, default_workspace())
    return root


@pytest.fixture
def session(default_folder, tmp_path):
    root = tmp_path / "ws"
    shutil.copytree(default_folder, root)
    session = Session.open(root, fits=FITS)
    yield session
    session.close()


def state(session: Session):
    """The store's state now."""
    return session.store.state


def model(session: Session):
    return session.snapshot().model


def scored(session: Session, key: tuple[str, str]):
    """The typicality of the take ``key`` once the learner has scored it (None: too few
    others)."""
    wait_until(lambda: key not in session.snapshot().scoring, timeout=120, what=f"{key} scored")
    return session.snapshot().typicality.get(key)


def files(session: Session) -> dict[str, bytes]:
    root = session.store.state.workspace.root
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def assert_same_state(session_a: Session, session_b: Session) -> None:
    a, b = state(session_a), state(session_b)
    assert a.primitives == b.primitives
    assert a.settings == b.settings
    assert a.demos.keys() == b.demos.keys()
    for name in a.demos:
        assert [d.name for d in a.demos[name]] == [d.name for d in b.demos[name]]
        for x, y in zip(a.demos[name], b.demos[name], strict=True):
            np.testing.assert_array_equal(x.times, y.times)
            np.testing.assert_array_equal(x.select(COLUMNS), y.select(COLUMNS))


def test_an_empty_workspace_opens_on_the_default_scenario(tmp_path) -> None:
    session = Session.open(tmp_path / "ws", default=default_workspace, fits=FITS)
    assert state(session).names == ("curved", "direct")
    assert [len(state(session).demos[n]) for n in state(session).names] == [20, 20]
    assert model(session) is not None and model(session).names == ("curved", "direct")
    learned = session.learner.state
    assert learned.error is None and learned.fit_ms > 0 and learned.n_demos == 40
    session.close()


def test_every_mutation_is_on_disk_and_reopening_restores_it_exactly(session) -> None:
    store = session.store
    demo = state(session).demos["curved"][3]
    store.create_primitive("lift", (1, 2, 3))
    store.add_demo("lift", demo.times + 5.0, demo.select(COLUMNS))
    store.add_demo("lift", demo.times, demo.select(COLUMNS) + 0.01)
    store.rename_primitive("lift", "lift_2")
    store.recolor_primitive("lift_2", (9, 8, 7))
    store.delete_demo("curved", "curved_005")
    store.delete_primitive("direct")
    store.set_learning(12, 1.25, shrinkage=0.1)
    reopened = Session.open(state(session).workspace.root, fits=FITS)
    assert_same_state(session, reopened)
    again = state(reopened)
    assert again.names == ("curved", "lift_2")
    assert again.color("lift_2") == (9, 8, 7)
    assert [d.name for d in again.demos["lift_2"]] == ["lift_000", "lift_001"]  # files kept
    assert again.demos["lift_2"][0].times[0] == 0.0  # times start at the first sample
    assert "curved_005" not in {d.name for d in again.demos["curved"]}
    assert not state(session).workspace.demo_dir("direct").exists()
    kinds = [e.kind for e in again.trash]
    assert kinds == ["primitive", "demo"]  # both deletions kept, newest first
    assert again.learning_settings().shrinkage == 0.1
    np.testing.assert_allclose(model(reopened).primitive("curved").shrinkage, 0.1)
    reopened.close()


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
    before_files, before = files(session), state(session)
    with pytest.raises(ValueError, match=message):
        mutation(session.store)
    assert files(session) == before_files
    assert state(session) is before  # not even a new state


def test_a_failed_write_keeps_the_demonstration_out_of_the_store(session, monkeypatch) -> None:
    demo = state(session).demos["curved"][0]

    def full_disk(primitive, demo, layout):
        raise OSError("No space left on device")

    monkeypatch.setattr(state(session).workspace, "write_demo", full_disk)
    with pytest.raises(OSError, match="No space"):
        session.store.add_demo("curved", demo.times, demo.select(COLUMNS))
    assert len(state(session).demos["curved"]) == 20


def test_typicality_flags_an_outlier_and_not_a_typical_demonstration(session) -> None:
    rng = np.random.default_rng(1)
    typical = state(session).demos["curved"][7]
    values = typical.select(COLUMNS).copy()  # the head angles re-measured (0.5 deg noise);
    values[:, 3:] += rng.normal(scale=np.radians(0.5), size=(len(values), 3))  # the hand is exact
    normal = session.store.add_demo("curved", typical.times, values)
    odd = state(session).demos["direct"][2]  # a direct movement filed under curved
    outlier = session.store.add_demo("curved", odd.times, odd.select(COLUMNS))
    good, bad = scored(session, ("curved", normal.name)), scored(session, ("curved", outlier.name))
    assert good.label == "typical" and good.percentile > 0.2
    assert bad.label == "outlier" and bad.percentile < 0.05
    assert bad.score < good.score


def test_typicality_needs_three_other_demonstrations(session) -> None:
    """Each take is scored against the others there were when it was recorded (the learner
    scores it later, on its worker)."""
    session.store.create_primitive("new")
    demo = state(session).demos["curved"][0]
    for _ in range(4):
        session.store.add_demo("new", demo.times, demo.select(COLUMNS))
    names = [d.name for d in state(session).demos["new"]]
    scores = {name: scored(session, ("new", name)) for name in names}
    assert [name for name, score in scores.items() if score is not None] == ["new_003"]


def test_a_deleted_take_leaves_the_takes_and_the_learner_goes_on(session) -> None:
    """A take deleted (its primitive's, or the take alone) is no longer one of this run's
    takes; the learner, told of the store after each, scores the others as before."""
    demo = state(session).demos["curved"][0]
    first = session.store.add_demo("curved", demo.times, demo.select(COLUMNS))
    second = session.store.add_demo("curved", demo.times, demo.select(COLUMNS))
    session.store.delete_demo("curved", first.name)
    assert state(session).takes == {("curved", second.name)}
    assert scored(session, ("curved", second.name)) is not None
    session.store.create_primitive("new")
    for _ in range(2):
        session.store.add_demo("new", demo.times, demo.select(COLUMNS))
    session.store.delete_primitive("new")
    assert state(session).takes == {("curved", second.name)}
    session.learner.follow(state(session))  # no take it cannot find


def test_hiding_redraws_without_refitting_and_listeners_hear_every_change(session) -> None:
    heard = []
    session.store.on_change(lambda new: heard.append(new.version))
    before = model(session)
    session.view.set_hidden("curved", "curved_000", True)
    assert model(session) is before and ("curved", "curved_000") in session.snapshot().hidden
    session.view.set_hidden("curved", "curved_000", False)
    assert session.snapshot().hidden == frozenset()
    session.store.set_learning(8, 1.0)
    session.wait_for_model()
    assert model(session) is not before and model(session).basis.n_basis == 8
    assert heard == [1]  # hiding is the view's: the store changed once


def test_shrinkage_settings(session) -> None:
    # The default workspace starts on the engine's defaults (automatic covariance prior).
    store = session.store
    assert state(session).settings == {}
    assert model(session).report["covariance"]["strength"] > 0
    store.set_learning(10, 1.0, shrinkage=1e-6)
    session.wait_for_model()
    np.testing.assert_allclose(model(session).primitive("curved").shrinkage, 1e-6)
    store.set_learning(10, 1.0, shrinkage=None)  # the pooled prior
    assert state(session).settings["shrinkage"] is None
    session.wait_for_model()
    loo = model(session).primitive("curved").shrinkage
    hand, head = LAYOUT.dims(["hand"]), LAYOUT.dims(["head"])
    assert len(set(loo[hand])) == 1 and len(set(loo[head])) == 1  # one per modality
    store.set_learning(11, 1.0)  # keeps the shrinkage
    assert state(session).settings["shrinkage"] is None
    store.set_learning(11, 1.0, shrinkage=0.3)
    session.wait_for_model()
    np.testing.assert_allclose(model(session).primitive("direct").shrinkage, 0.3)


def test_automatic_settings_are_chosen_by_the_fit_and_can_be_given_back(session) -> None:
    learned = session.wait_for_model()
    chosen = learned.report["settings"]["chosen"]
    assert set(chosen) == {"n_basis", "width", "noise_scale"}
    resolved = session.snapshot().resolved_settings()  # what typicality fits with: no new choice
    assert not resolved.to_choose  # the duration's temperature and the variant included
    assert resolved == learned.settings
    session.store.set_learning(9, 1.2)
    assert session.wait_for_model().settings.n_basis == 9
    resolved = session.snapshot().resolved_settings()
    assert resolved.n_basis == 9 and not resolved.to_choose
    index = state(session).workspace.index_path
    assert '"n_basis": 9' in index.read_text()
    session.store.set_learning(None, None)  # back to automatic: absent from studio.json
    assert "n_basis" not in state(session).settings and "width" not in state(session).settings
    assert '"n_basis"' not in index.read_text()
    assert session.wait_for_model().report["settings"]["chosen"] == chosen


def test_primitives_with_fewer_than_two_demonstrations_are_not_learned(session) -> None:
    store = session.store
    store.create_primitive("alone")
    demo = state(session).demos["curved"][0]
    store.add_demo("alone", demo.times, demo.select(COLUMNS))
    assert "alone" not in session.wait_for_model().names
    store.delete_primitive("curved")
    store.delete_primitive("direct")
    session.wait_for_model()
    assert model(session) is None and "at least two" in session.learner.state.error


def test_concurrent_recordings_get_distinct_names_and_files(session) -> None:
    demo = state(session).demos["curved"][0]
    errors = []

    def record() -> None:
        try:
            session.store.add_demo("curved", demo.times, demo.select(COLUMNS))
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=record) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    names = [d.name for d in state(session).demos["curved"]]
    assert len(names) == len(set(names)) == 24
    assert len(list(state(session).workspace.demo_dir("curved").glob("*.csv"))) == 24


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
    store, before = session.store, files(session)
    curved = state(session).demos["curved"][4]
    entry = store.delete_demo("curved", curved.name)
    assert curved.name not in {d.name for d in state(session).demos["curved"]}
    store.delete_primitive("direct")
    assert [e.name for e in state(session).deleted][-1] != entry.name
    store.undo_delete()  # the primitive first
    assert state(session).names == ("curved", "direct")
    assert len(state(session).demos["direct"]) == 20
    restored = store.undo_delete()
    assert restored.name == entry.name
    assert without_trash(files(session)) == before  # byte for byte
    names = [d.name for d in state(session).demos["curved"]]
    assert names == [f"curved_{i:03d}" for i in range(20)]
    session.wait_for_model()
    assert model(session) is not None and model(session).names == ("curved", "direct")
    with pytest.raises(ValueError, match="nothing deleted"):
        store.undo_delete()


def test_replacing_and_switching_workspaces(session, tmp_path) -> None:
    store, before = session.store, files(session)
    demo = state(session).demos["curved"][0]
    data = WorkspaceData(
        primitives=[PrimitiveEntry("wave", (1, 2, 3)), PrimitiveEntry("rest", (3, 2, 1))],
        demos={"wave": list(state(session).demos["curved"][:3]),
               "rest": list(state(session).demos["direct"][:3])},  # fmt: skip
        layout=LAYOUT,
    )
    version = state(session).version
    entry = store.replace(data, "replaced by a test")
    assert state(session).names == ("wave", "rest") and state(session).version > version
    session.wait_for_model()
    assert model(session).names == ("wave", "rest")
    store.restore(entry.name)
    assert without_trash(files(session)) == before
    old_root = state(session).workspace.root
    store.switch(tmp_path / "other", data)
    assert state(session).workspace.root == tmp_path / "other"
    assert state(session).names == ("wave", "rest")
    assert state(session).deleted == ()
    reopened = Session.open(old_root, fits=FITS)
    assert without_trash(files(reopened)) == before
    reopened.close()
    with pytest.raises(ValueError, match="already a studio workspace"):
        store.switch(old_root, data)
    store.add_demo("wave", demo.times, demo.select(COLUMNS))
    assert (tmp_path / "other" / "demos" / "wave" / "wave_003.csv").exists()


def test_refits_run_in_the_background_and_only_the_latest_is_adopted(session, monkeypatch):
    """A change returns at once; the previous model stays in use until the refit of the latest
    change is done; a refit superseded while it ran is never adopted."""
    fits = session.learner.fits
    real, learned = fits.fit, []
    started, release = threading.Event(), threading.Event()

    def gated(training, reuse=True):
        result = real(training, reuse)
        learned.append(training.settings.n_basis)
        if training.settings.n_basis == 8:
            started.set()
            release.wait(60)
        return result

    monkeypatch.setattr(fits, "fit", gated)
    before, adopted = model(session), session.learner.state.request
    session.store.set_learning(8, 1.0)
    assert started.wait(PATIENCE_S), "the refit did not start"
    assert model(session) is before and session.snapshot().refitting  # the previous meanwhile
    session.store.set_learning(9, 1.0)  # supersedes the refit in flight
    release.set()
    latest = session.wait_for_model()
    assert latest.basis.n_basis == 9 and model(session) is latest
    assert not session.snapshot().refitting
    assert learned == [8, 9]  # the first ran to its end, and was dropped
    assert session.learner.state.request == adopted + 2  # two changes, one model adopted
    session.close()


def test_a_held_out_model_is_fitted_with_the_settings_its_refit_resolved(session, monkeypatch):
    """The automatic settings are resolved once per refit (the learner's state holds them, the
    snapshot hands them on); a held-out model asked for while the refit of the latest change
    runs waits for it, then is fitted with the settings that refit resolved."""
    learned = session.wait_for_model()
    resolved = session.learner.state.settings
    assert not resolved.automatic and resolved.n_basis == learned.settings.n_basis
    assert session.snapshot().resolved_settings() is resolved  # not resolved again
    fits, store = session.learner.fits, session.store
    real, trained = fits.fit, []
    started, release = threading.Event(), threading.Event()

    def gated(training, reuse=True):
        if not started.is_set():  # the refit of the change below, held until released
            started.set()
            release.wait(60)
        trained.append(training.settings)
        return real(training, reuse)

    monkeypatch.setattr(fits, "fit", gated)
    store.set_learning(9, 1.2)
    assert started.wait(PATIENCE_S), "the refit did not start"
    snapshot = session.snapshot()
    assert snapshot.refitting and snapshot.learner.settings is resolved
    assert snapshot.resolved_settings().n_basis == 9  # the store's, while the refit runs
    assert session.learner.held_out(store.state, "curved", "curved_003") is None  # it waits
    release.set()
    session.wait_for_model()
    assert session.learner.state.settings.n_basis == 9
    fitted = wait_until(lambda: session.learner.held_out(store.state, "curved", "curved_003"),
                        timeout=120, what="the held-out model")  # fmt: skip
    assert fitted.model is not None and fitted.model.basis.n_basis == 9
    assert [s.n_basis for s in trained] == [9, 9]  # the refit, then the held-out model
    assert trained[1] is session.learner.state.settings
    np.testing.assert_allclose(fitted.model.basis.width, 1.2)


def _with_a_gap(demo, name: str):
    """``demo`` with a 20 s pause of the timestamps after its middle sample."""
    from promp.data import Demonstration

    times = demo.times.copy()
    times[demo.n_samples // 2 :] += 20.0
    return Demonstration(times, demo.select(COLUMNS), COLUMNS, name=name)


def test_a_flagged_demonstration_is_left_out_until_kept_and_the_choice_persists(session) -> None:
    store = session.store
    gap = _with_a_gap(state(session).demos["curved"][3], "gap")
    added = store.add_demo("curved", gap.times, gap.select(COLUMNS))
    key = ("curved", added.name)
    (finding,) = state(session).findings_of(*key)
    assert finding.kind == "gap" and finding.file == f"demos/curved/{added.name}.csv"
    assert list(state(session).left_out) == [key]
    learned = session.wait_for_model()
    assert learned.primitive("curved").n_demos == 20  # learned without it
    assert scored(session, key) is not None  # scored against the others that are learned from
    path = state(session).workspace.demo_path(*key)
    before = path.read_bytes()
    store.set_kept(*key, True)
    assert state(session).left_out == {}
    assert session.wait_for_model().primitive("curved").n_demos == 21
    reopened = Session.open(state(session).workspace.root, fits=FITS)
    assert state(reopened).checks.kept == {key} and state(reopened).left_out == {}
    reopened.close()
    store.rename_primitive("curved", "arc")
    assert state(session).checks.kept == {("arc", added.name)} and state(session).left_out == {}
    assert ("arc", added.name) in session.snapshot().typicality  # the score follows the rename
    store.set_kept("arc", added.name, False)
    assert list(state(session).left_out) == [("arc", added.name)]
    assert state(session).workspace.demo_path("arc", added.name).read_bytes() == before
    with pytest.raises(ValueError, match="has no demonstration"):
        store.set_kept("arc", "nowhere", True)


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
    session = Session.open(tmp_path / "ws", fits=FITS)
    key = ("direct", data.demos["direct"][1].name)
    assert [f.kind for f in state(session).findings_of(*key)] == ["timestamps"]
    assert list(state(session).left_out) == [key]
    assert session.wait_for_model().primitive("direct").n_demos == 3
    session.close()


def test_a_repaired_gap_makes_new_demonstrations_and_overwrites_nothing(session) -> None:
    store = session.store
    gap = _with_a_gap(state(session).demos["direct"][1], "gap")
    added = store.add_demo("direct", gap.times, gap.select(COLUMNS))
    folder = state(session).workspace.demo_dir("direct")
    squatter = folder / f"{added.name}-cut.csv"
    squatter.write_text("not a demonstration\n")  # a file the store could not read
    before = state(session).workspace.demo_path("direct", added.name).read_bytes()
    (cut,) = store.repair_gap("direct", added.name, "cut")
    assert cut.name == f"{added.name}-cut-2" and squatter.read_text() == "not a demonstration\n"
    assert cut.n_samples == gap.n_samples // 2
    assert state(session).workspace.demo_path("direct", added.name).read_bytes() == before
    # no gap any more; the part before it ends half-way, far from where the others end
    assert [f.kind for f in state(session).findings_of("direct", cut.name)] == ["end"]
    with pytest.raises(ValueError, match="has no gap"):
        store.repair_gap("direct", cut.name, "split")
