"""Rerun's own web viewer serving a recording on the loopback address, for the browser tests:
its analytics switched off (``rerun analytics disable`` in a configuration folder of the test's
own, never the user's), its listening sockets checked to be loopback ones, and stopped by its
process id."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
from contextlib import contextmanager
from pathlib import Path

from app.io.net import free_port
from tests.conftest import wait_until

LOOPBACK = ("127.", "::1", "localhost")


def rerun_binary() -> Path:
    """The ``rerun`` program the ``rerun-sdk`` wheel ships (the ``rerun`` script runs it as a
    child process: this one is stopped by its own id)."""
    import rerun_cli

    return Path(rerun_cli.__file__).parent / "rerun"


def quiet_environment(home: Path) -> dict[str, str]:
    """An environment whose Rerun configuration lives in ``home``, analytics disabled there by
    Rerun's own switch (checked in its configuration file)."""
    env = dict(os.environ, HOME=str(home), XDG_CONFIG_HOME=str(home / "config"),
               XDG_DATA_HOME=str(home / "data"), XDG_CACHE_HOME=str(home / "cache"))  # fmt: skip
    env.pop("FORCE_RERUN_ANALYTICS", None)
    subprocess.run([str(rerun_binary()), "analytics", "disable"], env=env, check=True,
                   capture_output=True, timeout=120)  # fmt: skip
    config = json.loads((home / "config" / "rerun" / "analytics.json").read_text())
    assert config["analytics_enabled"] is False, config
    return env


def _socket_inodes(pid: int) -> set[str]:
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    return inodes


def _address(hex_address: str) -> tuple[str, int]:
    host, port = hex_address.split(":")
    raw = bytes.fromhex(host)
    if len(raw) == 4:
        return socket.inet_ntop(socket.AF_INET, raw[::-1]), int(port, 16)
    words = b"".join(raw[i : i + 4][::-1] for i in range(0, 16, 4))
    return socket.inet_ntop(socket.AF_INET6, words), int(port, 16)


def listening(pid: int) -> set[tuple[str, int]]:
    """The (address, port) pairs process ``pid`` listens on (TCP, /proc)."""
    inodes = _socket_inodes(pid)
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in inodes:  # LISTEN
                found.add(_address(fields[1]))
    return found


def _accepts(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
    except OSError:
        return False
    return True


@contextmanager
def web_viewer(recording: Path, home: Path, log: Path):
    """``rerun --web-viewer --bind 127.0.0.1 RECORDING``: yields (the page's address, the
    process); stopped (by its id, killed after 20 s) on exit."""
    env = quiet_environment(home)
    web, grpc = free_port(), free_port()
    with open(log, "wb") as out:
        process = subprocess.Popen(
            [str(rerun_binary()), "--web-viewer", "--bind", "127.0.0.1", "--web-viewer-port",
             str(web), "--port", str(grpc), str(recording)],
            env=env, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
        )  # fmt: skip
    try:
        wait_until(lambda: process.poll() is not None or (_accepts(web) and _accepts(grpc)),
                   timeout=120, what="the web viewer's two ports")  # fmt: skip
        assert process.poll() is None, log.read_text()
        proxy = f"rerun%2Bhttp%3A%2F%2F127.0.0.1%3A{grpc}%2Fproxy"
        # notebook=true: the page's own analytics are off (Rerun starts none in a notebook)
        yield f"http://127.0.0.1:{web}/?url={proxy}&notebook=true&persist=false", process
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(timeout=20)
