"""The Teach tab: recording by dragging the hand in a real browser, the demonstration
list, primitives, head sources, learning settings, two tabs, and SIGKILL + restart; plus the
recorder and the uPlot band helpers without a browser."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.core.session import Session
from app.io.workspace import Workspace
from app.live.recorder import MAX_GAP_S, Recorder, Recording
from app.live.take_controller import COUNTDOWN_S
from app.live.takes import mean_start
from app.panels.teach.head import MAX_VIDEO_BYTES
from app.studio import default_workspace
from app.ui.charts import Band, Trace, band_chart, y_range
from promp.datasets import read_csv_demo
from promp.units import amount
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT
from tests.browser import (
    close_notifications,
    drag_gizmo,
    screenshot,
    server_caught_up,
    set_camera,
    settled_screenshot,
)
from tests.conftest import FITS, REPO, open_page, wait_until

# ====================================================================== without a browser


def _recording(times, head_rows) -> Recording:
    times = np.asarray(times, dtype=float)
    hand = np.column_stack([times, 2 * times, -times])
    return Recording(times, hand, np.asarray(head_rows, dtype=float))


def test_head_gaps_are_interpolated_between_readings_and_held_at_the_ends() -> None:
    t = np.arange(8) * 0.02
    nan = [np.nan] * 3
    head = [nan, [0.0, 1.0, 2.0], [0.2, 1.0, 2.0], nan, nan, [0.8, 1.6, 2.0], [1.0, 1.6, 2.0], nan]
    values, fill = _recording(t, head).values()
    np.testing.assert_allclose(values[:, :3], np.column_stack([t, 2 * t, -t]))
    np.testing.assert_allclose(values[:, 3], [0.0, 0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.0])
    np.testing.assert_allclose(values[:, 4], [1.0, 1.0, 1.0, 1.2, 1.4, 1.6, 1.6, 1.6])
    assert np.all(np.isfinite(values))
    assert fill.n_filled == 4 and fill.n_samples == 8
    assert "no face in 4 of 8 samples" in fill.message


def test_a_recording_without_any_face_or_with_a_long_gap_is_refused() -> None:
    t = np.arange(100) * 0.02
    with pytest.raises(ValueError, match="no face during the whole recording"):
        _recording(t, np.full((100, 3), np.nan)).values()
    head = np.zeros((100, 3))
    head[20:60] = np.nan  # 0.8 s without a face
    with pytest.raises(ValueError, match=r"lost for 0\.8 s \(from 0\.4 s to 1\.2 s"):
        _recording(t, head).values()
    head = np.zeros((100, 3))
    head[:30] = np.nan  # the first 0.6 s
    with pytest.raises(ValueError, match="lost for 0.6 s"):
        _recording(t, head).values()
    head = np.zeros((100, 3))
    head[20:30] = np.nan  # 0.22 s: filled
    assert _recording(t, head).values()[1].longest_gap_s < MAX_GAP_S
    with pytest.raises(ValueError, match="at least 2 are needed"):
        _recording([0.0], [[0.0, 0.0, 0.0]]).values()


def test_recorder_samples_at_its_rate_what_the_sampler_reads() -> None:
    """On the recorder's own clock: a sample per tick, 10 ms apart at 100 Hz, each what the
    sampler says was current at that tick; ticks the thread reaches late (a loaded machine)
    are sampled as they were, not left out; only ticks the sampler cannot tell any more
    (``LookupError``: older than the studio's histories) are skipped, and counted. The clock
    is scripted (a loaded machine changes how long the test takes, not what it sees); with
    the real clock, the recorder never samples faster than its rate."""
    period, late_read, lost = 0.01, 40, (0.30, 0.33)

    class Clock:  # each read moves on by half a period; one read finds the thread 3.6 late
        def __init__(self) -> None:
            self.now, self.reads = 0.0, 0

        def __call__(self) -> float:
            self.reads += 1
            self.now += (3.6 if self.reads == late_read else 0.5) * period
            return self.now

    def sample(t: float):
        if lost[0] <= t < lost[1]:
            raise LookupError("older than the histories keep")
        tick = round(t / period)
        return np.array([t, 0.0, 0.0]), (None if tick % 5 == 4 else np.array([0.1, 0.2, 0.3]))

    recorder = Recorder(sample, rate_hz=100.0, clock=Clock())
    recorder.start()
    wait_until(lambda: recorder.n_samples >= 60, timeout=60, what="60 samples")
    recording = recorder.stop()
    n = recording.n_samples
    assert n >= 60 and not recorder.running and recorder.skipped == 3
    steps = np.diff(recording.times)
    expected = np.full(n - 1, period)
    gap = int(round(lost[0] / period)) - int(round(recording.hand[0, 0] / period)) - 1
    expected[gap] = 4 * period  # the three ticks the sampler could not tell
    np.testing.assert_allclose(steps, expected, atol=1e-9)
    # Each sample is the sampler's value at its own tick (the late ones too).
    np.testing.assert_allclose(recording.hand[:, 0] - recording.hand[0, 0], recording.times,
                               atol=1e-12)  # fmt: skip
    ticks = np.round(recording.hand[:, 0] / period).astype(int)
    assert np.isnan(recording.head[ticks % 5 == 4]).all()
    assert not np.isnan(recording.head[ticks % 5 != 4]).any()
    stopped_at = recorder.n_samples
    wait_until(lambda: not recorder.running, timeout=10, what="the recorder's thread to end")
    assert recorder.n_samples == stopped_at, "a stopped recorder must not sample"
    with pytest.raises(ValueError, match="already been started"):
        recorder.start()
    with pytest.raises(ValueError, match="1-1000 Hz"):
        Recorder(sample, rate_hz=0.0)
    # The real clock: however busy the machine, never more samples than ticks that passed.
    started = time.monotonic()
    recorder = Recorder(lambda t: (np.zeros(3), np.zeros(3)), rate_hz=100.0)
    recorder.start()
    wait_until(lambda: recorder.n_samples >= 20, timeout=60, what="20 samples")
    real = recorder.stop()
    assert real.n_samples <= (time.monotonic() - started) / period + 1


def test_band_chart_shares_one_grid_and_leaves_nan_only_outside_each_span() -> None:
    t1, t2 = np.linspace(0.0, 2.0, 5), np.linspace(0.0, 3.0, 4)
    band = Band("a", t1, t1**2, 0.1 * np.ones(5), (200, 10, 10))
    other = Band("b", t2, -t2, np.zeros(4), (10, 10, 200))
    samples = Trace(
        "observed", np.array([0.25, 0.75]), np.array([1.0, 2.0]), (0, 0, 0), points=True
    )
    truth = Trace("truth", np.array([1.0, 2.5]), np.array([5.0, 6.0]), (0, 90, 0), dash=(4, 2))
    chart = band_chart([band, other], [samples, truth])
    grid = chart.grid
    np.testing.assert_array_equal(grid, np.unique(np.concatenate([t1, t2, [0.25, 0.75, 2.5]])))
    assert len(chart.data) == len(chart.series) == 1 + 3 * 2 + 2
    assert {len(d) for d in chart.data} == {len(grid)}
    upper, lower, mean = chart.data[1:4]
    inside = grid <= 2.0
    np.testing.assert_allclose(mean[inside], np.interp(grid[inside], t1, t1**2))
    np.testing.assert_allclose(upper[inside] - lower[inside], 0.4)
    assert np.isnan(mean[~inside]).all()  # the mean line ends with its span
    np.testing.assert_array_equal(upper[~inside], 4.0)  # the band has zero width beyond it
    np.testing.assert_array_equal(lower[~inside], 4.0)
    assert all(np.isfinite(chart.data[i]).all() for i in (1, 2, 4, 5))  # edges: never NaN
    assert chart.bands[0]["series"] == (1, 2) and chart.bands[1]["series"] == (4, 5)
    observed = chart.data[7]
    assert np.count_nonzero(np.isfinite(observed)) == 2
    np.testing.assert_array_equal(observed[np.searchsorted(grid, [0.25, 0.75])], [1.0, 2.0])
    truth_line = chart.data[8]
    span = (grid >= 1.0) & (grid <= 2.5)
    assert np.isfinite(truth_line[span]).all() and np.isnan(truth_line[~span]).all()
    assert chart.series[8]["dash"] == (4.0, 2.0)
    lo, hi = chart.y_range
    finite = np.concatenate([d[np.isfinite(d)] for d in chart.data[1:]])
    assert lo < finite.min() and hi > finite.max()
    assert chart.scales == {"x": {"time": False, "range": (0.0, 3.0)}, "y": {"range": (lo, hi)}}


def test_band_chart_rejects_bad_input() -> None:
    t = np.linspace(0, 1, 3)
    with pytest.raises(ValueError, match="finite"):
        Band("a", t, np.array([0.0, np.nan, 1.0]), np.zeros(3), (0, 0, 0))
    with pytest.raises(ValueError, match="strictly increasing"):
        Trace("a", np.array([0.0, 0.0, 1.0]), np.zeros(3), (0, 0, 0))
    with pytest.raises(ValueError, match="std must be >= 0"):
        Band("a", t, np.zeros(3), -np.ones(3), (0, 0, 0))
    with pytest.raises(ValueError, match="colour"):
        Trace("a", t, np.zeros(3), (0, 0, 300))
    with pytest.raises(ValueError, match="at least one band or trace"):
        band_chart([])
    assert y_range([np.array([2.0, 2.0])]) == pytest.approx((1.88, 2.12))


def test_default_workspace_refits_every_primitive_and_reports_the_time(tmp_path) -> None:
    """The refit's speed is measured by ``bench/scrub.py`` (``refit_ms_median``), not here."""
    session = Session.open(tmp_path / "ws", default=default_workspace, fits=FITS)
    assert sum(len(d) for d in session.store.state.demos.values()) == 40
    model = session.refit()
    assert model is not None and tuple(model.names) == ("curved", "direct")
    assert model.report["settings"]["chosen"]  # the automatic settings, chosen
    assert model.basis.n_basis == model.settings.n_basis and session.learner.state.fit_ms > 0.0
    assert not session.learner.state.reused
    session.close()


# ====================================================================== in a real browser




def panel(studio):
    from app.panels.teach import TeachPanel

    return next(p for p in studio.panels if isinstance(p, TeachPanel))


def text(page) -> str:
    return page.inner_text("body")


def wait_text(page, wanted: str, timeout: float = 60.0, present: bool = True) -> None:
    what = f"{wanted!r} to {'appear' if present else 'disappear'}"
    wait_until(lambda: (wanted in text(page)) == present, timeout=timeout, what=what)


def store(studio):
    """The studio's workspace now (the store's state)."""
    return studio.session.store.state


def fit_shown(session) -> str:
    """What the Learn folder says of the learner's latest fit."""
    learned = session.learner.state
    if learned.reused:
        return f"the same as a recent fit ({learned.fit_ms:.0f} ms)"
    return f"Fit in {learned.fit_ms:.0f} ms"


def row(page, label: str):
    """The GUI row (label + control) whose label contains ``label``."""
    return page.locator("label", has_text=label).first.locator(
        "xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]"
    )


def type_name(page, studio, name: str) -> None:
    """Type into the Name field and wait until the server has it (viser throttles text
    updates to 50 ms, so an immediate click could overtake them)."""
    row(page, "Name").locator("input").first.fill(name)
    field = panel(studio).primitives.new_name
    wait_until(lambda: field.value == name, what=f"the name {name!r} typed")


def choose(page, label: str, option: str) -> None:
    """Pick ``option`` in a dropdown (scrolled into view first: the options list hides while
    its input is scrolled out of the panel)."""
    field = row(page, label).locator("input").first
    field.evaluate("e => e.scrollIntoView({block: 'center'})")
    field.dispatch_event("click")
    page.get_by_role("option", name=option, exact=True).dispatch_event("click")


def click(page, name: str) -> None:
    """Click a GUI button. A DOM click event: Playwright's actionability checks wait for
    animation frames, which software WebGL on a loaded machine makes take seconds each."""
    page.get_by_role("button", name=name, exact=True).first.dispatch_event("click")


# Records every digit the countdown shows (a MutationObserver sees each DOM change, however
# slowly the page is polled).
COUNTDOWN_OBSERVER = """() => {
    window.__countdown = [];
    new MutationObserver(() => {
        const shown = document.querySelector("div[style*='font-size: 2.4em']");
        if (shown) window.__countdown.push(shown.innerText);
    }).observe(document.body, {subtree: true, childList: true, characterData: true});
}"""


def drag_hand(page, client, studio, direction, pixels: float, steps: int = 4) -> None:
    """Drag the hand's gizmo with the real mouse along the world ``direction``
    (:func:`tests.browser.drag_gizmo`)."""
    drag_gizmo(page, client, studio.arm.gizmo, direction, pixels, steps)


UP = (0.0, 0.0, 1.0)


def side_camera(client) -> None:
    """From the robot's left, behind it: the gizmo's arrows and rings apart on screen, for
    the drags (the studio's start view looks from the partner's side, where they overlap);
    returns once the browser reports the new camera."""
    set_camera(client, [0.3, -1.5, 0.85], [-0.3, -0.12, 0.12], fov_deg=50.0)


def test_the_head_source_stays_during_a_recording(studio) -> None:
    """GUI logic, driven from Python (setting a value runs its callbacks)."""
    from app.live.head import SimulatedPartner

    teach = panel(studio)
    source = studio.head.source
    assert isinstance(source, SimulatedPartner)
    teach.record.press()
    wait_until(lambda: teach.record.take is not None, what="the countdown")
    teach.head.controls.source.value = "Camera"
    assert teach.head.controls.source.value == "Simulated partner" and studio.head.source is source
    teach.record.press()  # cancel
    wait_until(lambda: teach.record.take is None, what="the cancellation")
    wait_until(lambda: teach.record.controls.button.label == "Record",
               what="the Record button back")  # fmt: skip
    assert "Recording cancelled." in teach.record.controls.status.content


def face_video(path: Path, seconds: float = 4.0) -> Path:
    """A video of a face rolling from -10 to 10 degrees (15 frames/s) at ``path``."""
    from skimage.data import astronaut

    from app.headpose.synthetic import ASTRONAUT_FACE_CENTRE, place_face

    face = np.ascontiguousarray(astronaut()[:, :, ::-1])
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (640, 480))
    for roll in np.linspace(-10, 10, round(15 * seconds)):
        writer.write(place_face(face, ASTRONAUT_FACE_CENTRE, (640, 480), roll_deg=roll, scale=1.5))
    writer.release()
    return path


