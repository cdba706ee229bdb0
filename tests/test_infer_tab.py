"""The Infer tab: the scrub computation, the live buffer, the replay, and the tab in a
real browser (slider scrubbed by mouse and keyboard, replay played, README screenshot)."""

from __future__ import annotations

import dataclasses
import math
import threading
import time

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.core.fits import FitCache, Training, held_out_training
from app.core.learner_state import resolved_settings
from app.live.inference import inferred
from app.live.replay import Replay
from app.live.stream import LiveStream
from app.ui.display import observed_choices
from promp import metrics
from promp.data import Demonstration
from promp.evidence.pipeline import condition
from promp.inference import Observation, predict
from promp.learn import fit
from promp.model import Settings
from promp.timing import n_observed_for
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT
from robots.icub.layout import hand_dims
from tests.browser import (
    choose,
    close_notifications,
    open_tab,
    press,
    press_until,
    set_camera,
    settled_render,
    settled_screenshot,
)
from tests.conftest import PageSpec, StudioSpec, open_page, wait_frames, wait_until

COLUMNS = LAYOUT.columns

SETTINGS = Settings()


@pytest.fixture(scope="module")
def scenario() -> dict[str, list[Demonstration]]:
    """The studio's default workspace: 20 curved and 20 direct simulated demonstrations."""
    from app.studio import default_workspace

    return default_workspace().demos


@pytest.fixture(scope="module")
def chosen(scenario) -> Settings:
    """The settings the studio's Infer tab fits its held-out models with: the automatic ones
    at the values the workspace's model chose (``Session.resolved_settings``), not chosen
    again for every held-out demonstration (that is the evaluation's rule, tested in
    tests/test_promp_evaluate.py; here it cost 40 choices)."""
    return resolved_settings(SETTINGS, LAYOUT, fit(scenario, LAYOUT, SETTINGS))


def held_out_model(scenario, primitive: str, demo: str, settings: Settings):
    return fit(held_out_training(scenario, primitive, demo), LAYOUT, settings)


# ---------------------------------------------------------------------- scrub computation


def test_n_observed_follows_the_evaluation_rule() -> None:
    assert n_observed_for(100, 147) == 147
    assert n_observed_for(90, 147) == math.ceil(0.9 * 147)
    assert n_observed_for(50, 100) == 50  # exact, not 51 by rounding error
    assert n_observed_for(1, 50) == 1
    assert n_observed_for(0.01, 10) == 1
    for bad in (0, -5, 100.5, float("nan")):
        with pytest.raises(ValueError, match="percentage"):
            n_observed_for(bad, 100)
    with pytest.raises(ValueError, match="at least one sample"):
        n_observed_for(50, 0)


def test_infer_offers_every_set_of_modalities_the_command_line_accepts(tmp_path) -> None:
    """A handover set (the human's hand x, y, z; 8 EMG channels; the robot's hand): every set
    ``python -m promp.evaluate --observe`` takes, in any order, is a choice of Infer's
    Observed dropdown, and no other."""
    from itertools import permutations

    from promp.datasets import write_csv_dataset
    from promp.evaluate.cli import build_parser, load

    rng = np.random.default_rng(0)
    emg = tuple(f"emg{i}" for i in range(8))
    columns = ("hx", "hy", "hz", *emg, "rx", "ry", "rz")
    times = np.arange(60) / 50.0
    dataset = {
        name: [Demonstration(times, np.cumsum(rng.normal(0, 0.01, (60, 14)), axis=0), columns,
                             name=f"{name}{i}") for i in range(3)]
        for name in ("give", "take")
    }  # fmt: skip
    write_csv_dataset(tmp_path / "handover", dataset)
    names = ("human", "emg", "robot")
    command = [str(tmp_path / "handover"), "--format", "csv", "--modality", "human=hx,hy,hz",
               "--modality", f"emg={','.join(emg)}", "--modality", "robot=rx,ry,rz"]  # fmt: skip
    given = [",".join(c) for k in (1, 2, 3) for c in permutations(names, k)]  # 15
    loaded = load(build_parser().parse_args([*command, *(a for g in given for a in
                                                         ("--observe", g))]))  # fmt: skip
    choices = observed_choices(loaded.layout)
    assert choices["human + emg"] == ("human", "emg")
    assert list(choices)[:4] == ["human + emg + robot", "human", "emg", "robot"]
    assert {frozenset(s) for s in loaded.observe} == {frozenset(c) for c in choices.values()}
    assert len(choices) == 7
    with pytest.raises(ValueError, match="unknown modality 'gaze'"):
        load(build_parser().parse_args([*command, "--observe", "human,gaze"]))


