"""Shared fixtures: the real-browser harness and the shared lab data.

Browser tests (marker ``browser``) drive the studio in Debian's headless Chromium through
Playwright. Without ``/usr/bin/chromium`` they are skipped with one clear line, except in CI
(``CI=true``), where a missing Chromium is an error.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

# LSL keeps every test's streams on this machine (before pylsl is imported anywhere).
os.environ["LSLAPICFG"] = str(Path(__file__).resolve().parent / "lsl_loopback.cfg")

from app.core.fits import FitCache  # noqa: E402

# The fits of the tests' sessions and studios, shared (the studio injects a cache: one per
# studio by default). Many tests open the same workspaces: their fits are learned once.
FITS = FitCache(max_entries=32)

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
REPO = Path(__file__).resolve().parent.parent
SHARED_DATA = REPO.parent / "shared" / "data"
HEIGHTS = SHARED_DATA / "lab-records-heights"
ARTIFACTS = REPO / "artifacts"


def in_ci() -> bool:
    return os.environ.get("CI", "").lower() in ("1", "true", "yes")


def pytest_report_header(config: pytest.Config) -> str:
    if CHROMIUM.exists():
        return f"browser tests: ON ({CHROMIUM})"
    return f"browser tests: SKIPPED, {CHROMIUM} not found (install it: apt-get install -y chromium)"


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if CHROMIUM.exists():
        return
    if in_ci() and any("browser" in item.keywords for item in items):
        raise pytest.UsageError(f"CI=true but {CHROMIUM} is missing: browser tests cannot run")
    skip = pytest.mark.skip(reason=f"{CHROMIUM} not found (apt-get install -y chromium)")
    for item in items:
        if "browser" in item.keywords:
            item.add_marker(skip)


def pytest_terminal_summary(terminalreporter, exitstatus: int, config: pytest.Config) -> None:
    if not CHROMIUM.exists():
        terminalreporter.write_line(
            f"NOTE: browser tests were skipped: {CHROMIUM} not found (apt-get install -y chromium)",
            yellow=True,
        )


@pytest.fixture(scope="session")
def artifacts() -> Path:
    """Folder for screenshots and other test artefacts (kept after the run)."""
    ARTIFACTS.mkdir(exist_ok=True)
    return ARTIFACTS


@pytest.fixture(scope="session")
def installed() -> None:
    """The face models of the head-pose estimator: the test is skipped (with the command that
    installs them) when they are missing, except in CI, where that is a failure."""
    from app.headpose.models import models_available

    available, reason = models_available()
    if not available:
        if in_ci():
            pytest.fail(f"CI=true but the face models are missing: {reason}")
        pytest.skip(reason)


@pytest.fixture(scope="session")
def heights_dir() -> Path:
    """The shared real recordings; the test is skipped (with the reason) when absent."""
    if not HEIGHTS.is_dir():
        pytest.skip(f"shared lab recordings not found at {HEIGHTS}")
    return HEIGHTS


@pytest.fixture(scope="session")
def browser() -> Iterator[object]:
    """One headless Chromium for the whole session."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        chromium = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_FLAGS)
        yield chromium
        chromium.close()


def wait_until(predicate, timeout: float = 30.0, interval: float = 0.05, what="condition"):
    """Poll ``predicate`` until it returns a truthy value; fail the test on timeout, saying
    ``what`` was awaited (a string, or a callable giving one with the state at that time)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval)
    pytest.fail(f"timed out after {timeout:.0f} s waiting for {what() if callable(what) else what}")


def scenario_workspace(root: Path, seed: int, n_demos: int, settings: dict | None = None) -> Path:
    """A workspace at ``root`` holding the simulated scenario (``n_demos`` per primitive), with
    the learning ``settings`` given (default: the engine's)."""
    from app.io.workspace import Workspace, WorkspaceData
    from app.io.workspace_index import PALETTE, PrimitiveEntry
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=seed, n_demos=n_demos)
    Workspace.create(
        root,
        WorkspaceData(
            primitives=[PrimitiveEntry(name, PALETTE[i]) for i, name in enumerate(dataset)],
            demos=dataset,
            settings=dict(settings or {}),
        ),
    )
    return root


def start_studio(workspace: Path, **kwargs):
    """A studio on a free loopback port, in this process (stop it with ``studio.stop()``)."""
    from app.io.net import free_port
    from app.studio import Studio

    kwargs.setdefault("fits", FITS)
    return Studio.start("127.0.0.1", free_port(), workspace, **kwargs)


# The 3D view's pixels per CSS pixel in the browser tests (viser's ``fixedDpr``). Headless
# Chromium draws with software WebGL, where a frame of the studio at 1400 x 900 costs about half
# a core-second, and the page answers nothing while it draws: with half the resolution each way
# (a quarter of the pixels) a page call during a drag or a scrub returns in ~100 ms, not ~220.
# A fixed ratio also keeps viser's adaptive resolution from changing the canvas mid-test. Tests
# that look at the picture (README screenshots, the start view's framing) ask for 1.0.
TEST_DPR = 0.5


def open_page(browser, studio, width: int = 1400, height: int = 900, dpr: float = TEST_DPR):
    """A Chromium tab connected to ``studio`` with its 3D view at ``dpr`` pixels per CSS pixel;
    returns (page, viser client handle) once the page has connected and reported its camera.

    viser's "Software WebGL rendering detected" notice (headless Chromium renders without a
    GPU) is closed by the page itself as soon as it shows
    (:data:`tests.browser.CLOSE_WEBGL_NOTICE`), so it never covers the panel or a screenshot,
    and nothing waits for it.
    """
    from tests.browser import CLOSE_WEBGL_NOTICE, camera_reports

    page = browser.new_page(viewport={"width": width, "height": height})
    page.add_init_script(CLOSE_WEBGL_NOTICE)
    known = set(studio.server.get_clients())
    page.goto(f"http://127.0.0.1:{studio.port}/?fixedDpr={dpr:g}")
    # Wrapped in a tuple: the first client's id is 0, which is falsy.
    (client_id,) = wait_until(
        lambda: next(((c,) for c in studio.server.get_clients() if c not in known), None),
        what="the browser to connect",
    )
    client = studio.server.get_clients()[client_id]
    camera_reports(client)
    wait_until(lambda: camera_reported(client), timeout=60, what="the browser's camera")
    return page, client


def camera_reported(client) -> bool:
    """Whether the browser tab of ``client`` has reported its camera (viser asserts it has
    before ``client.camera`` answers)."""
    try:
        client.camera.position  # noqa: B018
    except AssertionError:
        return False
    return True