def test_the_source_shown_is_the_head_source_in_use(installed, studio, tmp_path) -> None:
    """GUI logic, driven from Python: a video uploaded while Source says Simulated partner
    (viser's page shows the upload button whatever the Source chosen), a video file or a
    camera put in use (as the command line's --video and --camera do): Source, the camera
    index or the video's path, and the status line say which."""
    from app.live.head import SimulatedPartner, StreamHeadSource, TrackHeadSource
    from app.ui.text import escape

    head = panel(studio).head
    c = head.controls
    assert c.source.value == "Simulated partner"
    path = face_video(tmp_path / "face.avi", seconds=2.0)
    try:
        head.process("face.avi", path.read_bytes())  # what the upload button's callback does
        wait_until(lambda: isinstance(studio.head.source, TrackHeadSource), timeout=120,
                   what="the uploaded video in use")  # fmt: skip
        wait_until(lambda: c.source.value == "Uploaded video", what="Source: Uploaded video")
        assert not c.upload.disabled
        wait_until(lambda: "uploaded video face.avi" in c.status.content,
                   what="the status naming the uploaded video")  # fmt: skip
        studio.head.use(StreamHeadSource(str(path)))
        wait_until(lambda: c.source.value == "Video file", what="Source: Video file")
        assert c.video_path.value == str(path) and c.video_path.visible
        assert c.upload.disabled  # (viser's page shows it whatever its visible)
        wait_until(lambda: escape(f"video {path}") in c.status.content,
                   what="the status naming it")  # fmt: skip
        studio.head.use(StreamHeadSource(7))  # no such camera: in use, failing
        wait_until(lambda: c.source.value == "Camera", what="Source: Camera")
        assert c.camera_index.value == 7 and c.camera_index.visible
        wait_until(lambda: "camera 7" in c.status.content, what="the status naming it")
    finally:
        studio.head.use(SimulatedPartner())
        wait_until(lambda: c.source.value == "Simulated partner", what="Source: simulated")