def test_infer_names_its_sources_apart_and_the_help_names_them_so() -> None:
    """Source's choices: no name holds another, the two live ones share no word but "live";
    the tab's help and Teach's Live takes name them as the dropdown does."""
    import re
    from itertools import permutations

    from app.live.inference import LIVE, LSL, TEST
    from app.panels.infer.controls import SOURCES
    from app.panels.teach.live_record import OFF
    from app.ui.help import help_text

    assert SOURCES == (TEST, LIVE, LSL)
    for a, b in permutations(SOURCES, 2):
        assert a.lower() not in b.lower()
    live, lsl = ({w.lower() for w in re.findall(r"\w+", name)} for name in (LIVE, LSL))
    assert live & lsl == {"live"}
    assert "LSL" in LSL and "hand" in LIVE and "head" in LIVE  # each says what it is
    text = help_text("infer")
    assert all(name in text for name in SOURCES)
    assert LSL in OFF


def held_out(fits: FitCache, demos, primitive: str, demo: str):
    """The model learned from ``demos`` without ``demo`` (as the learner fits it)."""
    return fits.fit(Training(held_out_training(demos, primitive, demo), LAYOUT, SETTINGS)).model


def test_held_out_model_never_sees_the_test_demo(scenario) -> None:
    fits = FitCache()
    model = held_out(fits, scenario, "curved", "curved_003")
    assert model.primitive("curved").n_demos == len(scenario["curved"]) - 1
    assert model.primitive("direct").n_demos == len(scenario["direct"])
    assert held_out(fits, scenario, "curved", "curved_003") is model  # kept
    # Whatever the test demonstration holds, the held-out model is the same.
    test = next(d for d in scenario["curved"] if d.name == "curved_003")
    corrupted = Demonstration(test.times, test.values + 0.3, test.columns, name=test.name)
    changed = {
        "curved": [corrupted if d.name == test.name else d for d in scenario["curved"]],
        "direct": scenario["direct"],
    }
    assert held_out(fits, changed, "curved", "curved_003") is model  # the same training
    refit = held_out(FitCache(), changed, "curved", "curved_003")  # learned anew
    assert refit is not model
    assert_allclose(refit.primitive("curved").mean, model.primitive("curved").mean)
    assert_allclose(refit.primitive("curved").cov_factor, model.primitive("curved").cov_factor)
    # ... while the model learned with it is not (at the same settings: the automatic choice
    # of 40 demonstrations may differ from that of 39).
    full = fit(scenario, LAYOUT, model.settings)
    assert np.abs(full.primitive("curved").mean - model.primitive("curved").mean).max() > 1e-6


def test_held_out_training_refuses_bad_choices(scenario) -> None:
    with pytest.raises(ValueError, match="unknown primitive"):
        held_out_training(scenario, "nope", "curved_000")
    with pytest.raises(ValueError, match="no demonstration"):
        held_out_training(scenario, "curved", "direct_000")
    two = {"curved": scenario["curved"][:2], "direct": scenario["direct"]}
    with pytest.raises(ValueError, match="at least three"):
        held_out_training(two, "curved", "curved_000")
    # A primitive left with fewer than two demonstrations is simply not learned.
    train = held_out_training({**two, "direct": scenario["direct"][:3]}, "direct", "direct_000")
    assert set(train) == {"curved", "direct"} and len(train["direct"]) == 2


def test_recognises_every_held_out_demo_at_90_percent(scenario, chosen) -> None:
    """The default scenario: at 90 %, each held-out demonstration's own primitive is recognised
    (hand + head with both alpha methods; ML with each modality alone), with finite errors."""
    settings = [("hand + head", "ml"), ("hand + head", "model"), ("hand", "ml"), ("head", "ml")]
    wrong = []
    for primitive, demos in scenario.items():
        for demo in demos:
            model = held_out_model(scenario, primitive, demo.name, chosen)
            for observed, alpha in settings:
                obs = Observation.first(model, demo, 90, observed_choices(LAYOUT)[observed])
                result = inferred(model, obs, alpha, truth=demo).inference
                if result.primitive != primitive:
                    wrong.append((demo.name, observed, alpha, result.primitive))
                e = result.errors
                errors = [e.position, e.goal, e.duration]
                assert np.all(np.isfinite(errors)), (demo.name, observed, alpha, errors)
                assert e.position < 0.05 and e.goal < 0.05
                assert_allclose(result.probabilities.sum(), 1.0)
    assert not wrong, wrong


