"""Groups in the studio: a workspace imported from a dataset keeps where each demonstration
came from (:mod:`app.io.demo_sources`), the Data tab's evaluation holds out a whole group beside
leave-one-out (Group by), and the Infer tab's held-out model can leave out the test
demonstration's whole group (Hold out)."""

from __future__ import annotations

import contextlib
import dataclasses
import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.core.groups import group_choices, group_members, rule_of
from app.core.session import Session
from app.io.dataset_import import dataset_to_workspace
from app.io.demo_sources import DemoSources
from app.io.exchange import read_workspace_zip, workspace_zip
from app.io.workspace import Workspace
from app.live.inference import TEST
from app.panels.data.evaluation import EvaluationJob
from app.panels.data.evaluation_plan import NO_GROUPS, plan_evaluation
from app.panels.data.evaluation_section import summary
from app.panels.data.results import grouped_markdown
from app.panels.infer.view_model import InferState, choose_model
from promp.data import Demonstration
from promp.evaluate.groups import group_of, parse_group_by
from tests.conftest import FITS, wait_until
from tests.synthetic import LAYOUT, make_dataset

GIVEN = {"n_basis": 7, "width": 1.0, "noise_scale": 1.5}  # quick: the groups are the subject


def recorded_in_sessions(sessions: int = 3, n_demos: int = 6) -> dict:
    """Two primitives, their takes in ``session<i>/`` folders below the class folder."""
    return {
        name: [Demonstration(d.times, d.values, d.columns, f"session{j % sessions}/{d.name}")
               for j, d in enumerate(demos)]
        for name, demos in make_dataset(seed=3, n_demos=n_demos).items()
    }  # fmt: skip


@contextlib.contextmanager
def opened(root: Path, data) -> Iterator[Session]:
    """A session of a new workspace at ``root`` holding ``data``, closed after."""
    Workspace.create(root, data)
    session = Session.open(root, fits=FITS)
    try:
        yield session
    finally:
        session.close()


@pytest.fixture
def session(tmp_path):
    data = dataset_to_workspace(recorded_in_sessions(), LAYOUT)
    data.settings = dict(GIVEN)
    with opened(tmp_path / "ws", data) as session:
        yield session


def test_an_imported_dataset_keeps_where_each_demonstration_came_from(tmp_path) -> None:
    data = dataset_to_workspace(recorded_in_sessions(), LAYOUT)
    assert data.demos["left"][1].name == "session1_left1"
    assert data.sources.path("left", "session1_left1") == "session1/left1"
    root = tmp_path / "ws"
    Workspace.create(root, data)
    assert Workspace(root).load().sources == data.sources
    index = json.loads((root / "studio.json").read_text())
    assert ["left", "session1_left1", "session1/left1"] in index["sources"]
    # an export and its import keep them
    assert read_workspace_zip(workspace_zip(data)).data.sources == data.sources
    # a workspace of an earlier version has none: its demonstrations are their own names
    del index["sources"]
    (root / "studio.json").write_text(json.dumps(index))
    loaded = Workspace(root).load()
    assert loaded.sources == DemoSources() and loaded.n_demos == data.n_demos
    assert loaded.sources.path("left", "session1_left1") == "session1_left1"
    index["sources"] = [["left", "session1_left1"]]
    (root / "studio.json").write_text(json.dumps(index))
    with pytest.raises(ValueError, match="'sources' must be a list of"):
        Workspace(root).load()


def test_a_renamed_primitive_keeps_its_sources(session) -> None:
    session.store.rename_primitive("left", "leftward")
    state = session.store.state
    assert state.sources.path("leftward", "session2_left2") == "session2/left2"
    reopened = Workspace(state.workspace.root).load()
    assert reopened.sources.path("leftward", "session2_left2") == "session2/left2"


def test_the_group_choices_follow_the_sources(session, tmp_path) -> None:
    store = session.store.state
    assert group_choices(store, NO_GROUPS) == {NO_GROUPS: None, "folder": "folder"}
    assert rule_of("its folder", "its ") == "folder"
    assert rule_of("its folder level 3", "its ") == "3"
    assert rule_of("the demonstration", "its ") is None
    group, members = group_members(store, "left", "session1_left1", "folder")
    assert group == "session1"
    assert members == [("left", "session1_left1"), ("left", "session1_left4"),
                       ("right", "session1_right1"), ("right", "session1_right4")]  # fmt: skip
    # a workspace recorded in the studio has no folders: nothing to group by
    with opened(tmp_path / "taken", dataset_to_workspace(make_dataset(seed=3), LAYOUT)) as plain:
        assert group_choices(plain.store.state, NO_GROUPS) == {NO_GROUPS: None}
        with pytest.raises(ValueError, match="group by: expected one of"):
            plan_evaluation(plain.store.state, [["hand"]], "ML", "50", "ours",
                            group_by="folder")  # fmt: skip


