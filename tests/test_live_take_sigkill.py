"""A SIGKILL of the studio during a take recorded from a live stream loses nothing the page
said was recorded: the rows acknowledged are in the take's journal when the process dies, and
the next start of the studio makes them a take of the workspace (recovery is performed, not
offered) and removes the journal. A studio process, a Chromium page and a real LSL outlet on
the loopback (tests/lsl_loopback.cfg, which tests/conftest.py sets as LSLAPICFG)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.io.net import free_port
from app.io.workspace import Workspace
from app.live.inference import LSL
from promp.live.recorder import recover
from tests.browser import open_tab, press
from tests.conftest import REPO, wait_until
from tests.live_fakes import flt_dataset, flt_workspace, held, offset_in

pylsl = pytest.importorskip("pylsl")  # the live extra (make test installs it)

from tests.lsl_push import hand_outlet  # noqa: E402

NAME = f"KilledHand-{os.getpid()}-{time.monotonic_ns() % 10**9}"  # unique per run and worker
LABELS = ("hand_x", "hand_y", "hand_z")


def serve(workspace) -> tuple[subprocess.Popen, int]:
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "--workspace", str(workspace), "--port", str(port)],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    lines: list[str] = []
    while not any("running at" in line for line in lines):
        line = proc.stdout.readline()
        assert line, f"the studio exited early: {''.join(lines)}"
        lines.append(line)
    threading.Thread(target=proc.stdout.read, daemon=True).start()  # never a full pipe
    return proc, port


def row(page, label: str):
    return page.locator("label", has_text=label).first.locator(
        "xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]"
    )


def start_recording(page) -> str:
    """Start the Live source on the outlet with its guessed mapping and arm Live takes; the
    primitive the takes go into."""
    open_tab(page, "Infer")
    press(page, row(page, "Source").locator("input").first)
    press(page, page.get_by_role("option", name=LSL, exact=True))
    page.get_by_text(NAME, exact=True).wait_for()
    guessed = f"hand={NAME}:hand_x,hand_y,hand_z"  # the page shows what the studio guessed
    wait_until(lambda: row(page, "Mapping").locator("textarea").input_value() == guessed,
               timeout=120, what="the mapping guessed")  # fmt: skip
    # the take starts and ends by Teach's buttons: the kill comes while it is under way
    press(page, row(page, "Movement start").locator("input").first)
    press(page, page.get_by_role("option", name="Begin / End buttons", exact=True))
    chosen = row(page, "Movement start").locator("input").first
    wait_until(lambda: chosen.input_value() == "Begin / End buttons", what="the buttons chosen")
    page.get_by_role("button", name="Start", exact=True).first.dispatch_event("click")
    page.locator(f'[data-stream="{NAME}"][data-condition="ok"]').wait_for()
    open_tab(page, "Teach")
    page.get_by_text("Live takes (LSL)", exact=True).first.dispatch_event("click")
    row(page, "Record live movements").locator("input").first.dispatch_event("click")
    status = page.get_by_text("Recording each live movement into")
    status.wait_for()
    page.get_by_role("button", name="Begin take", exact=True).first.dispatch_event("click")
    return re.search(r"into (\S+) \(or", status.inner_text()).group(1)


def shown_acknowledged(page) -> int:
    """The rows the page says the take under way has acknowledged (0: none under way)."""
    return page.evaluate("() => { const e = document.querySelector('[data-acknowledged]');"
                         " return e ? Number(e.dataset.acknowledged) : 0; }")


@pytest.mark.browser
def test_sigkill_during_a_live_take_loses_nothing_acknowledged(browser, tmp_path) -> None:
    workspace = flt_workspace(tmp_path / "ws", per_class=3)
    demo = held(flt_dataset()["top"][0], 0.6, 0.8)
    fine = np.linspace(0, demo.n_samples - 1, 2 * demo.n_samples)  # twice slower: a window
    values_m = np.column_stack([np.interp(fine, np.arange(demo.n_samples), column)
                                for column in demo.select(["x", "y", "z"]).T])  # fmt: skip
    outlet = hand_outlet(NAME, LABELS)
    stop = threading.Event()
    stamps: list[float] = []

    sent: list[np.ndarray] = []

    def push() -> None:
        """The demonstration at its rate, then a slow circle from its end until told to stop:
        the movement never ends by itself, whatever the start mode. Stamped at 100 Hz as a
        device stamps its samples: a thread the loaded machine starves pushes what it owes
        when it wakes, on their stamps (pushing late rows at their push time left holes the
        session rightly took for a gap, which ended the take before the kill)."""
        k, t0 = 0, pylsl.local_clock()
        while not stop.is_set():
            t = t0 + 0.01 * k
            time.sleep(max(0.0, t - pylsl.local_clock()))
            extra = max(k - len(values_m) + 1, 0) * 0.01
            row = values_m[min(k, len(values_m) - 1)] + 0.05 * np.array(
                [np.cos(extra) - 1.0, np.sin(extra), 0.0])  # fmt: skip
            outlet.push_sample((row * 1000.0).tolist(), t)
            sent.append(row)
            stamps.append(t)
            k += 1

    proc, port = serve(workspace)
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    page.set_default_timeout(120_000)
    pusher = threading.Thread(target=push, daemon=True)
    try:
        page.goto(f"http://127.0.0.1:{port}")
        primitive = start_recording(page)
        before = {d.name for d in Workspace(workspace).load().demos[primitive]}
        pusher.start()
        acknowledged = wait_until(lambda: shown_acknowledged(page) >= 30, timeout=180,
                                  what="30 rows acknowledged in the page")  # fmt: skip
        acknowledged = max(acknowledged, shown_acknowledged(page))  # the latest it said
        proc.kill()  # mid-movement: the demonstration is still being pushed
        proc.wait(timeout=30)
        assert proc.returncode == -signal.SIGKILL
    finally:
        stop.set()
        page.close()
        if proc.poll() is None:
            proc.kill()
        proc.stdout.close()
    pusher.join(timeout=30)
    left = recover(workspace / "live-journals" / primitive)
    assert len(left) == 1, (f"journals {left} in {sorted(map(str, workspace.rglob('*')))}")
    (journalled,) = left
    path, kept = journalled
    assert not isinstance(kept, str), kept
    assert kept.n_samples >= acknowledged
    assert {d.name for d in Workspace(workspace).load().demos[primitive]} == before
    n = kept.n_samples
    rows = np.array(sent)
    i0 = offset_in(rows, kept.select(["x", "y", "z"]))
    assert_allclose(kept.select(["x", "y", "z"]), rows[i0:i0 + n], rtol=0, atol=1e-9)
    # The next start recovers it: a take of every acknowledged row; the journal removed.
    proc, port = serve(workspace)
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    page.set_default_timeout(120_000)
    try:
        page.goto(f"http://127.0.0.1:{port}")
        said = page.get_by_text(re.compile(rf"Recovered \S+ into {primitive}: {n} samples"))
        said.first.wait_for(state="attached")  # the Live takes folder says so (folded)
        wait_until(lambda: not path.exists(), what="the journal removed once recovered")
        after = Workspace(workspace).load().demos[primitive]
        (take,) = [d for d in after if d.name not in before]
        assert_allclose(take.times, kept.times, rtol=0, atol=1e-9)
        assert_allclose(take.select(["x", "y", "z"]), rows[i0:i0 + n], rtol=0, atol=1e-9)
    finally:
        page.close()
        proc.terminate()
        proc.communicate(timeout=30)