@pytest.mark.browser
def test_panel_lists_primitives_demonstrations_and_prior_plots(studio, page) -> None:
    # the page may still be building its panel when the test starts (a loaded machine)
    for wanted in ("Primitive", "Record", "Head source", "Learn", "Prior of curved",
                   "20 demonstration(s) of curved", "simulated partner: tracking"):
        wait_text(page, wanted)
    charts = page.evaluate("Object.keys(window.__viserTestpoints?.uplots ?? {}).length")
    assert charts >= 6
    wait_text(page, fit_shown(studio.session))


@pytest.mark.browser
def test_record_a_demonstration_by_dragging_the_hand(studio, page, artifacts) -> None:
    client = page.client
    teach = panel(studio)
    assert teach.primitives.selected() == "curved"
    tube_before = np.array(studio.scene.workspace.tubes["curved"].vertices)
    q_before, hand_before = studio.arm.q.copy(), studio.arm.hand_position()
    side_camera(client)
    page.evaluate(COUNTDOWN_OBSERVER)
    click(page, "Record")
    wait_text(page, "● Recording into curved")
    seen = page.evaluate("window.__countdown")
    digits = [d for i, d in enumerate(seen) if i == 0 or d != seen[i - 1]]
    assert digits == ["3", "2", "1"], f"countdown shown: {seen}"
    drag_hand(page, client, studio, UP, pixels=110)
    wait_until(lambda: teach.record.takes.recording().duration > 2.2, what="a 2.2 s recording")
    assert np.abs(studio.arm.q - q_before).max() > 0.05, "the arm did not follow the gizmo"
    assert studio.arm.hand_position()[2] - hand_before[2] > 0.05, "the hand did not go up 5 cm"
    close_notifications(page)
    page.screenshot(path=str(artifacts / "teach_recording.png"))
    click(page, "Stop")
    wait_text(page, "Saved curved_020")
    demo = store(studio).demos["curved"][-1]
    assert demo.name == "curved_020"
    hand = demo.select(("x", "y", "z"))
    assert np.ptp(hand[:, 2]) > 0.05, "the recorded hand does not move"
    assert 0.015 < demo.sample_period < 0.025  # 50 Hz
    assert np.all(np.isfinite(demo.values))
    # Listed with its typicality (the list shows it at the loop's next step), drawn, on disk,
    # and the prior changed.
    wait_until(lambda: row(page, "curved_020").count() == 1, what="the take listed")

    def listed() -> str | None:  # the label, once the learner has scored the take
        score = studio.session.snapshot().typicality.get(("curved", "curved_020"))
        if score is None:
            return None
        return f" · {'⚠ ' if score.label != 'typical' else ''}{score.label}"

    # (after any finding's mark: a drag made on a busy machine may be flagged)
    wait_until(lambda: listed() is not None and listed() in row(page, "curved_020").inner_text(),
               timeout=60, what=lambda: f"{listed()!r} in the take's row")  # fmt: skip
    wait_text(page, "21 demonstration(s) of curved")
    lines = studio.scene.workspace.lines  # drawn by the loop once the session has it
    key = ("curved", "curved_020")
    wait_until(lambda: key in lines and lines[key].visible, what="the new demonstration's line")
    path = store(studio).workspace.demo_path("curved", "curved_020")
    on_disk = read_csv_demo(path)
    np.testing.assert_allclose(on_disk.select(demo.columns), demo.values, atol=1e-9)
    tubes = studio.scene.workspace.tubes
    # Straight up, where curved's takes go to the bin: flagged for where it ends, said in
    # centimetres, left out of learning (the prior unchanged) until kept.
    end = next(f for f in store(studio).findings_of(*key) if f.kind == "end")
    wait_text(page, f"hand ends {amount(end.size, 'm')} from where curved's other takes end")
    assert key in store(studio).left_out and "⚠ left out" in row(page, "curved_020").inner_text()
    row(page, "curved_020").get_by_role("button", name="Keep").dispatch_event("click")

    def why() -> str:
        state = store(studio)
        learner = studio.session.learner.state
        return (f"the prior tube of curved to change (left out: {dict(state.left_out)}; "
                f"learned from version {learner.learn_version} of {state.learn_version}, "
                f"{learner.n_demos} demonstrations)")  # fmt: skip

    wait_until(
        lambda: not np.allclose(np.array(tubes["curved"].vertices), tube_before), what=why
    )
    assert key not in store(studio).left_out and "kept despite findings" in row(
        page, "curved_020").inner_text()  # fmt: skip


