"""Fault harness: kill -9 the studio at random moments, restart it, check nothing is lost.

    .venv/bin/python bench/soak.py [--cycles 20] [--seed 0] [--port 8765] [--keep DIR]

The studio runs as a separate process (``python -m app``) on a temporary workspace. Two
clients are connected: two **headless Chromium pages** (Playwright, ``/usr/bin/chromium``),
the way a user's browser tabs are. Every cycle:

1. page A records a demonstration through the GUI, as a user does: *Record*, then a real mouse
   drag of the hand's gizmo upwards (the gizmo is found on screen from the camera the page
   reports, ``?logCamera``, and the arm's start pose; grabbed by an arrow's cone), then,
   once the take's live curve in the Teach tab shows the hand moved 2 cm, *Stop*;
2. page B scrubs the Infer tab's *Observed %* slider meanwhile (arrow keys);
3. the server is killed with SIGKILL at a random moment of one of five phases, taken in turn
   in a shuffled order: during the recording, during the save (right after *Stop*), during
   the refit that follows a save, during a dataset import (*Create workspace*), or while
   page B scrubs;
   (before an import or a scrub, page A records one demonstration in full);
4. with the server dead, the disk is checked: ``studio.json`` loads
   (:meth:`app.io.workspace.Workspace.load`), every demonstration whose save page A was told of
   (the "Demonstration saved" notification) is on disk and loads, and every data file (CSV,
   JSON) of the workspace, of its trash and of any workspace an import created parses
   (a file that does not is counted in ``corrupt_files``; the hidden temporary files of
   interrupted atomic writes are never read and are counted apart);
5. the server is restarted on the same port; both pages reconnect by themselves; the time from
   the restart until both show the studio again is ``reconnect_s``; both must then show the
   same primitives and demonstration counts as the disk.

The last line is one JSON object: ``cycles``, ``kills_during_<phase>``, ``demos_acknowledged``,
``demos_lost``, ``corrupt_files``, ``temp_files_left``, ``client_mismatches``,
``reconnect_s_median`` (and ``_max``). Target: ``demos_lost == 0`` and ``corrupt_files == 0``.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import os
import random
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from app.io.workspace import Workspace  # noqa: E402
from app.scene.arm import GIZMO_SCALE  # noqa: E402
from promp.datasets import demo_to_csv, read_csv_demo  # noqa: E402
from robots.icub.kinematics import ArmChain  # noqa: E402
from robots.icub.model import load_urdf, natural_pose  # noqa: E402
from tests.browser import press  # noqa: E402

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--no-first-run",
]  # fmt: skip
PHASES = ("recording", "save", "refit", "import", "scrub")
VIEWPORT = {"width": 900, "height": 580}  # software WebGL costs about 1 core per 1.2 Mpixel page
# Where along a gizmo arrow the drag grabs it: on its cone. (At 0.85 of the arrow, in the start
# view from the partner's side, a rotation ring lies on the arrow: the grab turns the hand.)
GRAB = 0.95
# The largest range (cm) of the take's live curve ("the recording") over the Teach tab's hand
# charts (uPlot's test hook in viser's page).
LIVE_HAND_RANGE_JS = """() => {
    let best = 0;
    for (const t of Object.values(window.__viserTestpoints?.uplots ?? {})) {
        const title = t.chart.root.querySelector('.u-title')?.textContent ?? '';
        if (!title.startsWith('hand ')) continue;
        t.chart.series.forEach((s, i) => {
            if (i === 0 || s.label !== 'the recording') return;
            const v = Array.from(t.chart.data[i]).filter((x) => x !== null && Number.isFinite(x));
            if (v.length) best = Math.max(best, Math.max(...v) - Math.min(...v));
        });
    }
    return best;
}"""
SAVED = re.compile(r"\b([A-Za-z0-9][A-Za-z0-9_-]*_\d{3})\b")
DEADLINE_S = 120.0


def wait_for(predicate, timeout: float = DEADLINE_S, what: str = "a condition"):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.05)
    raise TimeoutError(f"timed out after {timeout:.0f} s waiting for {what}")


# ------------------------------------------------------------------------------ the server


@dataclass
class Server:
    workspace: Path
    port: int
    log: Path
    process: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/"

    def start(self) -> float:
        """Start the studio; returns the monotonic time it was started at, once it serves."""
        started = time.monotonic()
        handle = open(self.log, "a")  # noqa: SIM115 - the process owns it until it ends
        self.process = subprocess.Popen(
            [sys.executable, "-m", "app", "--workspace", str(self.workspace),
             "--port", str(self.port)],
            cwd=ROOT, stdout=handle, stderr=subprocess.STDOUT,
        )  # fmt: skip
        handle.close()
        wait_for(self._serves, what="the studio to serve its page")
        return started

    def _serves(self) -> bool:
        if self.process is not None and self.process.poll() is not None:
            raise RuntimeError(f"the studio exited ({self.process.returncode}); see {self.log}")
        try:
            with urllib.request.urlopen(self.url, timeout=2) as response:
                return response.status == 200
        except OSError:
            return False

    def kill(self) -> None:
        """SIGKILL: no chance to flush, close or clean anything."""
        if self.process is not None and self.process.poll() is None:
            os.kill(self.process.pid, signal.SIGKILL)
            self.process.wait()
        self.process = None


# ------------------------------------------------------------------------------ the clients


class Client:
    """One browser tab on the studio."""

    def __init__(self, browser, url: str, name: str):
        self.name = name
        self.context = browser.new_context(viewport=VIEWPORT)
        self.page = self.context.new_page()
        self.camera: dict | None = None
        self.acknowledged: set[str] = set()
        self.page.on("console", self._console)
        self.page.goto(url + "?logCamera")

    def _console(self, message) -> None:
        text = message.text
        if "initialCameraPosition=" in text:
            fields = dict(part.split("=", 1) for part in text.strip("&").split("&"))
            self.camera = {k: [float(v) for v in fields[k].split(",")] for k in fields}

    def press(self, locator) -> None:
        """A real mouse click at the middle of ``locator``, as the browser tests click."""
        press(self.page, locator)

    def tab(self, name: str) -> None:
        self.press(self.page.get_by_role("tab", name=name, exact=True).first)

    def button(self, name: str):
        return self.page.get_by_role("button", name=name, exact=True).first

    def click(self, name: str) -> None:
        """Click the button ``name`` (a DOM click event, as the tests do)."""
        button = self.button(name)
        button.wait_for(timeout=int(DEADLINE_S * 1000))
        button.dispatch_event("click")

    def connected(self) -> bool:
        """viser's header shows a green cloud while its websocket is connected."""
        try:
            return self.page.locator("svg.tabler-icon-cloud-check").count() > 0
        except Exception:  # noqa: BLE001 - the page is reloading
            return False

    def shows_studio(self) -> bool:
        """Connected, with the studio's GUI built."""
        try:
            return self.connected() and self.page.get_by_role(
                "tab", name="Teach", exact=True
            ).count() > 0
        except Exception:  # noqa: BLE001
            return False

    def state(self) -> tuple[tuple[str, ...], dict[str, int]]:
        """(primitives, demonstration count per primitive) as this tab shows them (Teach)."""
        self.tab("Teach")
        dropdown = self.page.get_by_label("Primitive", exact=True).first
        self.press(dropdown)
        options = self.page.get_by_role("option")
        options.first.wait_for(timeout=60_000)
        names = [options.nth(i).inner_text().strip() for i in range(options.count())]
        self.page.keyboard.press("Escape")
        counts = {}
        for name in (*names[1:], names[0]):  # the first one selected again at the end
            self.press(dropdown)
            self.press(self.page.get_by_role("option", name=name, exact=True).first)
            pattern = re.compile(rf"(\d+) demonstration\(s\) of {re.escape(name)}")
            found = wait_for(
                lambda p=pattern: p.search(self.page.inner_text("body")),
                what=f"the demonstration count of {name}",
            )
            counts[name] = int(found.group(1))
        return tuple(names), counts

    def remember_saved(self) -> None:
        """Note the demonstrations the notifications shown now say were saved."""
        self.acknowledged.update(self.saved_names())

    def saved_names(self) -> set[str]:
        """The demonstrations this tab was told were saved (notifications, still shown after
        the server died), with those noted by :meth:`remember_saved`."""
        boxes = self.page.locator(".mantine-Notification-root", has_text="Demonstration saved")
        found = set(self.acknowledged)
        for i in range(boxes.count()):
            try:
                found.update(SAVED.findall(boxes.nth(i).inner_text(timeout=2_000)))
            except Exception:  # noqa: BLE001 - closed meanwhile
                pass
        return found

    def close_notifications(self) -> None:
        buttons = self.page.locator(".mantine-Notification-closeButton")
        for _ in range(buttons.count()):
            try:
                buttons.first.dispatch_event("click", timeout=2_000)
            except Exception:  # noqa: BLE001
                pass


