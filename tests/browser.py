"""Helpers for driving the studio in headless Chromium (Playwright), shared by the browser
tests. Every wait is for a state, with a generous deadline, never a fixed sleep."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import viser.transforms as vtf

from tests.conftest import wait_until


def press(page, locator) -> None:
    """A real mouse click at the middle of ``locator``. (Playwright's own ``click`` first waits
    for the element to be stable over animation frames, which software WebGL makes very slow
    on a busy machine.)"""
    locator.wait_for(state="visible", timeout=120_000)
    box = locator.bounding_box(timeout=120_000)
    page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)


def click(page, name: str) -> None:
    """Click the first button named ``name`` (a DOM click event: no animation-frame waits)."""
    page.get_by_role("button", name=name, exact=True).first.dispatch_event("click")


def choose(page, handle, option: str) -> None:
    """Pick ``option`` in a dropdown by mouse, as a user does (nothing when already chosen)."""
    if handle.value == option:
        return
    press(page, page.locator(f"[id='{handle._impl.uuid}']"))
    press(page, page.get_by_role("option", name=option, exact=True))
    wait_until(lambda: handle.value == option, timeout=60, what=f"{option!r} chosen")


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


def close_notifications(page) -> None:
    buttons = page.locator(".mantine-Notification-closeButton")
    for _ in range(buttons.count()):
        try:
            buttons.first.dispatch_event("click", timeout=5_000)
        except Exception:  # a notification that closed by itself meanwhile
            pass


def screenshot(page, path: Path) -> None:
    """A screenshot without the notifications over the scene."""
    close_notifications(page)
    wait_until(
        lambda: page.locator(".mantine-Notification-root").count() == 0,
        timeout=30, what="the notifications to close",
    )  # fmt: skip
    page.screenshot(path=str(path))


def camera_pixels(client, points) -> np.ndarray:
    """Pixel coordinates (n, 2) of world points (n, 3) in the camera the browser reports
    (OpenCV convention: x right, y down, z forward; ``wxyz`` and ``position`` give the
    camera-to-world pose)."""
    camera = client.camera
    rotation = vtf.SO3(np.asarray(camera.wxyz)).as_matrix()
    local = (np.atleast_2d(points) - camera.position) @ rotation
    height, width = camera.image_height, camera.image_width
    focal = (height / 2.0) / math.tan(camera.fov / 2.0)
    return np.column_stack(
        [
            width / 2 + focal * local[:, 0] / local[:, 2],
            height / 2 + focal * local[:, 1] / local[:, 2],
        ]
    )
