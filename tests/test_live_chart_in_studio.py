"""The Infer tab's live recognition chart and session-file replay, in Chromium, over real LSL
on the loopback (tests/lsl_loopback.cfg): a demonstration of lab-records-flt replayed into the
live source with the commit rule commits, and the chart shows the movement's probabilities with
the commitment's mark at the committing prediction's time, the note under it saying it; a
session recorded by ``python -m promp.live --session`` with the studio's model is replayed in
the page and every prediction equals the recorded one, bit for bit; a session recorded with
another model is refused, and nothing changes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from app.live.inference import TUBE_POINTS
from app.panels.infer.live_chart import LIVE_TITLE
from app.panels.infer.session_replay_section import TITLE as REPLAY_TITLE
from app.panels.infer.view_model import LSL
from promp.io import load_model, save_model
from promp.live.session_file import model_sha256, read_session
from tests.browser import (
    choose,
    click,
    close_notifications,
    notification,
    screenshot,
    set_camera,
)
from tests.conftest import REPO, wait_frames, wait_until
from tests.live_fakes import hand_model, one_ulp_changed
from tests.test_live_streams_in_studio import (
    PAGE,
    STUDIO,
    Replayer,
    infer_panel,
    mapped,
    row,
    top_demo,
    unique,
)

pylsl = pytest.importorskip("pylsl")  # the live extra (make test installs it)
pytest.importorskip("mcap")

pytestmark = pytest.mark.browser
__all__ = ["PAGE", "STUDIO"]  # the module's studio and page (conftest reads them here)


def tick(page, label: str, handle) -> None:
    if not handle.value:
        row(page, label).locator("input").first.dispatch_event("click")
        wait_until(lambda: handle.value, what=f"{label} ticked")


def stopped(page, studio) -> None:
    """The live source (or a replay) stopped by its Stop button."""
    if studio.live.running is not None:
        click(page, "Stop")
        wait_until(lambda: studio.live.running is None, what="the source stopped")


def test_the_live_chart_marks_the_commitment_at_the_committing_prediction(
    page, studio, artifacts
) -> None:
    panel = infer_panel(studio)
    live, chart = panel.lsl.controls, panel.recognition.live
    hand = Replayer(unique("ChartHand"))
    mapped(page, studio, hand)
    assert not chart.chart.visible and not chart.note.visible  # nothing runs yet
    tick(page, "Commit to a primitive", live.commit)
    click(page, "Start")
    page.locator(f'[data-stream="{hand.name}"][data-condition="ok"]').wait_for()
    running = studio.live.running
    session = running.session
    hand.push(top_demo(1.0).select(["x", "y", "z"]) * 1000.0)
    made = wait_until(lambda: (p := session.snapshot().prediction) is not None and p.committed,
                      what="a commitment")  # fmt: skip

    def marked() -> list[float] | None:
        """The mark's x in the chart's data, once drawn."""
        x, *series = chart.chart.data
        where = np.flatnonzero(np.isfinite(np.asarray(series[-1])))
        return np.asarray(x)[where].tolist() if where.size else None

    at = wait_until(marked, what="the commitment marked on the chart")
    assert at == [made.time, made.time]
    curve = running.curves.curve()
    assert curve.movement == made.movement and curve.committed == made
    # the mark stands at the committing prediction's time: one of the movement's predictions
    # (the one whose latest sample is the commitment's)
    assert made.time in curve.times.tolist()
    x, *series = chart.chart.data
    where = np.flatnonzero(np.isfinite(np.asarray(series[-1])))
    assert np.asarray(series[-1])[where].tolist() == [0.0, 100.0]
    assert len(series) == len(curve.names) + 1 and chart.chart.visible
    note = (f"committed to '{made.primitive}' at {made.time:.2f} s "
            f"({100 * made.phase:.0f} %), p={made.probability:.2f}")  # fmt: skip
    shown = page.get_by_text(note)
    shown.wait_for()
    assert not panel.recognition.chart.visible  # the offline chart gives way
    title = page.get_by_text(LIVE_TITLE).first
    title.wait_for()
    title.evaluate("e => e.scrollIntoView({block: 'start'})")
    wait_frames(studio)
    screenshot(page, artifacts / "live-chart.png")  # docs/live-chart.png: copied from here
    stopped(page, studio)
    wait_until(lambda: not chart.chart.visible and not chart.note.visible,
               what="the chart hidden after Stop")  # fmt: skip


def open_replay(page, panel) -> None:
    """The LSL source chosen, its Replay a session file folder open."""
    choose(page, panel.controls.source, LSL)
    field = row(page, "Session file").locator("input").first
    if not field.is_visible():
        page.get_by_text(REPLAY_TITLE, exact=True).first.dispatch_event("click")
    field.wait_for(state="visible")


def give_path(page, panel, path) -> None:
    replay = panel.lsl.replay.controls
    row(page, "Session file").locator("input").first.fill(str(path))
    wait_until(lambda: replay.path.value == str(path), what="the path typed")


@pytest.fixture(scope="module")
def other_session(tmp_path_factory):
    """A session file recorded (headless, on a fake transport) with another model than the
    studio's: hand_model, learned on every demonstration but the first."""
    from promp.live.session import LiveOptions, LiveSession
    from promp.live.session_file import SessionSink
    from tests.live_fakes import FakeStream, FakeTransport, replay

    folder = tmp_path_factory.mktemp("other")
    model = hand_model()
    transport = FakeTransport()
    options = LiveOptions(start="still")
    sink = SessionSink(folder / "other.mcap", model, ["hand=Hand:0,1,2"], options,
                       transport.clock())  # fmt: skip
    session = LiveSession(model, ["hand=Hand:0,1,2"], transport, options, sinks=[sink],
                          now=transport.clock())  # fmt: skip
    stream = transport.add(FakeStream("Hand", ("x", "y", "z"), rate=100.0))
    session.connect()
    session.step()
    demo = top_demo(1.0)
    replay(session, transport, stream, demo.times - demo.times[0], demo.select(["x", "y", "z"]))
    session.close()
    return folder / "other.mcap"


