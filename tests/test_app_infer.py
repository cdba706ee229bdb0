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

from app.live.inference import (
    HeldOutModels,
    demo_observation,
    held_out_training,
    scrub_step,
)
from app.live.replay import Replay
from app.live.stream import LiveBuffer
from app.ui.display import observed_choices
from promp import metrics
from promp.data import Demonstration
from promp.inference import condition, predict
from promp.learn import fit
from promp.model import Settings
from promp.timing import n_observed_for
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT
from robots.icub.layout import hand_dims
from tests.browser import (
    choose,
    close_notifications,
    press,
    set_camera,
    settled_render,
    settled_screenshot,
)
from tests.conftest import open_page, start_studio, wait_until

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
    tests/test_evaluate.py; here it cost 40 choices, 70 s)."""
    model = fit(scenario, LAYOUT, SETTINGS)
    return dataclasses.replace(
        SETTINGS, **{name: getattr(model.settings, name) for name in SETTINGS.automatic}
    )


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


def test_held_out_model_never_sees_the_test_demo(scenario) -> None:
    models = HeldOutModels()
    model = models.get(0, scenario, "curved", "curved_003", SETTINGS, LAYOUT)
    assert model.primitive("curved").n_demos == len(scenario["curved"]) - 1
    assert model.primitive("direct").n_demos == len(scenario["direct"])
    assert models.get(0, scenario, "curved", "curved_003", SETTINGS, LAYOUT) is model  # cached
    # Whatever the test demonstration holds, the held-out model is the same.
    test = next(d for d in scenario["curved"] if d.name == "curved_003")
    corrupted = Demonstration(test.times, test.values + 0.3, test.columns, name=test.name)
    changed = {
        "curved": [corrupted if d.name == test.name else d for d in scenario["curved"]],
        "direct": scenario["direct"],
    }
    refit = models.get(1, changed, "curved", "curved_003", SETTINGS, LAYOUT)
    assert refit is not model
    assert_allclose(refit.primitive("curved").mean, model.primitive("curved").mean)
    assert_allclose(refit.primitive("curved").cov_factor, model.primitive("curved").cov_factor)
    # ... while the model learned with it is not.
    full = fit(scenario, LAYOUT, SETTINGS)
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
                obs = demo_observation(model, demo, 90, observed_choices(LAYOUT)[observed])
                result = scrub_step(model, obs, alpha, truth=demo)
                if result.primitive != primitive:
                    wrong.append((demo.name, observed, alpha, result.primitive))
                errors = [result.position_error_m, result.goal_error_m, result.duration_error_s]
                assert np.all(np.isfinite(errors)), (demo.name, observed, alpha, errors)
                assert result.position_error_m < 0.05 and result.goal_error_m < 0.05
                assert_allclose(result.probabilities.sum(), 1.0)
    assert not wrong, wrong


def test_scrub_step_geometry_and_errors(scenario, chosen) -> None:
    demo = scenario["direct"][7]
    model = held_out_model(scenario, "direct", demo.name, chosen)
    obs = demo_observation(model, demo, 40, ("hand", "head"))
    assert obs.n_observed == math.ceil(0.4 * demo.n_samples)
    result = scrub_step(model, obs, "ml", truth=demo)
    hand = hand_dims(LAYOUT)
    assert result.prior.mean.shape == result.posterior.mean.shape == (100, LAYOUT.n_dims)
    assert_allclose(result.observed_until, demo.times[obs.n_observed - 1] - demo.times[0])
    # The future path runs on the posterior mean from the observation point to the end.
    assert_allclose(result.future_times[[0, -1]], [result.observed_until, result.duration])
    assert_allclose(result.future_hand[-1], result.posterior.mean[-1, hand], atol=1e-9)
    at_obs = [
        np.interp(result.observed_until, result.posterior.times, result.posterior.mean[:, d])
        for d in hand
    ]
    assert_allclose(result.future_hand[0], at_obs, atol=2e-3)
    # It passes near the last observed hand position, and conditioning narrowed the spread there.
    assert np.linalg.norm(result.future_hand[0] - obs.values[-1, :3]) < 0.02
    k = np.searchsorted(result.posterior.times, result.observed_until) - 1
    assert np.all(result.posterior.std[k, hand] < result.prior.std[k, hand])
    # Errors are the evaluation's metrics.
    truth = LAYOUT.extract(demo)[:, hand]
    prim = model.primitive(result.primitive)
    natural = predict(model, condition(model, prim, obs, result.alpha), result.alpha).mean[:, hand]
    assert_allclose(
        result.position_error_m, metrics.remainder_error(truth, natural, obs.n_observed)
    )
    assert_allclose(result.goal_error_m, metrics.goal_error(truth, natural))
    assert_allclose(result.duration_error_s, abs(result.duration - demo.duration))
    # Nothing remains at 100 %: no remainder error; without the truth, no errors at all.
    full = scrub_step(model, demo_observation(model, demo, 100, ("hand",)), "ml", truth=demo)
    assert math.isnan(full.position_error_m) and math.isfinite(full.goal_error_m)
    live = scrub_step(model, obs, "model")
    assert math.isnan(live.goal_error_m) and math.isnan(live.true_duration)


def test_live_buffer_observation(scenario) -> None:
    demo = scenario["curved"][0]
    values = demo.select(COLUMNS)
    buffer = LiveBuffer(max_seconds=10.0)
    with pytest.raises(ValueError, match="nothing observed"):
        buffer.observation(100, ("hand",), LAYOUT)
    for t, row in zip(demo.times, values, strict=True):
        assert buffer.append(50.0 + t, row[:3], row[3:])
    assert not buffer.append(50.0 + 10.5, values[0, :3], values[0, 3:])  # full
    assert buffer.append(50.0, values[0, :3], None) and len(buffer) == demo.n_samples  # stale
    model = fit(scenario, LAYOUT, SETTINGS)
    for percent in (30, 100):
        live = buffer.observation(percent, ("hand", "head"), LAYOUT)
        ref = demo_observation(model, demo, percent, ("hand", "head"))
        assert_allclose(live.values, ref.values)
        assert_allclose(live.elapsed, ref.elapsed)
    # Samples without a face are left out when the head is observed, kept for the hand alone.
    buffer.clear()
    for i, (t, row) in enumerate(zip(demo.times, values, strict=True)):
        buffer.append(t, row[:3], None if i % 3 == 0 else row[3:])
    assert buffer.observation(100, ("hand",), LAYOUT).n_observed == demo.n_samples
    with_head = buffer.observation(100, ("head",), LAYOUT)
    assert with_head.n_observed == demo.n_samples - len(range(0, demo.n_samples, 3))
    buffer.clear()
    buffer.append(0.0, values[0, :3], None)
    with pytest.raises(ValueError, match="no face"):
        buffer.observation(100, ("hand", "head"), LAYOUT)


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
    replay.load(np.array([0.0, 4.0]), np.array([[0.0, 0.0, 0.0], [0.0, 0.4, 0.0]]), resume=True)
    assert replay.playing and replay.elapsed == 1.0  # a quarter of the new 4 s
    clock.t = 1.5
    replay.step()
    assert_allclose(moves[-1], [0.0, 0.2, 0.0])  # half of the new path after 1 s more
    clock.t = 10.0
    replay.step()
    assert replay.finished
    replay.load(np.array([0.0, 1.0]), np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), resume=True)
    assert not replay.playing and replay.elapsed == 0.0  # not playing: rewound


def moved_to(moves: list[np.ndarray], where: np.ndarray) -> bool:
    return bool(moves) and np.allclose(moves[-1], where)


# ---------------------------------------------------------------------- the tab in the studio


@pytest.fixture(scope="module")
def studio(tmp_path_factory):
    studio = start_studio(tmp_path_factory.mktemp("infer") / "workspace")
    panel = infer_panel(studio)
    wait_until(lambda: panel.scrub_count > 0, timeout=60, what="the first scrub step")
    yield studio
    studio.stop()


def infer_panel(studio):
    from app.panels.infer import InferPanel

    return next(p for p in studio.panels if isinstance(p, InferPanel))


def wait_scrubbed(panel, percent: int | None = None, timeout: float = 60.0):
    """Wait until the loop has scrubbed to the slider's value (or ``percent``)."""

    def done():
        result = panel.result
        if result is None or result.truth is None or result.truth.name != panel.demo.value:
            return None
        wanted = panel.percent.value if percent is None else percent
        if panel.percent.value != wanted:
            return None
        n_o = n_observed_for(wanted, result.truth.n_samples)
        return result if result.observation.n_observed == n_o and not panel._dirty else None

    return wait_until(done, timeout=timeout, what=f"a scrub step at {percent or 'the slider'} %")


