"""Shared fixtures: the real-browser harness and the shared lab data.

Browser tests (marker ``browser``) drive the studio in Debian's headless Chromium through
Playwright. Without ``/usr/bin/chromium`` they are skipped with one clear line, except in CI
(``CI=true``), where a missing Chromium is an error.

The shared lab recordings are read from ``../shared/data`` beside the clone, or from the folder
``STUDIO_SHARED_DATA`` names. A test reaches them only through :data:`SHARED_DATA`,
:func:`shared_set` or a helper marked :func:`uses_shared_data`; each such test is marked
``data`` at collection, and skips with one line saying why when the folder is absent (a user's
clone has none). CI reruns ``-m data`` with ``STUDIO_SHARED_DATA`` pointed at an empty folder.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

# LSL keeps every test's streams on this machine (before pylsl is imported anywhere).
os.environ["LSLAPICFG"] = str(Path(__file__).resolve().parent / "lsl_loopback.cfg")

from hypothesis import Phase, settings  # noqa: E402

from app.core.fits import FitCache  # noqa: E402

# bench/mutation.py's profile (``--hypothesis-profile=mutation``): the same examples for every
# mutant, none saved or replayed, and a failing one not shrunk (a failure is all it needs)
settings.register_profile("mutation", derandomize=True, database=None,
                          phases=(Phase.explicit, Phase.generate))  # fmt: skip

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
SHARED_DATA = Path(os.environ.get("STUDIO_SHARED_DATA") or REPO.parent / "shared" / "data")
HEIGHTS = SHARED_DATA / "lab-records-heights"
ARTIFACTS = REPO / "artifacts"


def uses_shared_data(function):
    """Mark ``function`` (a helper of the tests) as one that reads the shared recordings: a
    test module that imports it has its tests marked ``data``."""
    function.uses_shared_data = True
    return function


@uses_shared_data
def shared_set(name: str) -> Path:
    """The shared set ``name`` (``lab-records-flt``, ...); the test is skipped, saying where it
    was looked for, when it is absent."""
    folder = SHARED_DATA / name
    if not folder.is_dir():
        pytest.skip(f"shared lab recordings not found at {folder} (set STUDIO_SHARED_DATA)")
    return folder


def _reads_shared_data(item: pytest.Item) -> bool:
    """Whether ``item`` reaches the shared recordings: through the ``heights_dir`` fixture, or
    a module that holds :data:`SHARED_DATA` (or a path below it) or a marked helper."""
    if "heights_dir" in getattr(item, "fixturenames", ()):
        return True
    for value in vars(getattr(item, "module", None) or object()).values():
        if getattr(value, "uses_shared_data", False) is True:
            return True
        if isinstance(value, Path) and (value == SHARED_DATA or SHARED_DATA in value.parents):
            return True
    return False


def in_ci() -> bool:
    return os.environ.get("CI", "").lower() in ("1", "true", "yes")


def pytest_report_header(config: pytest.Config) -> str:
    if CHROMIUM.exists():
        return f"browser tests: ON ({CHROMIUM})"
    return f"browser tests: SKIPPED, {CHROMIUM} not found (install it: apt-get install -y chromium)"


@pytest.hookimpl(tryfirst=True)  # marked before `-m data` selects
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if _reads_shared_data(item):
            item.add_marker(pytest.mark.data)
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


@pytest.fixture(autouse=True)
def _lsl_released() -> Iterator[None]:
    """The LSL outlets and inlets a test made (tests/lsl_push.py) destroyed when it ends,
    under promp.live.lsl's lock, not later by the garbage collector."""
    yield
    made = sys.modules.get("tests.lsl_push")
    if made is not None:
        made.release_all()


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
    return shared_set(HEIGHTS.name)


@pytest.fixture(scope="session")
def browser() -> Iterator[object]:
    """One headless Chromium for the whole session."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        chromium = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_FLAGS)
        yield chromium
        chromium.close()


PATIENCE_S = 120.0  # the least any wait allows: a loaded CI machine is 4-10x slower than idle


def wait_until(predicate, timeout: float = 30.0, interval: float = 0.05, what="condition"):
    """Poll ``predicate`` until it returns a truthy value; fail the test on timeout, saying
    ``what`` was awaited (a string, or a callable giving one with the state at that time).
    ``timeout`` is what an idle machine needs at most; the wait allows at least
    :data:`PATIENCE_S` (a wait is on state, never a measure of speed)."""
    timeout = max(timeout, PATIENCE_S)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval)
    pytest.fail(f"timed out after {timeout:.0f} s waiting for {what() if callable(what) else what}")


def wait_frames(studio, n: int = 3, timeout: float = 60.0) -> None:
    """Wait until the studio's loop has run ``n`` whole frames from now: whatever a callback
    recorded or a task asked of the loop before the call has been handled (a check that
    nothing happened can then fail, where a sleep passes on a busy machine without proving
    anything)."""
    start = studio.loop.frames_done
    wait_until(lambda: studio.loop.frames_done >= start + n + 1, timeout=timeout,
               what=f"{n} frames of the studio's loop")  # fmt: skip


def scenario_workspace(
    root: Path, seed: int, n_demos: int, settings: dict | None = None, third: bool = False
) -> Path:
    """A workspace at ``root`` holding the simulated scenario (``n_demos`` per primitive, and a
    third primitive when ``third``), with the learning ``settings`` given (default: the
    engine's)."""
    from app.io.workspace import Workspace, WorkspaceData
    from app.io.workspace_index import PALETTE, PrimitiveEntry
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=seed, n_demos=n_demos, third=third)
    Workspace.create(
        root,
        WorkspaceData(
            primitives=[PrimitiveEntry(name, PALETTE[i]) for i, name in enumerate(dataset)],
            demos=dataset,
            settings=dict(settings or {}),
        ),
    )
    return root