def project(camera: dict, size: tuple[float, float], points: np.ndarray) -> np.ndarray:
    """Pixels of world ``points`` (n, 3) in a pinhole view of ``camera`` (the page's logged
    position, look-at point, up vector and vertical field of view in radians)."""
    position = np.array(camera["initialCameraPosition"])
    forward = np.array(camera["initialCameraLookAt"]) - position
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.array(camera["initialCameraUp"]))
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    local = (np.atleast_2d(points) - position) @ np.column_stack([right, down, forward])
    width, height = size
    focal = (height / 2.0) / math.tan(camera["initialCameraFov"][0] / 2.0)
    return np.column_stack([width / 2 + focal * local[:, 0] / local[:, 2],
                            height / 2 + focal * local[:, 1] / local[:, 2]])  # fmt: skip


def drag_path(client: Client, hand_pose: np.ndarray, pixels: float, rng: random.Random,
              steps: int = 4, stop_after: float | None = None) -> None:  # fmt: skip
    """Drag the hand up by the gizmo's arrow closest to vertical among those seen side-on, by
    ``pixels`` in ``steps`` moves (as the browser tests drag); with ``stop_after`` seconds,
    return mid-drag (the mouse still held)."""
    page = client.page
    wait_for(lambda: client.camera, what="the page's camera")
    box = page.locator("canvas").first.bounding_box()
    size = (box["width"], box["height"])
    centre, axes = hand_pose[:3, 3], hand_pose[:3, :3]
    best = None
    for k in np.argsort(-np.abs(axes[2])):  # the axis closest to vertical first
        axis = GIZMO_SCALE * axes[:, k]
        origin, grab, tip = project(client.camera, size, np.stack([centre, centre + GRAB * axis,
                                                                   centre + axis]))  # fmt: skip
        if np.linalg.norm(tip - origin) > 40.0:
            upward = np.sign(axes[2, k]) or 1.0  # along the arrow, or against it: up
            best = (grab, upward * (tip - grab) / np.linalg.norm(tip - grab))
            break
    if best is None:
        raise RuntimeError("every arrow of the gizmo points at the camera")
    grab, direction = best
    grab = grab + np.array([box["x"], box["y"]])
    page.mouse.move(*grab)
    page.mouse.down()
    started = time.monotonic()
    for i in range(1, steps + 1):
        wobble = rng.uniform(-0.1, 0.1) * pixels / steps
        page.mouse.move(*(grab + direction * pixels * i / steps + wobble))
        time.sleep(0.05)
        if stop_after is not None and time.monotonic() - started > stop_after:
            return
    page.mouse.up()


