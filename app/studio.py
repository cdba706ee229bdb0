"""The studio: one viser server composing the robot, the session, the scene and the panels.

:meth:`Studio.start` builds everything and each panel inside its tab, with a
:class:`app.ui.context.PanelContext` of its own. One loop thread (:meth:`Studio.step`, ~60 Hz)
does everything that is drawn: it solves the IK for the latest gizmo pose, reads the head
source, takes **one snapshot** of the session (:meth:`app.core.session.Session.snapshot`), hands
it to each panel (:class:`app.ui.context.Frame`), which reads its controls, computes what to
show and writes it, and draws the 3D view once from the snapshot and what the panels asked
for. GUI and gizmo callbacks (run by viser's thread pool) only record what was pressed, or make
one mutation of the store; long work (fits, typicality, held-out models, a take's save) runs on
workers and shows in a later frame's snapshot. Everything GUI-visible lives on the server (not
per client), so every browser tab shows the same studio.
"""

from __future__ import annotations

import collections
import functools
import time
import traceback
from pathlib import Path

import viser

from app.core.fits import FitCache
from app.core.session import Session
from app.io.workspace import FolderKind, WorkspaceData, inspect_folder
from app.io.workspace_index import PALETTE, PrimitiveEntry
from app.live.frame_loop import FrameLoop, one_message_group
from app.live.head import HeadInput, HeadSource, SimulatedPartner, StreamHeadSource
from app.live.lsl_source import LslSource
from app.panels.data import DataPanel
from app.panels.infer import InferPanel
from app.panels.teach import TeachPanel
from app.scene.arm import ArmController
from app.scene.camera_buttons import ViewControls
from app.scene.look import DATA, INFER, TEACH, Shown
from app.scene.robot import add_robot
from app.scene.scene_view import SceneView
from app.ui.callback_guard import GuardedGui
from app.ui.context import Frame, InferRequest, Panel, PanelContext, PanelGui
from app.ui.help import add_help
from app.ui.page_script import BrowserTabs, add_client_script
from app.ui.upload_guard import Refused, UploadGuard
from promp.data import Demonstration
from robots.icub.kinematics import ArmChain
from robots.icub.model import DEFAULT_ROBOT, load_urdf
from robots.icub.scene import DEFAULT_SCENE

TABS = (("Teach", TEACH, TeachPanel), ("Infer", INFER, InferPanel), ("Data", DATA, DataPanel))


@functools.cache
def _default_dataset() -> dict[str, tuple[Demonstration, ...]]:
    # Deterministic (seed 0) and 4 s of IK: generated once per process. Demonstrations are
    # immutable (read-only arrays), so every workspace made from it can share them.
    from robots.icub.scenario import generate_scenario

    return {name: tuple(demos) for name, demos in generate_scenario(seed=0, n_demos=20).items()}


def default_workspace() -> WorkspaceData:
    """The embedded default: the paper's experiment simulated on the iCub (curved, direct)."""
    dataset = {name: list(demos) for name, demos in _default_dataset().items()}
    return WorkspaceData(
        primitives=[PrimitiveEntry(name, PALETTE[i]) for i, name in enumerate(dataset)],
        demos=dataset,
        settings={},  # the engine's defaults: the covariance prior is chosen from the data
    )