def test_a_session_recorded_with_another_model_is_refused_and_nothing_changes(
    page, studio, other_session
) -> None:
    panel = infer_panel(studio)
    stopped(page, studio)
    open_replay(page, panel)
    kept = other_session.read_bytes()
    view = panel.view
    give_path(page, panel, other_session)
    click(page, "Replay")
    text = notification(page, "Cannot replay the session file", "another model")
    assert "SHA-256" in text
    page.locator("text=Not replayed:").first.wait_for()
    wait_frames(studio)
    assert studio.live.running is None and panel.view is view  # nothing started, shown
    assert other_session.read_bytes() == kept
    close_notifications(page)
    give_path(page, panel, other_session.with_name("absent.mcap"))
    click(page, "Replay")
    notification(page, "Cannot replay the session file", "no such file")
    assert studio.live.running is None
    close_notifications(page)


@pytest.fixture(scope="module")
def cli_session(studio, tmp_path_factory):
    """A session recorded by ``python -m promp.live ... --decide --session FILE`` with the
    studio's model (saved to a file as a user would export it): a demonstration pushed over
    the loopback, the command stopped after its movement ended."""
    folder = tmp_path_factory.mktemp("cli")
    model = studio.session.snapshot().inference_model
    save_model(folder / "model.json", model)
    assert model_sha256(load_model(folder / "model.json")) == model_sha256(model)
    hand = Replayer(unique("CliHand"))
    out, path = unique("cli-out"), folder / "recorded.mcap"
    command = [sys.executable, "-m", "promp.live", "--model", str(folder / "model.json"),
               "--in", f"hand={hand.name}:hand_x,hand_y,hand_z", "--out", out, "--decide",
               "--session", str(path), "--status-every", "0.2",
               "--lsl-config", str(REPO / "tests" / "lsl_loopback.cfg")]  # fmt: skip
    process = subprocess.Popen(command, cwd=folder, stdout=subprocess.PIPE, text=True,
                               env={**os.environ, "PYTHONPATH": str(REPO)})  # fmt: skip
    lines: list[str] = []

    def read_until(text: str) -> None:
        while not any(text in line for line in lines):
            line = process.stdout.readline()
            assert line, f"the command ended early: {lines}"
            lines.append(line)

    try:
        # its status line says its input is there (the studio's look for streams opens an
        # inlet too: a consumer of the outlet is not yet the command)
        read_until("streams ok")
        hand.push(top_demo(1.0).select(["x", "y", "z"]) * 1000.0)
        read_until("movement 1 ended")
        process.send_signal(signal.SIGINT)
        rest, _ = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, rest
    summary = json.loads(rest.strip().splitlines()[-1])
    assert summary["predictions"] >= 2
    return path