@pytest.mark.browser
def test_hide_and_delete_a_demonstration(studio, page) -> None:
    lines = studio.scene.workspace.lines
    line = wait_until(lambda: lines.get(("curved", "curved_020")), what="the line of curved_020")
    row(page, "curved_020").get_by_role("button", name="Hide").dispatch_event("click")
    wait_until(lambda: ("curved", "curved_020") in studio.session.snapshot().hidden,
               what="the demo to be hidden")  # fmt: skip
    wait_until(lambda: not line.visible, what="its line to be hidden")
    wait_until(lambda: "hidden" in row(page, "curved_020").inner_text(), what="'hidden' shown")
    row(page, "curved_020").get_by_role("button", name="Show").dispatch_event("click")
    wait_until(lambda: line.visible, what="its line to be shown again")
    wait_until(lambda: "hidden" not in row(page, "curved_020").inner_text(), what="'Hide' back")
    path = store(studio).workspace.demo_path("curved", "curved_020")
    content = path.read_bytes()
    # Deleting asks first; keeping it changes nothing.
    row(page, "curved_020").get_by_role("button", name="Delete").dispatch_event("click")
    wait_text(page, "Delete curved_020 of curved? It moves to the workspace's trash")
    click(page, "Keep it")
    wait_text(page, "Delete curved_020 of curved?", present=False)
    assert path.exists() and len(store(studio).demos["curved"]) == 21
    row(page, "curved_020").get_by_role("button", name="Delete").dispatch_event("click")
    click(page, "Delete demonstration")
    wait_text(page, "20 demonstration(s) of curved")
    assert not path.exists()
    assert [d.name for d in store(studio).demos["curved"]][-1] == "curved_019"
    assert ("curved", "curved_020") not in studio.scene.workspace.lines
    wait_until(lambda: row(page, "curved_020").count() == 0, what="the take no longer listed")
    # Undo brings it back, byte for byte, line and all.
    click(page, "Undo delete (curved_020 of curved)")
    wait_text(page, "21 demonstration(s) of curved")
    assert path.read_bytes() == content
    lines = studio.scene.workspace.lines
    wait_until(lambda: ("curved", "curved_020") in lines, what="its line back")
    assert list(store(studio).trash) == []
    # Deleted for good from the GUI's point of view: in the trash, kept on disk.
    row(page, "curved_020").get_by_role("button", name="Delete").dispatch_event("click")
    click(page, "Delete demonstration")
    wait_text(page, "20 demonstration(s) of curved")
    (entry,) = list(store(studio).trash)
    trash = store(studio).workspace.trash.root
    assert (trash / entry.name / "files" / "demos/curved/curved_020.csv"
            ).read_bytes() == content  # fmt: skip


