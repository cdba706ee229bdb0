"""Helpers for driving the studio in headless Chromium (Playwright), shared by the browser
tests. Every wait is for a state, with a generous deadline, never a fixed sleep."""

from __future__ import annotations

import math
import time
import weakref
from pathlib import Path

import numpy as np
import pytest
import viser.transforms as vtf
from playwright.sync_api import TimeoutError as PlaywrightTimeoutError

from tests.conftest import wait_until

# An init script for the studio's pages: closes viser's "Software WebGL rendering detected"
# notice (shown once, at start, when the browser renders without a GPU, as headless Chromium
# does) as soon as it appears, by its own close button.
CLOSE_WEBGL_NOTICE = """(() => {
    const close = () => {
        for (const root of document.querySelectorAll(".mantine-Notification-root")) {
            if (root.textContent.includes("Software WebGL rendering detected")) {
                const button = root.querySelector(".mantine-Notification-closeButton");
                if (button) button.click();
            }
        }
    };
    new MutationObserver(close).observe(document, {subtree: true, childList: true});
})();"""


def press(page, locator) -> None:
    """A real mouse click at the middle of ``locator``. (Playwright's own ``click`` first waits
    for the element to be stable over animation frames, which software WebGL makes very slow
    on a busy machine.)"""
    locator.wait_for(state="visible", timeout=120_000)
    # Scrolled into view first, as a person would (a page shared by a module's tests may have
    # been left scrolled; a click outside the viewport lands nowhere).
    locator.evaluate("e => e.scrollIntoView({block: 'nearest', inline: 'nearest'})")
    box = locator.bounding_box(timeout=120_000)
    page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)


def press_until(page, locator, done, what: str, tries: int = 12) -> None:
    """:func:`press` ``locator`` until ``done()``, pressing again while it stays false 10 s
    after a press: an element the page redraws as the server updates it loses a click that
    lands while it is replaced (seen under load with Source's dropdown)."""
    for _ in range(tries):
        press(page, locator)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            if done():
                return
            time.sleep(0.1)
    pytest.fail(f"{what}: pressed {tries} times, nothing happened")


def open_tab(page, name: str, timeout: float = 120.0) -> None:
    """Show the tab ``name`` by mouse and wait until the page says it is the selected one; a
    click that a busy page lost (laid out again under the pointer) is made again."""
    tab = page.get_by_role("tab", name=name)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        press(page, tab)
        retry = time.monotonic() + 10
        while time.monotonic() < min(retry, deadline):
            if tab.get_attribute("aria-selected") == "true":
                return
            time.sleep(0.1)
    raise AssertionError(f"the {name} tab was not shown within {timeout:.0f} s")


def click(page, name: str) -> None:
    """Click the first button named ``name`` (a DOM click event: no animation-frame waits),
    once the page shows it enabled: a click on a button the studio has enabled but the page
    not yet (a busy page, a message in flight) would be lost, as a person's would be."""
    button = page.get_by_role("button", name=name, exact=True).first
    button.wait_for(state="attached", timeout=120_000)
    wait_until(button.is_enabled, timeout=120, what=f"the {name!r} button enabled in the page")
    button.dispatch_event("click")


def choose(page, handle, option: str, timeout: float = 180.0) -> None:
    """Pick ``option`` in a dropdown by mouse, as a user does (nothing when already chosen).

    Once the studio offers the option, the dropdown is opened and the option clicked; while
    the option does not show within 10 s of opening (the list opened before the studio's new
    options reached the page, or the click was lost to the page drawing the dropdown again: a
    busy-core run of 2026-11-29 waited 120 s for a demonstration the list never showed), the
    list is closed (Escape) and opened again, as a person would."""
    if handle.value == option:
        return
    wait_until(lambda: option in getattr(handle, "options", (option,)),
               what=f"{option!r} offered by the studio")
    dropdown = page.locator(f"[id='{handle._impl.uuid}']")
    item = page.get_by_role("option", name=option, exact=True)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        press(page, dropdown)
        try:
            item.wait_for(state="visible", timeout=10_000)
        except PlaywrightTimeoutError:
            page.keyboard.press("Escape")
            continue
        press(page, item)
        wait_until(lambda: handle.value == option, timeout=60, what=f"{option!r} chosen")
        return
    pytest.fail(f"{option!r} never shown in the dropdown within {timeout:.0f} s")


def upload_file(page, button, name: str, content: bytes) -> None:
    """Choose a file in a viser upload button, as the browser's file dialog does."""
    page.set_input_files(
        f"#file_upload_{button._impl.uuid}",
        files=[{"name": name, "mimeType": "application/octet-stream", "buffer": content}],
    )


