"""The foundation: the CLI, the robot model, and the iCub standing in a real browser."""

from __future__ import annotations

import ctypes
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from app.cli import build_parser
from app.io.net import free_port, is_loopback, port_is_free
from app.scene.camera import partner_eye
from robots.icub.model import DEFAULT_ROBOT, available_robots, load_urdf, natural_pose, urdf_path
from tests.browser import settled_render
from tests.conftest import REPO, wait_until


def test_help_documents_every_option() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "app", "--help"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    for option in ("--host", "--port", "--workspace", "--robot"):
        assert option in out
    assert "127.0.0.1" in out


def test_default_host_is_loopback() -> None:
    args = build_parser().parse_args([])
    assert args.host == "127.0.0.1"
    assert is_loopback(args.host)
    assert args.port == 8080


@pytest.mark.parametrize(
    "host, loopback",
    [
        ("127.0.0.1", True),
        ("localhost", True),
        ("::1", True),
        ("0.0.0.0", False),
        ("10.1.2.3", False),
    ],
)
def test_is_loopback(host: str, loopback: bool) -> None:
    assert is_loopback(host) is loopback


def test_taken_port_is_a_clear_error(tmp_path) -> None:
    with socket.socket() as blocker:
        blocker.bind(("127.0.0.1", 0))
        blocker.listen()
        port = blocker.getsockname()[1]
        assert not port_is_free("127.0.0.1", port)
        proc = subprocess.run(
            [sys.executable, "-m", "app", "--port", str(port), "--workspace", str(tmp_path / "ws")],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=60,
        )
    assert proc.returncode != 0
    assert f"port {port}" in proc.stderr and "already in use" in proc.stderr


def test_public_host_warns(tmp_path) -> None:
    # An invalid port makes the CLI stop right after the host check.
    proc = subprocess.run(
        [sys.executable, "-m", "app", "--host", "0.0.0.0", "--port", "0"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert "WARNING" in proc.stderr and "no authentication" in proc.stderr
    assert proc.returncode != 0


def test_unknown_robot_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="unknown robot 'iCubNowhere'.*iCubNancy01"):
        urdf_path("iCubNowhere")
    assert DEFAULT_ROBOT in available_robots()


def test_natural_pose_is_inside_limits() -> None:
    urdf = load_urdf(load_meshes=False)
    q = natural_pose(urdf)
    for name, value in zip(urdf.actuated_joint_names, q, strict=True):
        limit = urdf.joint_map[name].limit
        assert limit.lower <= value <= limit.upper, name
    # The all-zero pose is not natural: the elbow limit excludes it.
    assert q[urdf.actuated_joint_names.index("l_elbow")] > 0.5


def test_server_serves_the_page_from_the_cli(tmp_path) -> None:
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "--port", str(port), "--workspace", str(tmp_path / "ws")],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        url = f"http://127.0.0.1:{port}"
        first_lines = []
        while not any("running at" in line for line in first_lines):
            line = proc.stdout.readline()
            assert line, f"the studio exited early: {''.join(first_lines)}"
            first_lines.append(line)
        assert f"running at {url}" in first_lines[-1]

        def page() -> bytes | None:
            try:
                with urllib.request.urlopen(url, timeout=2) as response:
                    return response.read()
            except OSError:
                return None

        body = wait_until(page, timeout=60, what="the studio's page")
        assert b"<html" in body.lower()
        # The kernel may hand a SIGTERM sent to the process to any of its threads (under load it
        # gave it to another than the main one, and the studio slept on through it): sent to a
        # thread that is not the main one, it must stop the studio as well.
        time.sleep(1.0)  # not a wait for a state: the studio must keep serving meanwhile
        assert proc.poll() is None, "the studio stopped without being asked to"
        _signal_a_thread_other_than_main(proc.pid, signal.SIGTERM)
        proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, "SIGTERM should stop the studio cleanly"


def _signal_a_thread_other_than_main(pid: int, number: int) -> None:
    """Send signal ``number`` to one thread of process ``pid`` other than its main thread
    (Linux's tgkill, from glibc)."""
    threads = sorted(int(task.name) for task in Path(f"/proc/{pid}/task").iterdir())
    other = next(tid for tid in threads if tid != pid)
    libc = ctypes.CDLL(None, use_errno=True)
    assert libc.tgkill(pid, other, number) == 0, os.strerror(ctypes.get_errno())


@pytest.mark.browser
def test_robot_is_rendered_in_chromium(browser, tmp_path, artifacts) -> None:
    from app.studio import Studio

    studio = Studio.start("127.0.0.1", free_port(), tmp_path / "ws")
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    try:
        page.goto(f"http://127.0.0.1:{studio.port}")
        clients = wait_until(studio.server.get_clients, what="the browser to connect")
        client = next(iter(clients.values()))
        wait_until(
            lambda: np.linalg.norm(client.camera.position - partner_eye()) < 0.2,
            timeout=60, what="the start view (behind the partner's head)",
        )  # fmt: skip
        with_robot = settled_render(client)
        page.screenshot(path=str(artifacts / "foundation.png"))
        studio.arm.robot.root.visible = False
        without_robot = settled_render(client, unlike=with_robot)
    finally:
        page.close()
        studio.stop()
    changed = np.abs(with_robot - without_robot).sum(axis=2) > 30
    assert changed.mean() > 0.03, "the robot does not show in the rendered frame"
    # Seen from behind the partner's head (the start view), the robot stands left of the
    # middle, above the table; the panel covers the right.
    rows, cols = np.nonzero(changed)
    assert cols.mean() / 400 < 0.5 and rows.mean() / 300 < 0.7, (cols.mean(), rows.mean())


def test_moving_the_arm_updates_its_joints_frames_as_a_full_update_would() -> None:
    """The robot's display updates only the frames of the joints whose angle changed (a full
    update of the iCub's 59 joints cost a frame of the loop at every step of a drag); the
    frames end where viser's full update puts them."""
    import viser

    from app.scene.robot import add_robot
    from robots.icub.scene import DEFAULT_SCENE

    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        view = add_robot(server, load_urdf(DEFAULT_ROBOT), DEFAULT_SCENE)
        rng = np.random.default_rng(0)
        q = view.q.copy()
        for _ in range(5):
            moved = rng.choice(q.size, 7, replace=False)
            q[moved] += rng.normal(scale=0.1, size=7)
            view.set_configuration(q)
        frames = view.viser_urdf._joint_frames
        fast = [(np.array(f.wxyz), np.array(f.position)) for f in frames]
        view.viser_urdf.update_cfg(q)  # viser's own: every joint
        for (wxyz, position), frame in zip(fast, frames, strict=True):
            same_rotation = min(np.abs(wxyz - frame.wxyz).max(), np.abs(wxyz + frame.wxyz).max())
            assert same_rotation < 1e-12 and np.abs(position - frame.position).max() < 1e-12
    finally:
        server.stop()