# Learning settings given rather than automatic: a leave-one-out run from the GUI then fits each
# fold once instead of choosing the settings in every fold (the choice inside the folds is
# tests/test_promp_evaluate.py's; in a browser test it cost a minute of a 2-core run).
GIVEN_SETTINGS = {"n_basis": 7, "width": 1.0, "noise_scale": 1.5}


@dataclass(frozen=True)
class StudioSpec:
    """What a test module's ``studio`` opens: its module-level ``STUDIO`` (default: the
    studio's default workspace, as ``make run`` starts it).

    Attributes
    ----------
    seed : int or None
        The simulated scenario with this seed (``n_demos`` per primitive, a third primitive
        when ``third``, learning ``settings``); None: the default workspace.
    make : callable or None
        ``make(root, request)`` writes the workspace at ``root`` instead (``request``: the
        module's, for its fixtures).
    folder : str
        The workspace folder's name.
    ready : callable or None
        ``ready(studio)`` truthy once the studio is ready for the module's first test.
    """

    seed: int | None = None
    n_demos: int = 4
    third: bool = False
    settings: dict | None = None
    make: Callable[[Path, pytest.FixtureRequest], object] | None = None
    folder: str = "ws"
    ready: Callable[[object], object] | None = None


@dataclass(frozen=True)
class PageSpec:
    """The module's ``page`` (its module-level ``PAGE``): a Chromium tab of ``width`` x
    ``height`` CSS pixels, its 3D view at ``dpr`` pixels per CSS pixel, showing ``tab``;
    ``ready(page, studio)`` is called (to wait for something) before the first test."""

    width: int = 1400
    height: int = 900
    dpr: float | None = None  # None: TEST_DPR
    tab: str | None = None
    ready: Callable[[object], object] | None = None


@pytest.fixture(scope="module")
def studio(request, tmp_path_factory):
    """The module's studio (see :class:`StudioSpec`), on a free loopback port, in this
    process; stopped after the module."""
    spec = getattr(request.module, "STUDIO", StudioSpec())
    name = request.module.__name__.rsplit(".", 1)[-1].removeprefix("test_")
    root = tmp_path_factory.mktemp(name) / spec.folder
    if spec.make is not None:
        spec.make(root, request)
    elif spec.seed is not None:
        scenario_workspace(root, spec.seed, spec.n_demos, spec.settings, third=spec.third)
    studio = start_studio(root)
    try:
        if spec.ready is not None:
            wait_until(lambda: spec.ready(studio), timeout=60, what="the studio ready")
        yield studio
    finally:
        studio.stop()


@pytest.fixture(scope="module")
def page(request, browser, studio):
    """A Chromium tab on the module's studio (see :class:`PageSpec`), with its viser client
    handle as ``page.client``; closed after the module."""
    spec = getattr(request.module, "PAGE", PageSpec())
    dpr = TEST_DPR if spec.dpr is None else spec.dpr
    page, client = open_page(browser, studio, width=spec.width, height=spec.height, dpr=dpr)
    page.client = client  # type: ignore[attr-defined]
    page.set_default_timeout(120_000)  # software WebGL on a shared, loaded machine is slow
    try:
        if spec.tab is not None:
            from tests.browser import open_tab

            open_tab(page, spec.tab)
        if spec.ready is not None:
            spec.ready(page, studio)
        yield page
    finally:
        page.close()


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
# The same for the pages a module keeps open to take pictures that a person looks at (/tmp,
# artifacts/; not the docs' pictures, which open a page at 1.0 for the shot). At 1.0 such a
# page drew at viser's 1 s heartbeat at a core-second a frame: a whole core for the module's
# length, which the other test worker's studio and page then lacked (tests/test_scene_on_
# imported_data.py alone: 176 s of CPU at 1.0, 113 s at 0.5). Their pictures keep the
# viewport's size, with a softer 3D view; STUDIO_PICTURE_DPR=1 draws it sharp.
PICTURE_DPR = float(os.environ.get("STUDIO_PICTURE_DPR") or TEST_DPR)


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