def notification(page, title: str, body: str | None = None) -> str:
    """The text (title and body) of the first notification with this title (and containing
    ``body``), once shown."""
    box = page.locator(".mantine-Notification-root", has_text=title)
    if body is not None:
        box = box.filter(has_text=body)
    box.first.wait_for(timeout=120_000)
    return box.first.inner_text()


CLOSE_ALL_NOTIFICATIONS = """() => {
    document.querySelectorAll(".mantine-Notification-closeButton").forEach((b) => b.click());
    return document.querySelectorAll(".mantine-Notification-root").length;
}"""


def close_notifications(page) -> None:
    """Close every notification by its close button, as a user does, and wait until none is
    left (each closes with an animation; one that arrives meanwhile is closed too) rather than
    for the studio's 8 s auto-close."""
    wait_until(
        lambda: page.evaluate(CLOSE_ALL_NOTIFICATIONS) == 0, timeout=60, interval=0.1,
        what="the notifications to close",
    )  # fmt: skip


class CameraReports:
    """The camera poses a browser tab reported, in order, with their times (viser calls
    ``on_update`` for each report from the browser, never for the server's own settings,
    which change ``client.camera`` at once, before the browser has moved)."""

    def __init__(self, client):
        self.poses: list[tuple[float, np.ndarray, np.ndarray]] = []  # (time, position, look_at)
        client.camera.on_update(self._add)

    def _add(self, camera) -> None:
        self.poses.append((time.monotonic(), np.array(camera.position), np.array(camera.look_at)))


# By the client handle itself: an id() of a closed tab's handle can come back for a new one.
_REPORTS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def camera_reports(client) -> CameraReports:
    """The reports of ``client``'s tab (recorded from the first call on: open_page calls it
    as the tab connects)."""
    if client not in _REPORTS:
        _REPORTS[client] = CameraReports(client)
    return _REPORTS[client]


def set_camera(client, position, look_at, fov_deg: float | None = None) -> None:
    """Point ``client``'s camera and wait until its browser reports it there (the page has
    moved its camera: what it draws and where a click lands follow from then on)."""
    reports = camera_reports(client)
    start = len(reports.poses)
    if fov_deg is not None:
        client.camera.fov = np.deg2rad(fov_deg)
    client.camera.position = np.asarray(position, dtype=float)
    client.camera.look_at = np.asarray(look_at, dtype=float)

    def there(pose) -> bool:
        _, at, looking = pose
        return np.allclose(at, position, atol=1e-3) and np.allclose(looking, look_at, atol=1e-3)

    already = start > 0 and there(reports.poses[start - 1])
    wait_until(lambda: already or any(there(p) for p in reports.poses[start:]), timeout=60,
               what="the browser's camera where it was set")  # fmt: skip


def wait_camera_still(client, quiet_s: float = 0.5) -> None:
    """Wait until ``client``'s browser has reported no camera move for ``quiet_s`` seconds."""
    reports = camera_reports(client)
    wait_until(lambda: not reports.poses or time.monotonic() - reports.poses[-1][0] > quiet_s,
               timeout=60, what="the camera still")  # fmt: skip


def server_caught_up(studio, client, frames: int = 3) -> int:
    """Wait until every message ``client``'s page sent before the call has reached the studio,
    and its loop has run ``frames`` whole frames since (a check that nothing happened, such as
    a key press that must not reach the server, can then fail where a sleep proves nothing).
    Returns the index, in :func:`camera_reports`, of the probe's report: every report the page
    sent before the call comes before it.

    The probe: the server raises the page's camera by 1 cm and waits for the page to
    report it. The page sends that report on the websocket after everything it sent before,
    viser handles a connection's messages in order, and the loop handles what their callbacks
    recorded at its next frame. The camera is then put back the same way."""
    from tests.conftest import wait_frames

    reports = camera_reports(client)
    seen = len(reports.poses)
    position = np.array(client.camera.position, dtype=float)
    look_at = np.array(client.camera.look_at, dtype=float)
    up = np.array([0.0, 0.0, 0.01])  # beyond set_camera's tolerance (1 mm)
    set_camera(client, position + up, look_at + up)
    probe = seen + next(i for i, p in enumerate(reports.poses[seen:])
                        if np.allclose(p[1], position + up, atol=1e-4))  # fmt: skip
    set_camera(client, position, look_at)
    wait_frames(studio, frames)
    return probe


def _same(a, b) -> bool:
    """Equal pictures: PNG bytes, or pixel arrays."""
    return a == b if isinstance(a, bytes) else np.array_equal(a, b)