def test_group_members_follow_the_methods_rule(session) -> None:
    """The groups read once per sources are promp.evaluate.groups' own: every demonstration's
    group and members at each folder level, those with no folder there in none."""
    store = session.store.state
    sources = DemoSources.of({**{(p, d): store.sources.path(p, d) for p, items
                                 in store.demos.items() for d in (x.name for x in items)},
                              ("left", "session0_left0"): "site/session0/left0"})  # fmt: skip
    store = dataclasses.replace(store, sources=sources)
    keys = [(p, d.name) for p, items in store.demos.items() for d in items]
    assert sources.folder_groups is sources.folder_groups  # read once
    for level in (1, 2):
        rule = parse_group_by(str(level))
        for primitive, demo in keys:
            try:
                group = group_of(sources.path(primitive, demo), rule)
            except ValueError:
                with pytest.raises(ValueError, match=f"no folder at level {level}"):
                    group_members(store, primitive, demo, str(level))
                continue
            found, members = group_members(store, primitive, demo, str(level))
            assert found == group
            expected = []
            for key in keys:
                with contextlib.suppress(ValueError):
                    if group_of(sources.path(*key), rule) == group:
                        expected.append(key)
            assert members == expected
    assert group_members(store, "left", "session0_left0", "2") == (
        "session0", [("left", "session0_left0")])
    assert group_members(store, "left", "session0_left3", "folder")[0] == "session0"
    with pytest.raises(ValueError, match="not by the pattern"):
        group_members(store, "left", "session0_left0", r"session(\d)")


def test_the_data_tab_evaluates_by_group_beside_leave_one_out(session) -> None:
    store = session.store.state
    plan = plan_evaluation(store, [["hand"]], "ML", "30 70", "ours + toolbox + baselines",
                           group_by="folder")  # fmt: skip
    assert list(plan.groups) == ["session0", "session1", "session2"]
    assert plan.n_held_out == 2 * store_demos(store)
    job = EvaluationJob(plan)
    job.run()
    outcome = job.outcome
    assert outcome.error is None and not outcome.cancelled
    assert job.progress.done == job.progress.total == plan.n_held_out
    grouped = outcome.grouped
    assert grouped is not None and len(grouped.comparisons) == 2 * 4  # 2 percents x 4 methods
    report = job.report()
    assert report["settings"]["group_by"] == "folder"
    assert {r["method"] for r in report["grouped"]["results"]} == {"ours", "seed", "dtw",
                                                                   "prefix-nn"}  # fmt: skip
    text = grouped_markdown(grouped)
    assert "**Grouped by folder**: 3 groups (session0, session1, session2)" in text
    assert "| one at a time | by group |" in text
    assert "groups held out whole (grouped by folder)" in summary(job)
    assert "one at a time and grouped by folder" in job.title()


def store_demos(store) -> int:
    return sum(len(v) for v in store.learned.values())


def test_infer_holds_out_the_test_demonstrations_group(session) -> None:
    session.wait_for_model()
    store = session.store.state
    fitted = wait_until(lambda: session.learner.held_out(store, "left", "session0_left0",
                                                         "folder"),
                        timeout=120, what="the model without session0")  # fmt: skip
    assert fitted.model.primitive("left").n_demos == 4  # 6 - the two of session0
    assert fitted.model.primitive("right").n_demos == 4
    alone = wait_until(lambda: session.learner.held_out(store, "left", "session0_left0"),
                       timeout=120, what="the model without the demonstration")  # fmt: skip
    assert alone.model.primitive("left").n_demos == 5
    state = InferState(TEST, "left", "session0_left0", "hand", "ml", 40, True, "shown",
                       hold_out="folder")  # fmt: skip
    choice = choose_model(state, session.snapshot(), session.learner)
    assert choice.model is fitted.model
    assert choice.note == ("learned without session0_left0's group session0 (4 demonstrations "
                           "held out)")
    assert choice.origin[-1] == "folder"


def test_a_group_that_leaves_a_primitive_too_few_is_refused_in_infer(tmp_path) -> None:
    data = recorded_in_sessions(sessions=2, n_demos=3)  # left: session0 x2, session1 x1
    with opened(tmp_path / "ws", dataset_to_workspace(data, LAYOUT)) as session:
        session.wait_for_model()
        state = InferState(TEST, "left", "session0_left0", "hand", "ml", 40, True, "shown",
                           hold_out="folder")  # fmt: skip
        choice = choose_model(state, session.snapshot(), session.learner)
        assert choice.model is None
        assert "group 'session0' of 'session0_left0' leaves 'left' with 1" in choice.message


def test_results_of_a_missing_path_say_so(tmp_path) -> None:
    """A take with no folder under a folder rule: the evaluation refuses it by name."""
    data = dataset_to_workspace(recorded_in_sessions(), LAYOUT)
    data.sources = DemoSources(tuple(e for e in data.sources.entries
                                     if e[:2] != ("left", "session0_left0")))  # fmt: skip
    with opened(tmp_path / "ws", data) as session:
        with pytest.raises(ValueError, match="left/session0_left0: no folder"):
            plan_evaluation(session.store.state, [["hand"]], "ML", "50", "ours",
                            group_by="folder")  # fmt: skip


def test_the_section_offers_group_by_where_the_workspace_has_groups(session) -> None:
    import viser

    from app.io.net import free_port
    from app.panels.data.evaluation_section import EvaluationSection

    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    ctx = type("Ctx", (), {"gui": server.gui, "store": session.store,
                           "open_in_infer": lambda *_: None})()  # fmt: skip
    try:
        section = EvaluationSection(ctx, lambda *_: None)
        assert tuple(section.controls.group_dropdown.options) == (NO_GROUPS, "folder")
        assert section.controls.group_dropdown.value == NO_GROUPS
    finally:
        server.stop()


def test_paths_are_their_names_without_sources(tmp_path: Path) -> None:
    assert DemoSources().path("left", "left0") == "left0"
    assert not DemoSources() and DemoSources.of({("a", "b"): "x/b"})
    assert DemoSources.of({("a", "b"): "x/b"}).renamed("a", "c").path("c", "b") == "x/b"