def scrub(client: Client, rng: random.Random, presses: int = 6) -> None:
    """Arrow keys on the Infer tab's slider (the only slider shown in that tab)."""
    slider = client.page.locator("[role=slider]:visible").first
    slider.focus(timeout=int(DEADLINE_S * 1000))
    for _ in range(presses):
        client.page.keyboard.press(rng.choice(("ArrowLeft", "ArrowRight", "ArrowRight")))
        time.sleep(0.05)


# ------------------------------------------------------------------------------ the disk


@dataclass
class DiskCheck:
    corrupt: list[str] = field(default_factory=list)
    temp_files: int = 0
    missing: list[str] = field(default_factory=list)


def check_disk(workspace: Path, acknowledged: dict[str, str]) -> DiskCheck:
    """Every data file parses; every acknowledged demonstration (name -> primitive) is in the
    workspace or its trash and loads."""
    out = DiskCheck()
    roots = [workspace] + [p for p in workspace.parent.iterdir()
                           if p != workspace and (p / "studio.json").exists()]  # fmt: skip
    for root in roots:
        try:
            Workspace(root).load()
        except Exception as exc:  # noqa: BLE001
            out.corrupt.append(f"{root}/studio.json: {exc}")
        for path in sorted(root.rglob("*")):
            if not path.is_file():
                continue
            if path.name.startswith(".") and path.name.endswith(".tmp"):
                out.temp_files += 1  # an atomic write cut short: never read
                continue
            try:
                if path.suffix == ".csv":
                    read_csv_demo(path)
                elif path.suffix == ".json":
                    json.loads(path.read_text())
            except Exception as exc:  # noqa: BLE001
                out.corrupt.append(f"{path}: {exc}")
    for name, primitive in acknowledged.items():
        places = [workspace / "demos" / primitive / f"{name}.csv",
                  *workspace.glob(f"trash/*/files/demos/{primitive}/{name}.csv")]  # fmt: skip
        found = [p for p in places if p.exists()]
        try:
            if not found:
                raise FileNotFoundError("not on disk")
            read_csv_demo(found[0])
        except Exception as exc:  # noqa: BLE001
            out.missing.append(f"{primitive}/{name}: {exc}")
    return out


