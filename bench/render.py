"""What an idle studio page costs a browser without a GPU: Chromium's CPU, in cores.

Headless Chromium draws the 3D view with SwiftShader (software Vulkan under ANGLE), as a
laptop without a usable GPU does. viser renders on demand, but it draws a heartbeat frame every
second, so an idle page still costs what its frames cost. The studio is started on a temporary
workspace (the default scenario) and one page of ``--width`` x ``--height`` is opened; after
``--settle`` seconds of loading, the CPU time of every Chromium process over ``--seconds`` is
measured, first with the studio's lighting (directional and ambient lights,
:mod:`app.scene.robot`) and then with viser's default look (its image-based environment map
and shadows), each on a fresh page, in the same run. The last line is one JSON object with
both figures and their ratio.

Run: ``.venv/bin/python bench/render.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from app.io.net import free_port  # noqa: E402
from app.studio import Studio  # noqa: E402


def chromium_cpu_seconds() -> float:
    """User + system CPU time of every running Chromium process (and its threads)."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0.0
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as file:
                if b"chromium" not in file.read().split(b"\0")[0]:
                    continue
            with open(f"/proc/{pid}/stat") as file:
                fields = file.read().rsplit(")", 1)[1].split()
        except OSError:  # a process that ended meanwhile
            continue
        total += (int(fields[11]) + int(fields[12])) / tick
    return total


def use_viser_default_look(studio: Studio) -> None:
    """viser's own look: its environment map and shadow-casting default lights."""
    scene = studio.server.scene
    scene.configure_environment_map(hdri="warehouse")  # viser's default
    scene.configure_default_lights(enabled=True, cast_shadow=True)
    scene.remove_by_name("/light/ambient")


def measure(browser, look: str, width: int, height: int, settle: float, seconds: float) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        studio = Studio.start("127.0.0.1", free_port(), Path(tmp) / "workspace")
        try:
            if look == "viser default":
                use_viser_default_look(studio)
            page = browser.new_page(viewport={"width": width, "height": height})
            page.goto(f"http://127.0.0.1:{studio.port}")
            time.sleep(settle)  # loading: the scene streams in, every message draws frames
            start_cpu, start = chromium_cpu_seconds(), time.monotonic()
            time.sleep(seconds)
            cores = (chromium_cpu_seconds() - start_cpu) / (time.monotonic() - start)
            page.close()
        finally:
            studio.stop()
    print(f"{look}: {cores:.2f} cores ({width} x {height}, idle page)")
    return cores


def main(width: int = 1400, height: int = 900, settle: float = 24.0, seconds: float = 16.0) -> None:
    from playwright.sync_api import sync_playwright

    from tests.conftest import CHROMIUM, CHROMIUM_FLAGS

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_FLAGS)
        studio_look = measure(browser, "studio", width, height, settle, seconds)
        default_look = measure(browser, "viser default", width, height, settle, seconds)
        browser.close()
    result = {
        "idle_page_cores_studio_look": round(studio_look, 2),
        "idle_page_cores_viser_default_look": round(default_look, 2),
        "ratio": round(default_look / studio_look, 2),
        "viewport": [width, height],
        "load_average_1min": round(os.getloadavg()[0], 2),
        "cpus": os.cpu_count(),
    }
    print(json.dumps(result))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=1400)
    parser.add_argument("--height", type=int, default=900)
    parser.add_argument("--settle", type=float, default=24.0, help="seconds of loading first")
    parser.add_argument("--seconds", type=float, default=16.0, help="seconds measured")
    args = parser.parse_args()
    main(args.width, args.height, args.settle, args.seconds)