def wait_at_rest(studio, where: str) -> None:
    """Until the hand moves less than 1 mm in 0.2 s: the arm follows a target over frames,
    and on a busy machine it still moved after the call that set it returned (a take's still
    ends came 0.3 s short of the 1.5 s the test waited for each)."""
    seen = [studio.arm.hand_position()]

    def at_rest() -> bool:
        now = studio.arm.hand_position()
        moved, seen[0] = float(np.linalg.norm(now - seen[0])), now
        return moved < 1e-3

    wait_until(at_rest, interval=0.2, what=f"the hand at rest {where}")


@pytest.mark.browser
def test_a_take_starts_at_the_ghost_loses_its_still_ends_and_can_be_discarded(
    studio, page
) -> None:
    """Go to start puts the hand on the ghost of the primitive's start; Space records (the 3D
    view has the focus); the still time before and after the drag is cut from the saved
    demonstration and kept, untrimmed, in raw/ (which the workspace does not load); the hand
    goes back to the start after Stop; Discard last take sends it to the trash, undoably."""
    client = page.client
    teach = panel(studio)
    record = teach.record
    assert record.controls.trim.value and record.controls.back_to_start.value
    record.controls.countdown.value = 0.5  # the countdown itself is the previous test's
    wait_text(page, "Still ends are trimmed: hand below 2 cm/s, head below 10°/s.")
    start = mean_start(store(studio).demos["curved"], store(studio).layout)
    ghost = studio.scene.start.sphere
    wait_until(lambda: ghost.visible and np.allclose(ghost.position, start, atol=1e-6),
               what="the ghost at the mean start of curved")  # fmt: skip
    # The previous take left the hand at the start (Back to start after Stop): lift it.
    studio.loop.call(lambda: studio.arm.move_hand_to(start + [0.0, 0.0, 0.08]))
    wait_until(lambda: np.linalg.norm(studio.arm.hand_position() - start) > 0.05,
               what="the hand away from the start")  # fmt: skip
    click(page, "Go to start")
    wait_until(lambda: np.linalg.norm(studio.arm.hand_position() - start) < 0.005,
               what="the hand at the start")  # fmt: skip
    wait_at_rest(studio, "at the start")
    side_camera(client)
    # Space, with the 3D view focused (not a control), presses Record, then Stop.
    n_before = len(store(studio).demos["curved"])
    page.evaluate("document.activeElement && document.activeElement.blur()")
    page.keyboard.press("Space")
    wait_text(page, "● Recording into curved")
    wait_until(lambda: record.takes.recording().duration > 1.5, what="1.5 s of stillness")
    drag_hand(page, client, studio, UP, pixels=110)
    wait_at_rest(studio, "after the drag")
    moved_until = record.takes.recording().duration
    wait_until(lambda: record.takes.recording().duration > moved_until + 1.5,
               what="1.5 s of stillness after the drag")  # fmt: skip
    page.evaluate("document.activeElement && document.activeElement.blur()")
    page.keyboard.press("Space")
    wait_until(lambda: len(store(studio).demos["curved"]) == n_before + 1, what="the take saved")
    demo = store(studio).demos["curved"][-1]
    wait_text(page, f"Saved {demo.name}")
    assert "still ends cut" in record.takes.outcome.text
    # The newest take of that name (an earlier take of a deleted curved_020 may be there too).
    raw_path = max((store(studio).workspace.root / "raw" / "curved").glob(f"{demo.name}_*.csv"))
    raw = read_csv_demo(raw_path)
    assert raw.duration > demo.duration + 2.5, (raw.duration, demo.duration)
    z = demo.select(("z",))[:, 0]
    assert np.ptp(z) > 0.05 and np.ptp(z[:5]) < 0.003 and np.ptp(z[-5:]) < 0.003
    assert Workspace(store(studio).workspace.root).load().demos["curved"][-1].name == demo.name
    assert len(Workspace(store(studio).workspace.root).load().demos["curved"]) == n_before + 1
    # Back at the start, ready for the next take.
    new_start = mean_start(store(studio).demos["curved"], store(studio).layout)
    wait_until(lambda: np.linalg.norm(studio.arm.hand_position() - new_start) < 0.005,
               what="the hand back at the start")  # fmt: skip
    # Discard last take: to the trash, and Undo delete brings it back.
    click(page, "Discard last take")
    wait_until(lambda: len(store(studio).demos["curved"]) == n_before, what="the take discarded")
    assert not store(studio).workspace.demo_path("curved", demo.name).exists()
    assert raw_path.exists()  # the record of what was sampled stays
    click(page, f"Undo delete ({demo.name} of curved)")
    wait_until(lambda: len(store(studio).demos["curved"]) == n_before + 1, what="the take back")
    # A focused control keeps Space: no recording starts. (Had the hotkey gone out, the
    # server would have it before the probe's camera report.)
    page.get_by_role("tab", name="Teach").focus()
    page.keyboard.press("Space")
    server_caught_up(studio, client)
    assert record.take is None and "● Recording" not in text(page)
    record.controls.countdown.value = COUNTDOWN_S