def test_inference_geometry_and_errors(scenario, chosen) -> None:
    demo = scenario["direct"][7]
    model = held_out_model(scenario, "direct", demo.name, chosen)
    obs = Observation.first(model, demo, 40, ("hand", "head"))
    assert obs.n_observed == math.ceil(0.4 * demo.n_samples)
    result = inferred(model, obs, "ml", truth=demo)
    inference, future = result.inference, result.future
    hand = hand_dims(LAYOUT)
    assert inference.prior.mean.shape == inference.prediction.mean.shape == (100, LAYOUT.n_dims)
    assert_allclose(inference.observed_until, demo.times[obs.n_observed - 1] - demo.times[0])
    # The future path runs on the posterior mean from the observation point to the end.
    assert_allclose(future.times[[0, -1]], [inference.observed_until, inference.duration])
    assert_allclose(future.hand[-1], inference.prediction.mean[-1, hand], atol=1e-9)
    prediction = inference.prediction
    at_obs = [
        np.interp(inference.observed_until, prediction.times, prediction.mean[:, d]) for d in hand
    ]
    assert_allclose(future.hand[0], at_obs, atol=2e-3)
    # It passes near the last observed hand position, and conditioning narrowed the spread there.
    assert np.linalg.norm(future.hand[0] - obs.values[-1, :3]) < 0.02
    k = np.searchsorted(prediction.times, inference.observed_until) - 1
    assert np.all(prediction.std[k, hand] < inference.prior.std[k, hand])
    # Errors are the evaluation's metrics.
    truth = LAYOUT.extract(demo)[:, hand]
    prim = model.primitive(inference.primitive)
    alpha = inference.alpha
    natural = predict(model, condition(model, prim, obs, alpha), alpha).mean[:, hand]
    errors = inference.errors
    assert_allclose(errors.position, metrics.remainder_error(truth, natural, obs.n_observed))
    assert_allclose(errors.goal, metrics.goal_error(truth, natural))
    assert_allclose(errors.duration, abs(inference.duration - demo.duration))
    # Nothing remains at 100 %: no remainder error; without the truth, no errors at all.
    full = inferred(model, Observation.first(model, demo, 100, ("hand",)), "ml", truth=demo)
    assert math.isnan(full.inference.errors.position)
    assert math.isfinite(full.inference.errors.goal)
    live = inferred(model, obs, "model")
    assert live.inference.errors is None and live.truth is None


def test_the_speed_readout_says_what_each_number_is(scenario, chosen) -> None:
    """The status line's speed: α with the number of samples it stands for (s̄ / α: the
    predicted duration's, at the model's sample period), then the same speed over the
    recognised primitive's typical one, named, in the line itself."""
    import html
    import re

    from app.panels.infer.readout import alpha_text, status_html

    demo = scenario["curved"][3]
    model = held_out_model(scenario, "curved", demo.name, chosen)
    result = inferred(model, Observation.first(model, demo, 40, ("hand", "head")), "ml", truth=demo)
    inference, s_bar = result.inference, model.settings.s_bar
    text = alpha_text(result)
    found = re.fullmatch(r"speed α = ([0-9.]+) \(([0-9.]+) / ([0-9]+) samples\): ([0-9.]+) × "
                         r"(\w+)'s typical speed", text)  # fmt: skip
    assert found, text
    alpha, reference, samples, relative, name = found.groups()
    assert float(alpha) == pytest.approx(inference.alpha, rel=5e-3)
    assert float(reference) == s_bar and name == inference.primitive
    # the samples are the predicted duration's, at the model's sample period
    duration = (int(samples) - 1) * model.sample_period
    assert duration == pytest.approx(inference.duration, abs=model.sample_period)
    typical = math.exp(model.primitive(name).log_alpha_mean)
    assert float(relative) == pytest.approx(inference.alpha / typical, abs=5e-3)
    assert text in html.unescape(status_html(result, "curved", "held out", ""))


def test_live_stream_observation(scenario) -> None:
    demo = scenario["curved"][0]
    values = demo.select(COLUMNS)
    stream = LiveStream(max_seconds=10.0)
    with pytest.raises(ValueError, match="nothing observed"):
        stream.samples().observation(100, ("hand",), LAYOUT)
    for t, row in zip(demo.times, values, strict=True):
        assert stream.append(50.0 + t, row[:3], row[3:])
    assert not stream.append(50.0 + 10.5, values[0, :3], values[0, 3:])  # full
    assert stream.append(50.0, values[0, :3], None)  # not after the last: ignored
    assert len(stream.samples()) == demo.n_samples
    model = fit(scenario, LAYOUT, SETTINGS)
    for percent in (30, 100):
        live = stream.samples().observation(percent, ("hand", "head"), LAYOUT)
        ref = Observation.first(model, demo, percent, ("hand", "head"))
        assert_allclose(live.values, ref.values)
        assert_allclose(live.elapsed, ref.elapsed)
    # Samples without a face are left out when the head is observed, kept for the hand alone.
    stream.clear()
    for i, (t, row) in enumerate(zip(demo.times, values, strict=True)):
        stream.append(t, row[:3], None if i % 3 == 0 else row[3:])
    samples = stream.samples()
    assert samples is stream.samples()  # the same value until a sample is added
    assert samples.observation(100, ("hand",), LAYOUT).n_observed == demo.n_samples
    with_head = samples.observation(100, ("head",), LAYOUT)
    assert with_head.n_observed == demo.n_samples - len(range(0, demo.n_samples, 3))
    stream.clear()
    stream.append(0.0, values[0, :3], None)
    with pytest.raises(ValueError, match="no face"):
        stream.samples().observation(100, ("hand", "head"), LAYOUT)


# ---------------------------------------------------------------------- replay


