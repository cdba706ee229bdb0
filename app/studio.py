"""The studio: one viser server composing the robot, the session and the panels.

Threading follows viser's dirty-flag pattern: GUI and gizmo callbacks (run by viser's thread
pool) only record what changed; one loop thread (:meth:`Studio._loop`, ~60 Hz) solves the IK,
reads the head source, samples recordings, redraws what the session changed and lets each
panel recompute. Everything GUI-visible lives on the server (not per client), so every browser
tab shows the same studio.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import viser

from app.arm import ArmController
from app.head_sources import HeadReading, HeadSource, SimulatedPartner, StreamHeadSource
from app.robot_view import RobotView, add_robot
from app.scene_view import SceneView
from app.session import Session
from app.workspace import PALETTE, FolderKind, PrimitiveEntry, WorkspaceData, inspect_folder
from robots.icub.kinematics import ArmChain
from robots.icub.model import load_urdf
from robots.icub.scene import DEFAULT_SCENE

LOOP_HZ = 60.0


def default_workspace() -> WorkspaceData:
    """The embedded default: the paper's experiment simulated on the iCub (curved, direct)."""
    from robots.icub.scenario import generate_scenario

    dataset = generate_scenario(seed=0, n_demos=20)
    return WorkspaceData(
        primitives=[PrimitiveEntry(name, PALETTE[i]) for i, name in enumerate(dataset)],
        demos=dataset,
        settings={},  # the engine's defaults: the covariance prior is chosen from the data
    )


@dataclass
class LoopTiming:
    """Server-side durations of the loop's work, milliseconds (shown in the GUI)."""

    ik_ms: float = 0.0
    redraw_ms: float = 0.0
    step_ms: float = 0.0


class Studio:
    """The running studio (build it with :meth:`start`)."""

    def __init__(
        self,
        server: viser.ViserServer,
        session: Session,
        robot: RobotView,
        arm: ArmController,
        head_source: HeadSource,
    ):
        self.server = server
        self.session = session
        self.robot = robot
        self.arm = arm
        self.head_source = head_source
        self.head: HeadReading = head_source.read(arm.hand_position())
        self.view = SceneView(server, session)
        self.timing = LoopTiming()
        self.panels: list = []
        self._stop = threading.Event()
        self._tasks: list[Callable[[], None]] = []
        self._tasks_lock = threading.Lock()
        self._thread = threading.Thread(target=self._loop, name="studio-loop", daemon=True)

    @property
    def port(self) -> int:
        return self.server.get_port()

    @property
    def workspace(self) -> Path:
        return self.session.workspace.root

    @classmethod
    def start(
        cls,
        host: str,
        port: int,
        workspace: Path,
        robot: str = "iCubNancy01",
        camera: int | None = None,
        video: Path | None = None,
        with_panels: bool = True,
    ) -> Studio:
        """Serve the studio on (host, port) with its workspace in ``workspace``.

        An absent or empty workspace folder is first filled with the simulated scenario; a
        folder that holds anything else is refused untouched.

        Raises
        ------
        ValueError
            If the robot name is unknown, the workspace is not a usable folder, or the port
            could not be bound (viser would silently pick another one).
        """
        workspace = Path(workspace)
        kind, message = inspect_folder(workspace)  # before anything slow: refuse at once
        if kind is FolderKind.FOREIGN:
            raise ValueError(message)
        urdf = load_urdf(robot)  # before binding: an unknown robot fails fast
        arm_chain = ArmChain.from_urdf(load_urdf(robot, load_meshes=False))
        session = Session.open(workspace, default=default_workspace)
        server = viser.ViserServer(
            host=host, port=port, label="iCub intention studio", verbose=False
        )
        if port != 0 and server.get_port() != port:
            server.stop()
            raise ValueError(f"port {port} on {host} is already in use")
        # No "Share" button: it would publish the studio on a public URL, past the loopback
        # default.
        server.gui.configure_theme(
            control_width="large", dark_mode=False, show_logo=False, show_share_button=False
        )
        view = add_robot(server, urdf, DEFAULT_SCENE)
        arm = ArmController(server, view, arm_chain)
        if camera is not None:
            source: HeadSource = StreamHeadSource(int(camera))
        elif video is not None:
            source = StreamHeadSource(str(video))
        else:
            source = SimulatedPartner()
        studio = cls(server, session, view, arm, source)
        if with_panels:
            from app.panels import build_panels

            build_panels(studio)
        studio._thread.start()
        return studio

    # ------------------------------------------------------------------ loop

    def call_in_loop(self, task: Callable[[], None]) -> None:
        """Run ``task()`` on the loop thread at its next iteration (from any thread)."""
        with self._tasks_lock:
            self._tasks.append(task)

    def set_head_source(self, source: HeadSource) -> None:
        old, self.head_source = self.head_source, source
        if old is not source:
            old.close()

    def _loop(self) -> None:
        period = 1.0 / LOOP_HZ
        while not self._stop.is_set():
            start = time.perf_counter()
            try:
                self.step()
            except Exception as exc:  # a bug in one step must not kill the studio
                import traceback

                traceback.print_exc()
                self.notify("Internal error", f"{type(exc).__name__}: {exc}", color="red")
            elapsed = time.perf_counter() - start
            self._stop.wait(max(0.0, period - elapsed))

    def step(self) -> None:
        """One iteration of the loop (also callable directly, e.g. from tests)."""
        start = time.perf_counter()
        with self._tasks_lock:
            tasks, self._tasks = self._tasks, []
        for task in tasks:
            task()
        if self.arm.step():
            self.timing.ik_ms = 1e3 * (time.perf_counter() - start)
        self.head = self.head_source.read(self.arm.hand_position())
        self.view.show_head(self.head.angles)
        redraw = time.perf_counter()
        if self.view.refresh():
            self.timing.redraw_ms = 1e3 * (time.perf_counter() - redraw)
        for panel in self.panels:
            panel.step()
        self.timing.step_ms = 1e3 * (time.perf_counter() - start)

    def notify(
        self,
        title: str,
        body: str,
        color: str = "blue",
        client: viser.ClientHandle | None = None,
        auto_close_seconds: float = 8.0,
    ) -> None:
        """A notification in ``client``'s browser tab, or in every connected tab when None."""
        clients = [client] if client is not None else self.server.get_clients().values()
        for target in clients:
            target.add_notification(
                title=title, body=body, color=color, auto_close_seconds=auto_close_seconds
            )

    def hand_and_head(self) -> tuple[np.ndarray, np.ndarray | None]:
        """The current hand position (3,) and head angles (3,) or None."""
        return self.arm.hand_position(), self.head.angles

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        for panel in self.panels:
            close = getattr(panel, "close", None)
            if close is not None:
                close()
        self.head_source.close()
        self.session.close()
        self.server.stop()