class Studio:
    """The running studio (build it with :meth:`start`)."""

    def __init__(
        self,
        server: viser.ViserServer,
        session: Session,
        arm: ArmController,
        head_source: HeadSource,
    ):
        self.server = server
        self.session = session
        self.arm = arm
        self.head = HeadInput(head_source)
        self.head.read(arm.hand_position())
        self.scene = SceneView(server, robot=arm.robot, on_via_moved=lambda id, position: (
            session.view.change_via_point(id, position=position)))
        self.panels: list[Panel] = []
        self.camera: ViewControls | None = None
        self.tabs: BrowserTabs | None = None
        # The latest notifications (title, body, color), newest last: what the studio said.
        self.notices: collections.deque[tuple[str, str, str]] = collections.deque(maxlen=256)
        self.loop = FrameLoop(self._frame, self._frame_failed)
        self.live = LslSource()  # the live source over LSL, shared by Infer and Teach
        self.live.on_commitment.call = self.loop.wake  # the robot takes over at once

    @property
    def port(self) -> int:
        return self.server.get_port()

    @property
    def workspace(self) -> Path:
        return self.session.store.state.workspace.root

    @classmethod
    def start(
        cls,
        host: str,
        port: int,
        workspace: Path,
        robot: str = DEFAULT_ROBOT,
        camera: int | None = None,
        video: Path | None = None,
        fits: FitCache | None = None,
    ) -> Studio:
        """Serve the studio on (host, port) with its workspace in ``workspace``; ``fits``:
        where its fits are kept (a new cache by default; several studios may share one).

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
        session = Session.open(workspace, default=default_workspace, fits=fits)
        server = viser.ViserServer(
            host=host, port=port, label="iCub intention studio", verbose=False
        )
        if port != 0 and server.get_port() != port:
            server.stop()
            session.close()
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
        studio = cls(server, session, arm, source)
        studio.panels = studio._build_panels()
        studio.loop.start()
        return studio

    def _context(self, panel: str) -> PanelContext:
        """What the panel ``panel`` may read and do."""
        server, session = self.server, self.session

        def guard_upload(button, max_bytes: int, refused: Refused) -> UploadGuard:
            return UploadGuard(server, button, max_bytes, refused)

        return PanelContext(
            gui=PanelGui(server.gui, lambda: self.scene.use_panel(panel), self.notify),
            store=session.store,
            view=session.view,
            learner=session.learner,
            arm=self.arm,
            head=self.head,
            notify=self.notify,
            atomic=server.atomic,
            guard_upload=guard_upload,
            open_in_infer=self.open_in_infer,
            wait_for_model=session.wait_for_model,
            inference_layer=self.scene.inference if panel == INFER else None,
            live=self.live,
        )

    def _build_panels(self) -> list[Panel]:
        """The tab report, the camera buttons, then one tab per panel, each ending with its
        help ("?", collapsed), then the page's script (:mod:`app.ui.page_script`)."""
        names = {title: name for title, name, _ in TABS}
        self.tabs = BrowserTabs(self.server, tuple(names), lambda t: self.scene.use_panel(names[t]))
        guarded = GuardedGui(self.server.gui, self.notify)
        self.camera = ViewControls(self.server, self.scene, guarded, self.session)
        tabs = self.server.gui.add_tab_group()
        panels: list[Panel] = []
        for title, name, build in TABS:
            with tabs.add_tab(title):
                panels.append(build(self._context(name)))
                add_help(self.server.gui, name)
        charts = {}
        for panel in panels:
            charts.update(getattr(panel, "chart_sliders", dict)())
        add_client_script(self.server.gui, charts, self.tabs)
        return panels

    # ------------------------------------------------------------------ between panels

    def open_in_infer(self, request: InferRequest, client: viser.ClientHandle | None) -> None:
        """The Infer tab shows ``request`` and ``client``'s browser switches to it (see
        :attr:`app.ui.context.PanelContext.open_in_infer`); done by the loop's next iteration."""

        def open_it() -> None:
            infer = next(panel for panel in self.panels if isinstance(panel, InferPanel))
            try:
                percent = infer.open(request, self.session.snapshot())
            except ValueError as exc:
                self.notify("Cannot open in Infer", f"{exc}.", "red", client=client)
                return
            self.scene.use_panel(INFER)
            if client is not None:
                self.tabs.show(client, next(title for title, name, _ in TABS if name == INFER))
            if percent != request.percent:
                self.notify(
                    "Opened in Infer",
                    f"{request.demo} at {percent} % observed: the slider moves by whole "
                    f"percents (the evaluation observed {request.percent:g} %).",
                    "yellow",
                    client=client,
                )

        self.loop.call(open_it)

    # ------------------------------------------------------------------ loop

    def step(self) -> None:
        """One frame, now, on the calling thread (e.g. from tests; the loop runs them ~60
        times a second on its own: :class:`app.live.frame_loop.FrameLoop`)."""
        self.loop.step()

    def _frame(self) -> None:
        """One frame: the tasks asked of the loop, the arm, the head, then one snapshot shown
        by every panel and drawn by the scene.

        One message group per frame (:func:`one_message_group`): the browser applies the arm,
        the panels' controls and the 3D view of one frame together, and viser's sender is
        woken at the frame's end (the group's close and its flush) rather than once per
        message (measured with ``bench/scrub.py``:
        each wake-up is a write to the event loop's pipe, ~7 a frame while scrubbing)."""
        with one_message_group(self.server):
            self.loop.run_tasks()
            self.arm.step()
            hand = self.arm.hand_position()
            reading = self.head.read(hand)
            frame = Frame(self.session.snapshot(), time.monotonic(), hand, reading.angles,
                          self.head.source.error, self.scene.panel)  # fmt: skip
            shown = Shown()
            for panel in self.panels:
                shown = shown.merged(panel.step(frame))
            self.scene.draw(frame.snapshot, frame.head, shown)
            if self.camera is not None:
                self.camera.step()

    def _frame_failed(self, exc: Exception) -> None:
        traceback.print_exc()
        self.notify("Internal error", f"{type(exc).__name__}: {exc}", color="red")

    def notify(
        self,
        title: str,
        body: str,
        color: str = "blue",
        client: viser.ClientHandle | None = None,
        auto_close_seconds: float = 8.0,
    ) -> list[viser.NotificationHandle]:
        """A notification in ``client``'s browser tab, or in every connected tab when None;
        their handles (to close them). Kept in :attr:`notices` too."""
        self.notices.append((title, body, color))
        clients = [client] if client is not None else self.server.get_clients().values()
        return [
            target.add_notification(
                title=title, body=body, color=color, auto_close_seconds=auto_close_seconds
            )
            for target in clients
        ]

    def stop(self) -> None:
        self.loop.stop()
        self.live.close()
        for panel in self.panels:
            panel.close()
        self.head.close()
        self.session.close()
        self.server.stop()