class FakeClock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_a_finished_replay_has_already_moved_the_hand_to_the_end() -> None:
    """Another thread that sees the replay finished must see the hand at the end: the state
    changes only after the hand has moved (a test once read the hand in between)."""
    clock = FakeClock()
    seen = []
    replay = Replay(lambda p: seen.append((np.array(p), replay.finished, replay.playing)),
                    clock=clock)  # fmt: skip
    path = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]])
    replay.load(np.array([0.0, 1.0]), path)
    replay.play()
    clock.t = 2.0
    replay.step()
    position, finished_while_moving, playing_while_moving = seen[-1]
    assert_allclose(position, path[-1])
    assert not finished_while_moving and playing_while_moving
    assert replay.finished and not replay.playing


def test_replay_advances_by_elapsed_time() -> None:
    clock, moves = FakeClock(), []
    replay = Replay(lambda p: moves.append(np.array(p)), clock=clock)
    with pytest.raises(ValueError, match="no path"):
        replay.play()
    times = np.array([0.0, 1.0, 2.0])
    path = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.1, 0.2, 0.0]])
    replay.load(times, path)
    replay.play()
    assert replay.playing and moved_to(moves, path[0])
    clock.t = 0.5
    assert replay.step()
    assert_allclose(moves[-1], [0.05, 0.0, 0.0])
    replay.pause()
    clock.t = 5.0
    assert not replay.step() and replay.elapsed == 0.5  # paused: time does not count
    replay.play()
    clock.t = 5.25
    replay.step()
    assert_allclose(replay.elapsed, 0.75)
    assert_allclose(replay.progress, 0.375)
    clock.t = 60.0
    replay.step()
    assert replay.finished and not replay.playing
    assert_allclose(moves[-1], path[-1])
    replay.reset()
    assert replay.elapsed == 0.0 and moved_to(moves, path[0])
    replay.play()  # finished then played again: from the start
    assert replay.playing and replay.elapsed == 0.0
    for bad_times, bad_path in (
        (times, path[:2]),
        (times, np.where(path == 0.1, np.nan, path)),
        (np.array([0.0, 1.0, 1.0]), path),
    ):
        with pytest.raises(ValueError):
            replay.load(bad_times, bad_path)