def disk_state(workspace: Path) -> tuple[tuple[str, ...], dict[str, int]]:
    data = Workspace(workspace).load()
    names = tuple(p.name for p in data.primitives)
    return names, {n: len(data.demos.get(n, [])) for n in names}


def dataset_zip(seed: int) -> bytes:
    """A small dataset (two primitives, three demonstrations each) to import."""
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=seed, n_demos=3)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for primitive, demos in dataset.items():
            for demo in demos:
                archive.writestr(f"imported/{primitive}/{demo.name}.csv", demo_to_csv(demo))
    return buffer.getvalue()


# ------------------------------------------------------------------------------ one cycle


def record(a: Client, b: Client, hand_pose: np.ndarray, rng: random.Random, kill, phase: str
           ) -> None:  # fmt: skip
    """Record one demonstration on page A (B scrubs meanwhile); ``kill()`` at the phase's
    random moment (phase "saved": no kill, return once the save is acknowledged)."""
    a.tab("Teach")
    a.close_notifications()
    a.click("Record")
    a.page.get_by_text("Recording into", exact=False).first.wait_for(timeout=60_000)
    b.tab("Infer")
    scrub(b, rng, presses=3)
    if phase == "recording":
        drag_path(a, hand_pose, pixels=80, rng=rng, stop_after=rng.uniform(0.0, 1.2))
        kill()
        return
    drag_path(a, hand_pose, pixels=80, rng=rng)
    scrub(b, rng, presses=3)
    # Stop once the take's live curve shows the hand moved, as a user watching it would: on a
    # busy machine the page sends the gizmo's moves a frame late, and the Stop click (sent at
    # once) can overtake them.
    wait_for(lambda: a.page.evaluate(LIVE_HAND_RANGE_JS) >= 2.0,
             what="the live curve to show the hand moved 2 cm")  # fmt: skip
    a.click("Stop")
    if phase == "save":
        time.sleep(rng.uniform(0.0, 0.3))
        kill()
        return
    saved = a.page.locator(".mantine-Notification-root", has_text="Demonstration saved")
    refused = a.page.locator(".mantine-Notification-root", has_text="Nothing saved")
    wait_for(lambda: saved.count() or refused.count(), what="the take saved or refused")
    if not saved.count():  # the scripted drag missed the gizmo: a harness defect, say so
        raise RuntimeError(f"the take was refused: {refused.first.inner_text()!r}")
    a.remember_saved()  # now: the notification closes by itself after a while
    if phase == "refit":
        time.sleep(rng.uniform(0.0, 1.5))
        kill()