@pytest.mark.browser
def test_primitives_are_managed_from_the_gui_and_two_tabs_agree(browser, studio, page) -> None:
    other, _ = open_page(browser, studio)
    try:
        # A bad name changes nothing and says why.
        type_name(page, studio, "bad name!")
        click(page, "Create")
        wait_text(page, "invalid primitive name")
        assert list(store(studio).names) == ["curved", "direct"]
        # Create in one tab, see it in the other.
        type_name(page, studio, "wave")
        click(page, "Create")
        wait_until(lambda: "wave" in list(store(studio).names), what="the primitive to be created")
        wait_text(other, "No demonstration of wave yet")
        assert row(other, "Primitive").locator("input").first.input_value() == "wave"
        assert store(studio).workspace.demo_dir("wave").is_dir()
        # Rename from the other tab.
        type_name(other, studio, "wave2")
        click(other, "Rename")
        wait_until(lambda: list(store(studio).names) == ["curved", "direct", "wave2"],
                   what="the rename")  # fmt: skip
        wait_text(page, "No demonstration of wave2 yet")
        assert not store(studio).workspace.demo_dir("wave").exists()
        # Recolour.
        colour = row(page, "Colour").locator("input").first
        colour.fill("rgb(10, 200, 30)")
        colour.press("Enter")
        wait_until(lambda: store(studio).color("wave2") == (10, 200, 30), what="the new colour")
        index = json.loads(store(studio).workspace.index_path.read_text())
        assert {"name": "wave2", "color": [10, 200, 30]} in index["primitives"]
        wait_until(
            lambda: "10, 200, 30" in row(other, "Colour").locator("input").first.input_value(),
            what="the other tab to show the colour",
        )
        # Delete: cancel first, then confirm.
        click(page, "Delete primitive")
        wait_text(other, "Delete wave2 and its 0 demonstration(s)")
        click(page, "Cancel")
        wait_text(page, "Delete wave2 and its", present=False)
        assert "wave2" in list(store(studio).names)
        click(other, "Delete primitive")
        click(other, "Yes, delete")
        wait_until(lambda: list(store(studio).names) == ["curved", "direct"], what="the deletion")
        assert not store(studio).workspace.demo_dir("wave2").exists()
        wait_until(
            lambda: row(page, "Primitive").locator("input").first.input_value() == "curved",
            what="the selection to fall back to curved",
        )
    finally:
        other.close()


@pytest.mark.browser
def test_a_missing_camera_is_a_clear_message_and_the_rest_keeps_working(studio, page) -> None:
    choose(page, "Source", "Camera")
    index = row(page, "Camera index").locator("input").first
    index.fill("99")
    index.press("Enter")
    wait_until(lambda: panel(studio).head.controls.camera_index.value == 99, what="camera index 99")
    click(page, "Connect")
    wait_text(page, "camera 99: cannot be opened")
    wait_text(page, "Head source failed")
    assert "keeps working" in text(page)
    # The rest works: recording refuses clearly, learning still refits, the arm still moves.
    click(page, "Record")
    wait_text(page, "The head source failed")
    assert panel(studio).record.take is None
    choose(page, "Shrinkage", "0.01")
    # the setting stored, and the model refitted with it (the store's version alone also moves
    # when background work, e.g. a take's scores, is written: under load it came first)
    wait_until(lambda: store(studio).settings.get("shrinkage") == 0.01, what="shrinkage 0.01")
    wait_until(lambda: all(np.allclose(p.shrinkage, 0.01)
                           for p in studio.session.snapshot().model.primitives),
               what="a refit with shrinkage 0.01")  # fmt: skip
    assert studio.arm.move_hand_to(studio.arm.hand_position() + [0, 0, 0.01]).reached
    choose(page, "Source", "Simulated partner")
    wait_text(page, "simulated partner: tracking")
    close_notifications(page)  # the refusal's notification; the red line must go by itself
    wait_text(page, "The head source failed", present=False)  # the refusal no longer holds
    choose(page, "Shrinkage", "automatic (pooled prior)")  # back to the workspace's default
    wait_until(lambda: store(studio).settings["shrinkage"] is None, what="the default back")