def settled(capture, unlike=None, *, timeout: float, interval: float, what: str):
    """What ``capture()`` returns once two captures in a row are equal (the last changes drawn)
    and differ from ``unlike`` (a picture from before the changes, when given)."""
    previous = None

    def steady():
        nonlocal previous
        image = capture()
        same = previous is not None and _same(image, previous)
        previous = image
        if same and (unlike is None or not _same(image, unlike)):
            return (image,)
        return None

    (image,) = wait_until(steady, timeout=timeout, interval=interval, what=what)
    return image


def settled_screenshot(page, path: Path, unlike: bytes | None = None, timeout=60.0) -> None:
    """Save a screenshot of ``page`` once two in a row are the same and differ from
    ``unlike`` when given (:func:`settled`), without the notifications."""
    close_notifications(page)
    image = settled(page.screenshot, unlike, timeout=timeout, interval=0.2,
                    what="the picture changed, then still")  # fmt: skip
    path.write_bytes(image)


def settled_render(client, unlike: np.ndarray | None = None) -> np.ndarray:
    """A 400 x 300 render of the browser's view once two in a row are the same (the meshes
    have arrived and the scene is still), and differ from ``unlike`` when given."""
    return settled(lambda: client.get_render(300, 400, timeout=60).astype(float), unlike,
                   timeout=120, interval=0.5, what="a settled render")  # fmt: skip


def screenshot(page, path: Path) -> None:
    """A screenshot without the notifications over the scene."""
    close_notifications(page)
    page.screenshot(path=str(path))


CANVAS_SCALE_JS = """() => {
    const area = (c) => c.clientWidth * c.clientHeight;
    let best = null;
    for (const canvas of document.querySelectorAll("canvas")) {
        if (canvas.width > 0 && (!best || area(canvas) > area(best))) best = canvas;
    }
    return best.clientWidth / best.width;
}"""


def camera_pixels(page, client, points) -> np.ndarray:
    """Page coordinates (CSS pixels, n x 2) of world points (n, 3) in the camera the browser
    reports (OpenCV convention: x right, y down, z forward; ``wxyz`` and ``position`` give the
    camera-to-world pose). The camera's image size is the 3D canvas's in its own pixels,
    which are CSS pixels times the page's resolution (the largest sized canvas is the 3D view's)."""
    camera = client.camera
    rotation = vtf.SO3(np.asarray(camera.wxyz)).as_matrix()
    local = (np.atleast_2d(points) - camera.position) @ rotation
    height, width = camera.image_height, camera.image_width
    focal = (height / 2.0) / math.tan(camera.fov / 2.0)
    pixels = np.column_stack(
        [
            width / 2 + focal * local[:, 0] / local[:, 2],
            height / 2 + focal * local[:, 1] / local[:, 2],
        ]
    )
    return pixels * page.evaluate(CANVAS_SCALE_JS)


def drag_gizmo(page, client, gizmo, direction, pixels: float, steps: int = 4) -> None:
    """Drag ``gizmo`` (a viser transform control) with the real mouse, in a few steps, by the
    arrow of its frame's axis closest to the world ``direction`` (3,) among those seen side-on,
    so that it moves along it. (Each mouse event waits for the page to render a frame, which
    software WebGL makes slow, so the steps are few and large; the gizmo follows the pointer
    anyway.)"""
    centre = np.asarray(gizmo.position, dtype=float)
    axes = vtf.SO3(np.asarray(gizmo.wxyz)).as_matrix()
    alignment = np.asarray(direction, dtype=float) @ axes  # cosine with each axis
    best = None
    for k in np.argsort(-np.abs(alignment)):
        axis = gizmo.scale * axes[:, k]
        ends = np.stack([centre, centre + 0.85 * axis, centre + axis])
        origin, grab, tip = camera_pixels(page, client, ends)
        if np.linalg.norm(tip - origin) > 40.0:  # an arrow seen side-on, easy to grab
            best = (k, grab, tip)
            break
    assert best is not None, "every arrow of the gizmo points at the camera"
    k, grab, tip = best
    screen = (tip - grab) / np.linalg.norm(tip - grab) * np.sign(alignment[k])
    camera = np.array(client.camera.position)
    page.mouse.move(*grab)
    page.mouse.down()
    for i in range(1, steps + 1):
        page.mouse.move(*(grab + screen * pixels * i / steps))
        time.sleep(0.05)
    page.mouse.up()
    np.testing.assert_allclose(client.camera.position, camera, err_msg="the drag orbited the view")