def test_scrub_from_python_and_bad_replay(studio, monkeypatch) -> None:
    """GUI logic without a browser: the slider's callback only marks dirty, the loop scrubs;
    Play with nothing to replay says so and moves nothing."""
    from app.panels.infer import LIVE, TEST

    panel = infer_panel(studio)
    panel.percent.value = 37
    result = wait_scrubbed(panel, 37)
    assert result.truth.name == panel.demo.value and panel.scrub_ms > 0
    assert f"{panel.scrub_ms:.1f} ms" in panel.status.content
    notes = []
    quiet = dataclasses.replace(
        panel.ctx, notify=lambda title, body, color="blue": notes.append(title)
    )
    monkeypatch.setattr(panel, "ctx", quiet)
    panel.source.value = LIVE
    wait_until(lambda: panel.result is None and "nothing observed" in panel.message, timeout=30)
    q = studio.arm.q.copy()
    panel.replay_buttons.value = "Play"
    wait_until(lambda: notes, timeout=30, what="a notification")
    assert notes == ["Nothing to replay"]
    assert_allclose(studio.arm.q, q)
    panel.source.value = TEST
    wait_scrubbed(panel)


@pytest.mark.parametrize("primitive", ["curved", "direct"])
def test_live_stream_follows_the_dragged_hand(studio, scenario, primitive) -> None:
    """Observing the live stream: the hand moved along a demonstration at its own speed
    (through the arm's IK, as a drag does) is recognised from the hand alone.

    The panel's clock is a manual one that the test sets to the demonstration's time of each
    sample once the hand is there, so the stream holds exactly the demonstration's samples up
    to 60 % of the movement however busy the machine is (with the wall clock, a starved loop
    took fewer samples than the demonstration has)."""
    from app.panels.infer import LIVE, TEST

    panel = infer_panel(studio)
    demo = scenario[primitive][4]
    hand = LAYOUT.extract(demo)[:, :3]
    panel.source.value = LIVE
    panel.observed.value = "hand"
    panel.percent.value = 100
    studio.call_in_loop(lambda: studio.arm.move_hand_to(hand[0]))
    wait_until(
        lambda: np.linalg.norm(studio.arm.hand_position() - hand[0]) < 5e-3,
        timeout=30, what="the hand at the start",
    )  # fmt: skip
    now = [1000.0 + demo.times[0]]
    panel.clock = lambda: now[0]
    try:
        panel.live_button.value = True  # "Start observing"
        wait_until(lambda: panel.observing and len(panel.live) == 1, timeout=30,
                   what="observing to start")  # fmt: skip
        # The user's drag: each of the demonstration's samples up to 60 % of the movement,
        # stamped with its own time once the IK has put the hand there.
        n_drive = int(np.searchsorted(demo.times, demo.times[0] + 0.6 * demo.duration))
        for k in range(1, n_drive):
            studio.call_in_loop(lambda p=hand[k]: studio.arm.move_hand_to(p))
            wait_until(
                lambda p=hand[k]: np.linalg.norm(studio.arm.hand_position() - p) < 5e-3,
                timeout=30, what=f"the hand at sample {k}",
            )  # fmt: skip
            now[0] = 1000.0 + demo.times[k]
            wait_until(lambda k=k: len(panel.live) == k + 1, timeout=30,
                       what=f"sample {k} in the live buffer")  # fmt: skip
            if k == 6:
                wait_until(
                    lambda: panel.result is not None and panel.result.observation.n_observed > 5,
                    timeout=30, what="a live inference",
                )  # fmt: skip
        panel.live_button.value = True  # "Stop observing"
        wait_until(lambda: not panel.observing and not panel._dirty, timeout=30)
        wait_until(lambda: panel.result is not None, timeout=30, what="the final live inference")
    finally:
        panel.clock = time.monotonic
    result = panel.result
    assert result.truth is None and result.observation.modalities == ("hand",)
    assert result.observation.n_observed == len(panel.live) == n_drive > 20
    assert_allclose(result.observation.times, demo.times[:n_drive] - demo.times[0], atol=1e-9)
    assert result.primitive == primitive, result.probabilities
    assert f"Recognised: {primitive}" in panel.status.content
    panel.observed.value = "hand + head"
    panel.source.value = TEST
    wait_scrubbed(panel)