@pytest.mark.browser
def test_a_video_file_gives_a_preview_calibration_and_an_upload_works(
    installed, studio, page, tmp_path, artifacts
) -> None:
    from app.live.head import StreamHeadSource, TrackHeadSource

    path = face_video(tmp_path / "face.avi")
    choose(page, "Source", "Video file")
    row(page, "Video file").locator("input").first.fill(str(path))
    wait_until(lambda: panel(studio).head.controls.video_path.value == str(path),
               what="the path typed")  # fmt: skip
    click(page, "Connect")
    wait_until(lambda: isinstance(studio.head.source, StreamHeadSource), what="the video source")
    wait_text(page, f"video {path}: tracking")
    preview = page.locator("img[src^='blob:']")
    wait_until(lambda: preview.count() and preview.first.is_visible(), what="the preview image")
    assert preview.first.bounding_box()["width"] > 150
    click(page, "Calibrate neutral")
    wait_text(page, "Neutral pose set")
    # An uploaded video over the size limit is refused before it is buffered; nothing changes.
    choose(page, "Source", "Uploaded video")
    teach, source = panel(studio), studio.head.source
    job = teach.head.tracks.job  # (an earlier test's upload, if any)
    assert teach.head.video_guard.active
    teach.head.video_guard.max_bytes = 1024
    try:
        page.set_input_files(
            f"#file_upload_{teach.head.controls.upload._impl.uuid}",
            files=[{"name": "big.avi", "mimeType": "video/x-msvideo", "buffer": path.read_bytes()}],
        )
        wait_text(page, "Cannot use the video big.avi")
        assert "over the 1.0 KB limit for an uploaded video" in text(page)
        wait_until(lambda: teach.head.video_guard.refusals == 1, what="the guard's refusal")
        assert studio.head.source is source and teach.head.tracks.job is job  # none started
    finally:
        teach.head.video_guard.max_bytes = MAX_VIDEO_BYTES
    close_notifications(page)
    button = page.get_by_role("button", name="Upload a video")
    wait_until(button.is_enabled, what="the upload button to be usable again")
    # Under the limit, the same video uploaded from the browser becomes a head-pose track.
    page.set_input_files(f"#file_upload_{teach.head.controls.upload._impl.uuid}", str(path))
    wait_text(page, "Video ready", timeout=60)
    assert isinstance(studio.head.source, TrackHeadSource)
    # The loop hides the preview at its next step, after the upload's worker said it is ready.
    wait_until(lambda: not preview.first.is_visible(), what="the preview hidden")
    # The page's Source says what is in use, and the line below names the video.
    source = page.locator(f"[id='{teach.head.controls.source._impl.uuid}']")
    wait_until(lambda: source.input_value() == "Uploaded video", what="Source in the page")
    wait_text(page, "uploaded video face.avi: tracking")
    close_notifications(page)
    head = page.get_by_text("Head source", exact=True).first
    head.evaluate("e => e.scrollIntoView({block: 'start'})")
    page.mouse.move(5, 450)
    screenshot(page, artifacts / "teach_head_source.png")  # (its angles change: never still)
    choose(page, "Source", "Simulated partner")
    wait_text(page, "simulated partner: tracking")
    close_notifications(page)  # the refusal's notification; the red line must go by itself
    wait_text(page, "The head source failed", present=False)  # the refusal no longer holds


def test_the_recognition_line_says_which_variant_and_why() -> None:
    from types import SimpleNamespace

    from app.panels.teach.learn import recognition_line
    from promp.selection.recognition_choice import KEPT_RECOGNITION_RULE

    def model(name, why=None):
        report = {} if why is None else {"settings": {"recognition": why}}
        return SimpleNamespace(settings=SimpleNamespace(recognition=name), report=report)

    losses = {"promp": 0.44, "mixture:0.85": 0.43, "mixture:0.5": 0.38}
    line = recognition_line(model("mixture:0.5", {"log_loss": losses, "lowest": "mixture:0.5"}))
    assert line.count("\n") == 1 and "mixture over the demonstrations (bandwidth 0.5)" in line
    assert "0.380 against the ProMP's 0.440" in line
    line = recognition_line(model("promp", {"log_loss": losses, "lowest": "mixture:0.5"}))
    assert "the ProMP" in line and "mixture:0.5's 0.380 is within the trials' noise" in line
    line = recognition_line(model("promp", {"log_loss": {"promp": 0.2}, "lowest": "promp"}))
    assert "held-out log-loss 0.200, the lowest" in line
    kept = {"rule": KEPT_RECOGNITION_RULE}  # the settings kept: the variant against the ProMP
    line = recognition_line(model("promp", {"log_loss": {"promp": 0.2}, "lowest": "promp", **kept}))
    assert line.endswith("the ProMP (one Gaussian per primitive): held-out log-loss 0.200, kept "
                         "with the settings from the last fit.")  # fmt: skip
    line = recognition_line(model("mixture:0.5", {"log_loss": losses, **kept}))
    assert "0.380 against the ProMP's 0.440, kept with the settings" in line
    assert recognition_line(model("mixture:0.7")).endswith("(bandwidth 0.7), given.")
    assert recognition_line(model(None)) == ""