def import_dataset(a: Client, content: bytes, rng: random.Random, kill) -> None:
    a.tab("Data")
    button = a.page.get_by_role("button", name="Upload dataset", exact=True).first
    button.wait_for(timeout=60_000)
    uuid = button.evaluate(
        "b => { let n = b; while (n && !n.querySelector('input[type=file]')) n = n.parentElement;"
        " return n ? n.querySelector('input[type=file]').id : null; }"
    )
    a.page.set_input_files(f"[id='{uuid}']", files=[{
        "name": "imported.zip", "mimeType": "application/zip", "buffer": content}])  # fmt: skip
    a.click("Create workspace")
    time.sleep(rng.uniform(0.0, 1.0))
    kill()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cycles", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--keep", type=Path, default=None,
                        help="keep the workspaces and the server log in this folder")  # fmt: skip
    args = parser.parse_args(argv)
    from playwright.sync_api import sync_playwright

    rng = random.Random(args.seed)
    base = Path(tempfile.mkdtemp(prefix="icub-soak-")) if args.keep is None else args.keep
    base.mkdir(parents=True, exist_ok=True)
    workspace = base / "workspace"
    server = Server(workspace, args.port, base / "server.log")
    urdf = load_urdf("iCubNancy01", load_meshes=False)
    chain = ArmChain.from_urdf(urdf)
    hand_pose = chain.fk(chain.from_full(natural_pose(urdf)))  # where every start leaves it
    phases = [PHASES[i % len(PHASES)] for i in range(args.cycles)]
    rng.shuffle(phases)
    kills = dict.fromkeys(PHASES, 0)
    acknowledged: dict[str, str] = {}
    lost: set[str] = set()
    corrupt: set[str] = set()
    temp_files = mismatches = 0
    reconnect: list[float] = []
    content = dataset_zip(args.seed)
    print(f"soak: {args.cycles} cycles, workspace {workspace}, log {server.log}", flush=True)
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        server.start()
        a, b = Client(browser, server.url, "A"), Client(browser, server.url, "B")
        for client in (a, b):
            client.page.bring_to_front()
            wait_for(client.shows_studio, what=f"page {client.name}")
        try:
            for cycle, phase in enumerate(phases, start=1):
                primitive = disk_state(workspace)[0][0]
                killed = []

                def kill(killed=killed) -> None:
                    server.kill()
                    killed.append(time.monotonic())

                if phase in ("import", "scrub"):  # after a demonstration saved in full
                    record(a, b, hand_pose, rng, kill, "saved")
                if phase == "import":
                    import_dataset(a, content, rng, kill)
                elif phase == "scrub":
                    b.tab("Infer")
                    scrub(b, rng, presses=rng.randint(1, 8))
                    kill()
                else:
                    record(a, b, hand_pose, rng, kill, phase)
                if not killed:
                    kill()
                kills[phase] += 1
                for name in a.saved_names():
                    acknowledged.setdefault(name, primitive)
                a.acknowledged.clear()  # counted
                wait_for(lambda: not a.connected() and not b.connected(),
                         what="both pages to see the server gone")  # fmt: skip
                check = check_disk(workspace, acknowledged)
                lost.update(check.missing)
                corrupt.update(check.corrupt)
                temp_files += check.temp_files
                started = server.start()
                served = time.monotonic() - started
                for client in (a, b):  # viser retries only in a focused tab, as a user's is
                    client.page.bring_to_front()
                    wait_for(client.shows_studio, what=f"page {client.name} back")
                reconnect.append(time.monotonic() - started)
                expected = disk_state(workspace)
                seen = [a.state(), b.state()]
                if any(state != expected for state in seen):
                    mismatches += 1
                    print(f"  clients {seen} != disk {expected}", flush=True)
                print(
                    f"cycle {cycle:2d} {phase:9s} acknowledged {len(acknowledged):3d} "
                    f"lost {len(lost)} corrupt {len(corrupt)} reconnect {reconnect[-1]:.1f} s "
                    f"(serving after {served:.1f} s)",
                    flush=True,
                )
        except Exception:
            for client in (a, b):  # what the pages showed, for the report
                client.page.screenshot(path=str(base / f"failed-{client.name}.png"))
            print(f"  screenshots of the pages in {base}", flush=True)
            raise
        finally:
            server.kill()
            browser.close()
    for problem in sorted(lost | corrupt):
        print("  PROBLEM:", problem)
    if args.keep is None:
        shutil.rmtree(base)  # the temporary folder this run made
    summary = {
        "cycles": args.cycles,
        **{f"kills_during_{p}": kills[p] for p in PHASES},
        "demos_acknowledged": len(acknowledged),
        "demos_lost": len(lost),
        "corrupt_files": len(corrupt),
        "temp_files_left": temp_files,
        "client_mismatches": mismatches,
        "reconnect_s_median": round(statistics.median(reconnect), 2) if reconnect else None,
        "reconnect_s_max": round(max(reconnect), 2) if reconnect else None,
    }
    print(json.dumps(summary))
    return 0 if not lost and not corrupt and not mismatches else 1


if __name__ == "__main__":
    sys.exit(main())