# ---------------------------------------------------------------------- real browser


@pytest.fixture(scope="module")
def page(browser, studio):
    page, client = open_page(browser, studio)
    press(page, page.get_by_role("tab", name="Infer"))
    page.client = client  # type: ignore[attr-defined]
    yield page
    page.close()


def slider_box(page, panel):
    root = page.locator(f"[id='{panel.percent._impl.uuid}']")
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
    choose(page, panel.primitive, "curved")
    choose(page, panel.demo, "curved_000")
    wait_until(lambda: panel.demo.value == "curved_000", timeout=30, what="the demo choice")
    click_slider(page, panel, 0.01)  # the track's left end: the first samples only
    wait_until(lambda: panel.percent.value <= 3, timeout=30, what="the slider at its start")
    early = wait_scrubbed(panel)
    early_vertices = np.array(studio.scene.inference.tube.vertices)
    wait_until(lambda: bars_in_page(page) and abs(
        bars_in_page(page)["curved"] - early.probabilities[0]) < 1e-4, timeout=30,
        what="the probability bars in the page",
    )  # fmt: skip
    click_slider(page, panel, 0.3)
    wait_until(lambda: 25 <= panel.percent.value <= 35, timeout=30, what="the slider near 30 %")
    later = wait_scrubbed(panel)
    assert later.observation.n_observed > early.observation.n_observed
    moved = np.linalg.norm(np.array(studio.scene.inference.tube.vertices) - early_vertices, axis=1)
    assert moved.max() > 0.01, "the posterior tube did not change"
    assert np.abs(later.probabilities - early.probabilities).max() > 0.05
    wait_until(
        lambda: abs(bars_in_page(page)["curved"] - later.probabilities[0]) < 1e-4,
        timeout=30, what="the new probabilities in the page",
    )  # fmt: skip
    # Keyboard: End (100 %) then ten steps left: 90 %.
    root, _ = slider_box(page, panel)
    root.get_by_role("slider").focus()
    page.keyboard.press("End")
    for _ in range(10):
        page.keyboard.press("ArrowLeft")
    wait_until(lambda: panel.percent.value == 90, timeout=30, what="the slider at 90 %")
    for primitive, demo in (("curved", "curved_000"), ("direct", "direct_006")):
        if panel.demo.value != demo:
            choose(page, panel.primitive, primitive)
            choose(page, panel.demo, demo)
        wait_until(lambda d=demo: panel.demo.value == d, timeout=30, what=f"{demo} chosen")
        result = wait_scrubbed(panel, 90)
        assert result.truth.name == demo
        assert result.primitive == primitive, result.probabilities
        status = page.get_by_text(f"Recognised: {primitive}")
        status.wait_for(timeout=30_000)
        bars = bars_in_page(page)
        assert max(bars, key=bars.get) == primitive


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
                replay = panel.replay
                self.samples.append(
                    (time.monotonic(), studio.arm.q.copy(), replay.progress, replay.playing)
                )
                time.sleep(0.01)

        self._thread = threading.Thread(target=run, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()


@pytest.mark.browser
def test_replay_plays_in_the_browser(studio, page) -> None:
    panel = infer_panel(studio)
    click_slider(page, panel, 0.2)
    wait_until(lambda: 15 <= panel.percent.value <= 25, timeout=30, what="the slider at 20 %")
    result = wait_scrubbed(panel)
    assert result.remaining > 2.0
    def button(name: str) -> None:
        """A mouse click on the button where it is now (the lines above it change as the
        replay runs: a place found beforehand was once a click beside the button, under load)."""
        press(page, page.get_by_role("button", name=name, exact=True))

    # Pause and resume, on a clock the test moves: how far the replay gets between two clicks
    # must not depend on how busy the machine is.
    clock = ManualClock()
    panel.replay.clock = clock
    try:
        button("Play")
        wait_until(lambda: panel.replay.playing, timeout=30, what="the replay to start")
        clock.now += 0.3 * result.remaining
        wait_until(lambda: panel.replay.progress > 0.0, timeout=30, what="the replay to advance")
        button("Pause")
        wait_until(lambda: not panel.replay.playing, timeout=30, what="the pause")
        assert 0.25 <= panel.replay.progress <= 0.35, "paused where the clock was"
        q_paused = studio.arm.q.copy()
        clock.now += result.remaining  # time passes while paused: the arm stays
        time.sleep(0.3)
        assert_allclose(studio.arm.q, q_paused)
        assert panel.replay.progress <= 0.35
        button("Play")
        wait_until(lambda: panel.replay.playing, timeout=30, what="the replay to resume")
        clock.now += result.remaining
        wait_until(lambda: panel.replay.finished, timeout=60, what="the end of the replay")
    finally:
        panel.replay.clock = time.monotonic
    # Then in real time, from the start.
    button("Reset")
    wait_until(lambda: panel.replay.progress == 0.0, timeout=30, what="the rewind")
    sampler = ArmSampler(studio, panel)
    try:
        button("Play")
        wait_until(lambda: panel.replay.playing, timeout=30, what="the replay to start")
        wait_until(lambda: panel.replay.finished, timeout=60, what="the end of the replay")
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
    assert 0.7 * result.remaining <= played <= 1.5 * result.remaining + 1.0, played
    hand = studio.arm.hand_position()
    assert np.linalg.norm(hand - result.future_hand[-1]) < 0.01  # the predicted end, reached
    assert_allclose(studio.arm.gizmo.position, hand, atol=1e-5)  # the gizmo follows the hand
    button("Reset")
    wait_until(
        lambda: np.linalg.norm(studio.arm.hand_position() - result.future_hand[0]) < 0.01,
        timeout=30, what="the hand back at the observation point",
    )  # fmt: skip
    assert panel.replay.progress == 0.0 and not panel.replay.playing


@pytest.mark.browser
def test_infer_view_screenshot(browser, studio, page, artifacts) -> None:
    """The README's screenshot: a scrubbed state with the tube, the path, bars and charts (in
    a page of its own, at full resolution)."""
    panel = infer_panel(studio)
    client = page.client
    panel.session_mode.value = "faded"
    choose(page, panel.primitive, "curved")
    choose(page, panel.demo, "curved_002")
    click_slider(page, panel, 0.45)
    wait_until(lambda: 42 <= panel.percent.value <= 48, timeout=30, what="the slider at 45 %")
    result = wait_scrubbed(panel)
    assert result.truth.name == "curved_002"
    studio.call_in_loop(lambda: panel.replay.reset())  # the robot's hand at the observation point
    camera = dict(position=[-0.9, -0.45, 0.9], look_at=[-0.22, -0.15, 0.05], fov_deg=42.0)
    set_camera(client, **camera)
    with_tube = settled_render(client)
    panel.show_3d.value = False
    wait_until(lambda: not studio.scene.inference.tube.visible, timeout=30)
    without = settled_render(client, unlike=with_tube)
    panel.show_3d.value = True
    wait_until(lambda: studio.scene.inference.tube.visible, timeout=30)
    changed = np.abs(with_tube - without).sum(axis=2) > 30
    assert changed.mean() > 0.005, "the inference does not show in the rendered frame"
    shot, shot_client = open_page(browser, studio, dpr=1.0)
    try:
        press(shot, shot.get_by_role("tab", name="Infer"))
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
    panel.session_mode.value = "shown"