def test_a_new_prediction_during_a_replay_is_followed_from_where_it_was() -> None:
    """A refit lands while the robot finishes the movement: it goes on along the new path from
    the same fraction, and a path loaded while stopped rewinds as before."""
    clock, moves = FakeClock(), []
    replay = Replay(lambda p: moves.append(np.array(p)), clock=clock)
    replay.load(np.array([0.0, 2.0]), np.array([[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]]))
    replay.play()
    clock.t = 0.5
    replay.step()
    assert_allclose(replay.progress, 0.25)
    replay.load(np.array([0.0, 4.0]), np.array([[0.0, 0.0, 0.0], [0.0, 0.4, 0.0]]))
    assert replay.playing and replay.elapsed == 1.0  # a quarter of the new 4 s
    clock.t = 1.5
    replay.step()
    assert_allclose(moves[-1], [0.0, 0.2, 0.0])  # half of the new path after 1 s more
    clock.t = 10.0
    replay.step()
    assert replay.finished
    replay.load(np.array([0.0, 1.0]), np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    assert not replay.playing and replay.elapsed == 0.0  # not playing: rewound
    assert_allclose(moves[-1], [0.0, 0.0, 0.0])  # and the hand at the new path's start


def test_a_new_path_moves_the_hand_only_while_the_replay_holds_it() -> None:
    """Who holds the arm is explicit: idle (the user's), a new path moves nothing; paused or
    finished, the hand goes to the new path's start (the observation point, which the slider
    moved); a drag hands the arm back to the user."""
    from app.live.replay import Phase

    clock, moves = FakeClock(), []
    replay = Replay(lambda p: moves.append(np.array(p)), clock=clock)
    first = np.array([[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]])
    second = np.array([[0.1, 0.0, 0.0], [0.1, 0.3, 0.0]])
    replay.load(np.array([0.0, 1.0]), first)
    assert replay.phase is Phase.IDLE and moves == []
    replay.load(np.array([0.0, 1.0]), second)
    assert moves == []  # the arm is the user's
    replay.play()
    clock.t = 5.0
    replay.step()
    assert replay.phase is Phase.FINISHED and moved_to(moves, second[-1])
    replay.load(np.array([0.0, 2.0]), first)  # the slider moved
    assert replay.phase is Phase.PAUSED and moved_to(moves, first[0])
    replay.release()  # the user drags the hand
    n = len(moves)
    replay.load(np.array([0.0, 1.0]), second)
    assert replay.phase is Phase.IDLE and len(moves) == n
    replay.clear()
    assert replay.phase is Phase.IDLE and not replay.has_path


def moved_to(moves: list[np.ndarray], where: np.ndarray) -> bool:
    return bool(moves) and np.allclose(moves[-1], where)


# ---------------------------------------------------------------------- the tab in the studio


STUDIO = StudioSpec(folder="workspace", ready=lambda studio: infer_panel(studio).steps.count)
PAGE = PageSpec(tab="Infer")


def infer_panel(studio):
    from app.panels.infer import InferPanel

    return next(p for p in studio.panels if isinstance(p, InferPanel))


def wait_drawn(studio, result, timeout: float = 60.0) -> None:
    """Wait until the 3D view has drawn ``result`` (the scene draws a frame's result after the
    panel computed it: on a busy machine, a frame or more later)."""
    wait_until(lambda: studio.scene.inference.drawn.result is result, timeout=timeout,
               what="the scrub step drawn in 3D")  # fmt: skip


def expected_tube(drawn) -> np.ndarray:
    """The posterior tube's vertices computed from what the Infer layer says it drew (its
    result, in its tube style), as the 3D view should hold them."""
    from app.scene import tubes

    result = drawn.result
    hand = next(view for view in result.positions if view.modality == "hand")
    return tubes.region_vertices(hand.region, tubes.tube_look(drawn.style).probability)


BROWSER_TUBE_JS = """() => {
    const node = window.__viserSceneTree?.getState()?.['/infer/posterior'];
    const vertices = node?.message?.props?.vertices;
    return vertices ? Array.from(vertices) : null;
}"""


def browser_tube(page) -> np.ndarray | None:
    """The posterior tube's vertices the page holds (viser's scene tree in the browser)."""
    flat = page.evaluate(BROWSER_TUBE_JS)
    return None if flat is None else np.asarray(flat, dtype=float).reshape(-1, 3)


def assert_tube_drawn(studio, page, result) -> None:
    """The scene has drawn ``result``: the server's tube is the one computed from it, and the
    page comes to hold the same tube (float32 on the wire)."""
    wait_drawn(studio, result)
    drawn = studio.scene.inference.drawn
    assert drawn.result is result and id(studio.scene.inference.tube) in drawn.shaped
    expected = expected_tube(drawn)
    np.testing.assert_array_equal(studio.scene.inference.tube.vertices,
                                  expected.astype(np.float32))  # fmt: skip

    def in_page() -> bool:
        tube = browser_tube(page)
        return tube is not None and tube.shape == expected.shape and np.allclose(
            tube, expected, atol=1e-6
        )

    def differs() -> str:
        tube = browser_tube(page)
        gap = "no tube" if tube is None else f"{np.abs(tube - expected).max():.3g} m"
        n = result.observation.n_observed
        return f"the page's tube to be the one of the result drawn ({n} observed): {gap}"

    wait_until(in_page, timeout=60, what=differs)


def wait_scrubbed(panel, percent: int | None = None, timeout: float = 60.0):
    """Wait until the panel shows an inference of the test demonstration chosen at the
    slider's value (or ``percent``): the view says which state of the controls it was
    computed from."""

    def done():
        view, controls = panel.view, panel.controls
        if view is None or view.result is None or view.state.live:
            return None
        wanted = controls.percent.value if percent is None else percent
        if (view.state.demo, view.state.percent) != (controls.demo.value, wanted):
            return None
        return view.result

    return wait_until(done, timeout=timeout, what=f"a scrub step at {percent or 'the slider'} %")


def test_scrub_from_python_and_bad_replay(studio, monkeypatch) -> None:
    """GUI logic without a browser: the slider's callback only marks dirty, the loop scrubs;
    Play with nothing to replay says so and moves nothing."""
    from app.panels.infer import LIVE, TEST

    panel = infer_panel(studio)
    panel.controls.percent.value = 37
    result = wait_scrubbed(panel, 37)
    assert result.truth.name == panel.controls.demo.value and panel.steps.last_ms > 0
    assert f"{panel.steps.last_ms:.1f} ms" in panel.controls.status.content
    notes = []
    quiet = dataclasses.replace(
        panel.ctx, notify=lambda title, body, color="blue": notes.append(title)
    )
    monkeypatch.setattr(panel, "ctx", quiet)
    monkeypatch.setattr(panel.playback, "ctx", quiet)  # the replay's section says it
    panel.controls.source.value = LIVE
    wait_until(lambda: panel.view.result is None and "nothing observed" in panel.view.message,
               timeout=30)  # fmt: skip
    q = studio.arm.q.copy()
    panel.controls.replay_buttons.value = "Play"
    wait_until(lambda: notes, timeout=30, what="a notification")
    assert notes == ["Nothing to replay"]
    assert_allclose(studio.arm.q, q)
    panel.controls.source.value = TEST
    wait_scrubbed(panel)


@pytest.mark.parametrize("primitive", ["curved", "direct"])
def test_live_stream_follows_the_dragged_hand(studio, scenario, primitive) -> None:
    """Observing the live stream: the hand moved along a demonstration at its own speed
    (through the arm's IK, as a drag does) is recognised from the hand alone.

    The stream's clock is a manual one that the test sets to the demonstration's time of each
    sample once the hand is there, so the stream holds exactly the demonstration's samples up
    to 60 % of the movement however busy the machine is (with the wall clock, a starved loop
    took fewer samples than the demonstration has). The inference is checked against the
    samples it was computed from (the view holds them): the stream may not grow between the
    computation and the check."""
    from app.panels.infer import LIVE, TEST

    panel = infer_panel(studio)
    controls = panel.controls
    demo = scenario[primitive][4]
    hand = LAYOUT.extract(demo)[:, :3]
    controls.source.value = LIVE
    controls.observed.value = "hand"
    controls.percent.value = 100
    studio.loop.call(lambda: studio.arm.move_hand_to(hand[0]))
    wait_until(
        lambda: np.linalg.norm(studio.arm.hand_position() - hand[0]) < 5e-3,
        timeout=30, what="the hand at the start",
    )  # fmt: skip
    now = [1000.0 + demo.times[0]]
    panel.live.clock = lambda: now[0]
    try:
        controls.live_button.value = True  # "Start observing"
        wait_until(lambda: panel.live.observing and len(panel.live.samples()) == 1, timeout=30,
                   what="observing to start")  # fmt: skip
        # The user's drag: each of the demonstration's samples up to 60 % of the movement,
        # stamped with its own time once the IK has put the hand there.
        n_drive = int(np.searchsorted(demo.times, demo.times[0] + 0.6 * demo.duration))
        for k in range(1, n_drive):
            studio.loop.call(lambda p=hand[k]: studio.arm.move_hand_to(p))
            wait_until(
                lambda p=hand[k]: np.linalg.norm(studio.arm.hand_position() - p) < 5e-3,
                timeout=30, what=f"the hand at sample {k}",
            )  # fmt: skip
            now[0] = 1000.0 + demo.times[k]
            wait_until(lambda k=k: len(panel.live.samples()) == k + 1, timeout=30,
                       what=f"sample {k} in the live stream")  # fmt: skip
            if k == 6:
                wait_until(
                    lambda: panel.view.result is not None
                    and panel.view.result.observation.n_observed > 5,
                    timeout=30, what="a live inference",
                )  # fmt: skip
        controls.live_button.value = True  # "Stop observing"

        def final():
            view = panel.view
            done = not panel.live.observing and view.samples is panel.live.samples()
            return view if done and view.result is not None else None

        view = wait_until(final, timeout=30, what="the inference of the whole stream")
    finally:
        panel.live.clock = time.monotonic
    result = view.result
    assert result.truth is None and result.observation.modalities == ("hand",)
    assert result.observation.n_observed == len(view.samples) == n_drive > 20
    assert_allclose(result.observation.times, demo.times[:n_drive] - demo.times[0], atol=1e-9)
    assert result.inference.primitive == primitive, result.inference.probabilities
    assert f"Recognised: {primitive}" in controls.status.content
    controls.observed.value = "hand + head"
    controls.source.value = TEST
    wait_scrubbed(panel)


# ---------------------------------------------------------------------- real browser


def slider_box(page, panel):
    root = page.locator(f"[id='{panel.controls.percent._impl.uuid}']")
    root.wait_for(timeout=60_000)
    return root, root.bounding_box()


def click_slider(page, panel, fraction: float) -> None:
    _, box = slider_box(page, panel)
    page.mouse.click(box["x"] + fraction * box["width"], box["y"] + box["height"] / 2)


def bars_in_page(page) -> dict[str, float]:
    rows = page.locator("[data-primitive]")
    return {
        rows.nth(i).get_attribute("data-primitive"): float(rows.nth(i).get_attribute("data-p"))
        for i in range(rows.count())
    }


CHART_STATE_JS = """(uuid) => {
    const entry = window.__viserTestpoints?.uplots?.[uuid];
    if (!entry) return null;
    const c = entry.chart;
    return {x: [c.scales.x.min, c.scales.x.max], y: [c.scales.y.min, c.scales.y.max],
            n: c.data[0].length, series: c.series.length};
}"""


def chart_in_page(page, handle) -> dict | None:
    """What uPlot holds in the page for the chart ``handle`` (viser's test hook)."""
    return page.evaluate(CHART_STATE_JS, handle._impl.uuid)


def chart_ok(state: dict | None, handle) -> bool:
    if state is None or None in state["x"] + state["y"]:
        return False
    x_lo, x_hi = state["x"]
    return (
        all(math.isfinite(v) for v in state["x"] + state["y"])
        and x_lo == 0.0
        and x_hi >= float(handle.data[0][-1]) - 1e-9
        and state["n"] == len(handle.data[0])
        and state["series"] == len(handle.series)
    )


@pytest.mark.browser
def test_slider_scrubbed_in_the_browser(studio, page) -> None:
    panel = infer_panel(studio)
    controls = panel.controls
    choose(page, controls.primitive, "curved")
    choose(page, controls.demo, "curved_000")
    wait_until(lambda: controls.demo.value == "curved_000", timeout=30, what="the demo choice")
    click_slider(page, panel, 0.01)  # the track's left end: the first samples only
    wait_until(lambda: controls.percent.value <= 3, timeout=30, what="the slider at its start")
    early = wait_scrubbed(panel)
    assert_tube_drawn(studio, page, early)
    early_vertices = np.array(studio.scene.inference.tube.vertices)
    wait_until(lambda: bars_in_page(page) and abs(
        bars_in_page(page)["curved"] - early.inference.probabilities[0]) < 1e-4, timeout=30,
        what="the probability bars in the page",
    )  # fmt: skip
    click_slider(page, panel, 0.3)
    wait_until(lambda: 25 <= controls.percent.value <= 35, timeout=30, what="the slider near 30 %")
    later = wait_scrubbed(panel)
    assert later.observation.n_observed > early.observation.n_observed
    assert_tube_drawn(studio, page, later)
    moved = np.linalg.norm(np.array(studio.scene.inference.tube.vertices) - early_vertices, axis=1)
    assert moved.max() > 0.01, "the posterior tube did not change"
    assert np.abs(later.inference.probabilities - early.inference.probabilities).max() > 0.05
    wait_until(
        lambda: abs(bars_in_page(page)["curved"] - later.inference.probabilities[0]) < 1e-4,
        timeout=30, what="the new probabilities in the page",
    )  # fmt: skip
    # Keyboard: End (100 %) then ten steps left: 90 %.
    root, _ = slider_box(page, panel)
    root.get_by_role("slider").focus()
    page.keyboard.press("End")
    for _ in range(10):
        page.keyboard.press("ArrowLeft")
    wait_until(lambda: controls.percent.value == 90, timeout=30, what="the slider at 90 %")
    for primitive, demo in (("curved", "curved_000"), ("direct", "direct_006")):
        if controls.demo.value != demo:
            choose(page, controls.primitive, primitive)
            choose(page, controls.demo, demo)
        wait_until(lambda d=demo: controls.demo.value == d, timeout=30, what=f"{demo} chosen")
        result = wait_scrubbed(panel, 90)
        assert result.truth.name == demo
        assert result.inference.primitive == primitive, result.inference.probabilities
        status = page.get_by_text(f"Recognised: {primitive}")
        status.wait_for(timeout=30_000)
        bars = bars_in_page(page)
        assert max(bars, key=bars.get) == primitive


@pytest.mark.browser
def test_a_slider_moved_quickly_ends_on_the_tube_of_its_last_value(studio, page) -> None:
    """Bursts of clicks along the slider, each made without waiting for the studio: once a
    burst has settled, the result drawn is the one of the slider's last value, the 3D view's
    tube is that result's, and so is the page's."""
    panel = infer_panel(studio)
    controls = panel.controls
    for burst in ((0.2, 0.7, 0.35, 0.9, 0.5), (0.85, 0.1, 0.6), (0.3, 0.95, 0.15, 0.4)):
        _, box = slider_box(page, panel)
        for fraction in burst:
            page.mouse.click(box["x"] + fraction * box["width"], box["y"] + box["height"] / 2)
        last = burst[-1]
        # The slider's own value where the last click put it (a step of 1 %).
        wait_until(lambda f=last: abs(controls.percent.value - 100 * f) <= 4, timeout=60,
                   what=f"the slider near {100 * last:.0f} %")  # fmt: skip
        result = wait_scrubbed(panel)  # the panel's view of the slider's value
        assert result.inference is not None
        assert_tube_drawn(studio, page, result)
        drawn = studio.scene.inference.drawn.result
        assert panel.view.state.percent == controls.percent.value
        assert drawn.observation.n_observed == n_observed_for(
            controls.percent.value, drawn.truth.n_samples
        )


class ManualClock:
    """A monotonic clock that only moves when the test says."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


class ArmSampler:
    """Samples (time, arm configuration, replay progress, playing) every 10 ms in a thread."""

    def __init__(self, studio, panel) -> None:
        self.samples: list[tuple[float, np.ndarray, float, bool]] = []
        self._stop = threading.Event()

        def run() -> None:
            while not self._stop.is_set():
                replay = panel.playback.replay
                self.samples.append(
                    (time.monotonic(), studio.arm.q.copy(), replay.progress, replay.playing)
                )
                time.sleep(0.01)

        self._thread = threading.Thread(target=run, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()


def test_replay_plays_in_the_browser(studio, page) -> None:
    panel = infer_panel(studio)
    controls = panel.controls
    click_slider(page, panel, 0.2)
    wait_until(lambda: 15 <= controls.percent.value <= 25, timeout=30, what="the slider at 20 %")
    result = wait_scrubbed(panel)
    assert result.inference.remaining > 2.0

    def button(name: str, done=None) -> None:
        """A mouse click on the button where it is now (the lines above it change as the
        replay runs: a place found beforehand was once a click beside the button, under load).
        With ``done``, clicked again while ``done()`` stays false 10 s after a click: the button
        is redrawn as the replay runs, and a click on the element being replaced is lost (once
        in a loaded full run the pause never came, once the play never started)."""
        locator = page.get_by_role("button", name=name, exact=True)
        if done is None:
            press(page, locator)
        else:
            press_until(page, locator, done, name)

    # Pause and resume, on a clock the test moves: how far the replay gets between two clicks
    # must not depend on how busy the machine is.
    clock = ManualClock()
    panel.playback.replay.clock = clock

    def started() -> bool:
        return panel.playback.replay.playing or panel.playback.replay.finished

    try:
        button("Play", started)
        wait_until(lambda: panel.playback.replay.playing, timeout=30, what="the replay to start")
        clock.now += 0.3 * result.inference.remaining
        wait_until(lambda: panel.playback.replay.progress > 0.0, timeout=30,
                   what="the replay to advance")
        button("Pause", lambda: not panel.playback.replay.playing)
        assert 0.25 <= panel.playback.replay.progress <= 0.35, "paused where the clock was"
        q_paused = studio.arm.q.copy()
        clock.now += result.inference.remaining  # time passes while paused: the arm stays
        wait_frames(studio, 5)  # the loop steps the replay every frame: a paused one moves not
        assert_allclose(studio.arm.q, q_paused)
        assert panel.playback.replay.progress <= 0.35
        button("Play", started)
        wait_until(lambda: panel.playback.replay.playing, timeout=30, what="the replay to resume")
        clock.now += result.inference.remaining
        wait_until(lambda: panel.playback.replay.finished, timeout=60, what="the end of the replay")
    finally:
        panel.playback.replay.clock = time.monotonic
    # Then in real time, from the start.
    button("Reset", lambda: panel.playback.replay.progress == 0.0)
    wait_until(lambda: panel.playback.replay.progress == 0.0, timeout=30, what="the rewind")
    sampler = ArmSampler(studio, panel)
    try:
        button("Play", started)
        wait_until(lambda: panel.playback.replay.finished, timeout=60, what="the end of the replay")
    finally:
        sampler.stop()
    playing = [s for s in sampler.samples if s[3]]
    distinct = {tuple(np.round(q, 4)) for _, q, _, _ in playing}
    assert len(distinct) >= 5, "the arm did not move over time"
    progress = [p for _, _, p, _ in playing]
    assert all(b >= a for a, b in zip(progress, progress[1:], strict=False))
    # Real time at the predicted speed: the time spent playing is the predicted remainder.
    played = sum(
        b[0] - a[0] for a, b in zip(sampler.samples, sampler.samples[1:], strict=False) if a[3]
    )
    remaining = result.inference.remaining
    assert 0.7 * remaining <= played <= 1.5 * remaining + 1.0, played
    hand = studio.arm.hand_position()
    assert np.linalg.norm(hand - result.future.hand[-1]) < 0.01  # the predicted end, reached
    assert_allclose(studio.arm.gizmo.position, hand, atol=1e-5)  # the gizmo follows the hand
    button("Reset")
    wait_until(
        lambda: np.linalg.norm(studio.arm.hand_position() - result.future.hand[0]) < 0.01,
        timeout=30, what="the hand back at the observation point",
    )  # fmt: skip
    assert panel.playback.replay.progress == 0.0 and not panel.playback.replay.playing


@pytest.mark.browser
def test_infer_view_screenshot(browser, studio, page, artifacts) -> None:
    """The README's screenshot: a scrubbed state with the tube, the path, bars and charts (in
    a page of its own, at full resolution)."""
    panel = infer_panel(studio)
    controls = panel.controls
    client = page.client
    controls.session_mode.value = "faded"
    choose(page, controls.primitive, "curved")
    choose(page, controls.demo, "curved_002")
    click_slider(page, panel, 0.45)
    wait_until(lambda: 42 <= controls.percent.value <= 48, timeout=30, what="the slider at 45 %")
    result = wait_scrubbed(panel)
    assert result.truth.name == "curved_002"
    # the robot's hand at the observation point
    studio.loop.call(lambda: panel.playback.replay.reset())
    camera = dict(position=[-0.9, -0.45, 0.9], look_at=[-0.22, -0.15, 0.05], fov_deg=42.0)
    set_camera(client, **camera)
    with_tube = settled_render(client)
    controls.show_3d.value = False
    wait_until(lambda: not studio.scene.inference.tube.visible, timeout=30)
    without = settled_render(client, unlike=with_tube)
    controls.show_3d.value = True
    wait_until(lambda: studio.scene.inference.tube.visible, timeout=30)
    changed = np.abs(with_tube - without).sum(axis=2) > 30
    assert changed.mean() > 0.005, "the inference does not show in the rendered frame"
    shot, shot_client = open_page(browser, studio, dpr=1.0)
    try:
        open_tab(shot, "Infer")
        # The hand charts (the open chart tab) show the data the server holds, on finite scales.
        for handle in panel.charts.handles[:3]:
            wait_until(
                lambda h=handle: chart_ok(chart_in_page(shot, h), h), timeout=60,
                what="the chart drawn in the page",
            )  # fmt: skip
        shot.mouse.move(5, 450)  # away from the slider: no hover hint in the picture
        close_notifications(shot)
        start_view = shot.screenshot()
        set_camera(shot_client, **camera)
        path = artifacts / "infer.png"
        settled_screenshot(shot, path, unlike=start_view)
        assert path.stat().st_size > 50_000
    finally:
        shot.close()
    controls.session_mode.value = "shown"