@pytest.mark.browser
def test_learning_settings_from_the_gui_refit_and_are_saved(studio, page, artifacts) -> None:
    session = studio.session
    model = session.wait_for_model()
    # Automatic: the sliders show what the fit chose, read-only.
    assert store(studio).learning_settings().automatic and "n_basis" not in store(studio).settings
    n_basis = model.settings.n_basis
    learn = panel(studio).learn
    wait_until(lambda: learn.automatic.value and learn.n_basis.disabled
               and learn.n_basis.value == n_basis, what="the chosen M shown")  # fmt: skip
    shown = (f"Chosen from the demonstrations: M = {n_basis}",  # a search, or the choice of
             f"Kept from the last fit (it still beats the runner-up): M = {n_basis}")  # the last
    wait_until(lambda: any(line in text(page) for line in shown), what="the choice shown")
    wait_until(lambda: "Recognition: the " in text(page), what="the recognition variant shown")
    page.get_by_text("Recognition: the ").first.scroll_into_view_if_needed()
    page.screenshot(path=str(artifacts / "teach_recognition.png"))
    # Unticked, the sliders set the values, starting from the chosen ones.
    row(page, "Automatic").get_by_role("checkbox").click()
    wait_until(lambda: store(studio).settings.get("n_basis") == n_basis, what="M given explicitly")
    thumb = row(page, "Basis functions").get_by_role("slider")
    wait_until(lambda: not learn.n_basis.disabled, what="the slider enabled")
    thumb.focus()
    thumb.press("ArrowRight")
    # The setting is stored, then the model refitted (on the thread of the slider's callback).
    wait_until(lambda: store(studio).settings["n_basis"] == n_basis + 1
               and studio.session.snapshot().model.basis.n_basis == n_basis + 1,
               what="n_basis + 1")  # fmt: skip
    assert f'"n_basis": {n_basis + 1}' in store(studio).workspace.index_path.read_text()
    wait_text(page, fit_shown(session))
    assert store(studio).settings.get("shrinkage") is None  # the default: the pooled prior
    choose(page, "Shrinkage", "1e-6 (span of the demos)")
    wait_until(lambda: store(studio).settings["shrinkage"] == 1e-6, what="shrinkage 1e-6")
    assert '"shrinkage": 1e-06' in store(studio).workspace.index_path.read_text()
    wait_until(
        lambda: np.allclose(studio.session.snapshot().model.primitive("curved").shrinkage, 1e-6),
        what="the model refitted with shrinkage 1e-6",
    )
    thumb.press("ArrowLeft")
    choose(page, "Shrinkage", "automatic (pooled prior)")
    wait_until(lambda: store(studio).settings["shrinkage"] is None, what="leave-one-out shrinkage")
    assert '"shrinkage": null' in store(studio).workspace.index_path.read_text()
    wait_until(lambda: store(studio).settings["n_basis"] == n_basis, timeout=30,
               what=lambda: f"n_basis back (settings {store(studio).settings}, slider "
               f"{panel(studio).learn.n_basis.value})")  # fmt: skip
    # Automatic again: the settings leave studio.json, the fit chooses.
    row(page, "Automatic").get_by_role("checkbox").click()
    def automatic_again() -> bool:
        snapshot = studio.session.snapshot()  # the three read at one moment
        return ("n_basis" not in snapshot.store.settings and not snapshot.refitting
                and bool(snapshot.model.report["settings"]["chosen"]))  # fmt: skip

    wait_until(automatic_again, what="automatic again")
    assert '"n_basis"' not in store(studio).workspace.index_path.read_text()


@pytest.mark.browser
def test_readme_screenshot(browser, studio, artifacts) -> None:
    """The Teach view seen from the partner's side: the demonstrations of both primitives and
    their prior tubes over the table, the Learn settings and the prior plot of curved (a page of
    its own, at full resolution)."""
    teach = panel(studio)
    teach.primitives.dropdown.value = "curved"
    start = LAYOUT.extract(store(studio).demos["curved"][0])[0, :3]
    studio.loop.call(lambda: studio.arm.move_hand_to(start))  # the hand at the object
    page, client = open_page(browser, studio, dpr=1.0)
    try:
        for folder in ("Primitive", "Demonstrations"):
            page.get_by_text(folder, exact=True).first.dispatch_event("click")  # collapse
        wait_until(lambda: np.linalg.norm(studio.arm.hand_position() - start) < 0.005,
                   what="the hand at the object")  # fmt: skip
        page.mouse.move(5, 450)
        close_notifications(page)
        start_view = page.screenshot()
        set_camera(client, [-0.95, -0.35, 0.95], [-0.22, -0.12, 0.08], fov_deg=42.0)
        settled_screenshot(page, artifacts / "teach.png", unlike=start_view)
        assert (artifacts / "teach.png").stat().st_size > 50_000
    finally:
        page.close()


# ====================================================================== SIGKILL and restart


def _snapshot(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def _serve(workspace: Path) -> tuple[subprocess.Popen, int]:
    from app.io.net import free_port

    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "--workspace", str(workspace), "--port", str(port)],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines = []
    while not any("running at" in line for line in lines):
        line = proc.stdout.readline()
        assert line, f"the studio exited early: {''.join(lines)}"
        lines.append(line)
    return proc, port


@pytest.mark.browser
def test_sigkill_loses_nothing_recorded_and_restart_restores_the_workspace(
    browser, tmp_path
) -> None:
    workspace = tmp_path / "ws"
    proc, port = _serve(workspace)
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    try:
        page.goto(f"http://127.0.0.1:{port}")
        wait_text(page, "Ready to record into curved", timeout=60)
        # A still take is all idle: keep it whole (trimming would refuse it).
        page.get_by_text("Take options", exact=True).first.dispatch_event("click")
        row(page, "Trim idle ends").locator("input").first.dispatch_event("click")
        wait_text(page, "Still ends are trimmed", present=False)
        row(page, "Countdown (s)").locator("input").first.fill("0.5")  # no need to wait 3 s
        click(page, "Record")
        wait_text(page, "● Recording into curved")
        time.sleep(0.5)
        click(page, "Stop")
        wait_text(page, "Saved curved_020")
        # the take's typicality kept in studio.json once the learner has given it
        index = workspace / "studio.json"
        wait_until(lambda: '"curved_020"' in index.read_text()
                   and not json.loads(index.read_text())["checks"]["typicality"]["pending"],
                   timeout=120, what="the take's score kept in studio.json")  # fmt: skip
        saved = _snapshot(workspace)
        assert "demos/curved/curved_020.csv" in saved and len(saved) == 42
        # Killed in the middle of the next recording: nothing half-written appears.
        click(page, "Record")
        wait_text(page, "● Recording into curved")
        proc.kill()
        proc.wait(timeout=30)
        assert proc.returncode == -signal.SIGKILL
        assert _snapshot(workspace) == saved
    finally:
        page.close()
        if proc.poll() is None:
            proc.kill()
        proc.stdout.close()
    proc, port = _serve(workspace)
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    try:
        page.goto(f"http://127.0.0.1:{port}")
        wait_text(page, "21 demonstration(s) of curved", timeout=60)
        wait_until(lambda: row(page, "curved_020").count() == 1, what="the take listed")
        assert _snapshot(workspace) == saved, "restarting must not rewrite the workspace"
    finally:
        page.close()
        proc.terminate()
        proc.communicate(timeout=30)