def test_a_session_recorded_by_the_command_replays_in_the_page_bit_for_bit(
    page, studio, cli_session, artifacts
) -> None:
    panel = infer_panel(studio)
    stopped(page, studio)
    recorded = read_session(cli_session)
    n = len(recorded.of("p"))
    committed = [r for r in recorded.of("p") if r["committed"] is not None]
    assert n >= 2 and committed  # the command's rule committed
    kept = cli_session.read_bytes()
    open_replay(page, panel)
    give_path(page, panel, cli_session)
    assert not panel.lsl.replay.controls.fast.value  # at the recorded timing
    click(page, "Replay")
    running = wait_until(lambda: studio.live.running, what="the replay started")
    assert running.replay is not None
    shown = page.locator('[data-replay="equal"]')
    shown.wait_for()
    text = " ".join(shown.inner_text().split())
    assert text.endswith(f"every one of the {n} predictions equalled the recorded one, "
                         "bit for bit.")  # fmt: skip
    last = running.session.snapshot().prediction
    assert last.seq == recorded.of("p")[-1]["seq"]
    # shown as a live session's: the view, the 3D drawing and the chart with its mark
    view = wait_until(lambda: panel.view if panel.view is not None and
                      panel.view.samples.prediction is last else None,
                      what="the last replayed prediction shown")  # fmt: skip
    wait_until(lambda: studio.scene.inference.drawn.result is view.result,
               what="the replayed prediction drawn in 3D")  # fmt: skip
    # the command's predictions are on the model's own samples: drawn on the tube's rings
    assert studio.scene.inference.has_shape
    assert view.result.prediction.mean.shape[0] == TUBE_POINTS
    assert view.result.inference.probabilities is last.probabilities
    made = last.committed
    assert made is not None and made.primitive == committed[0]["committed"]
    page.get_by_text(f"committed to '{made.primitive}' at {made.time:.2f} s").first.wait_for()
    shown.evaluate("e => e.scrollIntoView({block: 'center'})")
    set_camera(page.client, position=[-1.5, -0.9, 0.8], look_at=[-0.15, -0.1, 0.15])
    wait_frames(studio)
    screenshot(page, artifacts / "session_replay.png")  # docs/: copied from here
    # a live start is refused while the replay is shown: Start reads Stop
    assert panel.lsl.controls.run.label == "Stop" and panel.lsl.replay.controls.replay.disabled
    assert not panel.lsl.controls.movement.visible  # a replay's movements are the recorded
    stopped(page, studio)
    assert cli_session.read_bytes() == kept  # only read


def test_a_session_file_whose_prediction_differs_is_said_in_red_with_the_difference(
    page, studio, cli_session, tmp_path
) -> None:
    panel = infer_panel(studio)
    stopped(page, studio)
    changed = tmp_path / "changed.mcap"
    one_ulp_changed(cli_session, changed)  # its first prediction's phase, by one ulp
    kept = changed.read_bytes()
    open_replay(page, panel)
    give_path(page, panel, changed)
    click(page, "Replay")
    shown = page.locator('[data-replay="differs"]')
    shown.wait_for()
    text = " ".join(shown.inner_text().split())
    assert text.startswith("Replayed changed.mcap: not the recorded predictions:")
    assert "phase" in text  # the number that differs is named
    assert not page.locator('[data-replay="equal"]').count()
    stopped(page, studio)
    assert changed.read_bytes() == kept  # only read
