"""The 3D view's camera buttons, above the tabs: *Partner view* (also the view a new browser tab
starts with, and viser's "Reset view"), *Top view*, *Side view* and *Frame paths*.

A click only records which view which browser tab asked for; :meth:`ViewControls.step`, on the
studio's loop, computes the camera (:mod:`app.scene.camera`) from what the scene shows and sets
it for that browser tab alone (each tab has its own camera). The presets frame the workspace's
demonstrations; *Frame paths* keeps the current direction and frames the demonstrations (but
those hidden) and, in Infer, the inference on show with them (never the dragged hand's gizmo
alone). Without any hand path, the scene's hand targets (the object and the bins) are framed.
The start view follows the demonstrations once they have been still for :data:`SETTLE_S` (a
take, then its refit, change them: the view is framed once, off the busy frames). Under the
buttons, what is drawn around the data (:mod:`app.scene.scene_controls`). Every view frames the
paths without their outliers (:func:`app.scene.camera.framed_points`).
"""

from __future__ import annotations

import threading
import time

import numpy as np
import viser

from app.core.session import Session
from app.scene.camera import (
    CANVAS,
    FRAME,
    PARTNER,
    VIEWS,
    CameraPose,
    frame,
    framed_points,
    scene_points,
)
from app.scene.camera import view_pose as preset_pose
from app.scene.scene_controls import SceneControls
from app.scene.scene_view import SceneView

SETTLE_S = 1.0  # the start view follows a changed drawing once it has not changed for this long


class ViewControls:
    """The camera buttons (see the module docstring), built in the current GUI container."""

    def __init__(
        self, server: viser.ViserServer, scene: SceneView, gui=None, session: Session | None = None
    ):
        """``gui``: what the buttons are built with (the studio's guards its callbacks;
        ``server.gui`` by default); ``session``: whose scene and frames the controls under
        them choose (none without)."""
        self.server = server
        self.scene = scene
        self._requests: list[tuple[viser.ClientHandle, str]] = []
        self._lock = threading.Lock()
        self._initial_for: tuple | None = None  # the workspace drawing the start view frames
        self._drawn: tuple | None = None  # the latest drawing, and since when
        self._drawn_at = 0.0
        self._started: set[int] = set()  # browser tabs checked for the start view
        # No hint: its tooltip opened over the panel when the pointer rested on a button, and
        # stayed there while the user looked at the view the button gave (the buttons' names
        # say what they do; the manual says the rest).
        self.buttons = (gui or server.gui).add_button_group("3D view", VIEWS)

        @self.buttons.on_click
        def _(event) -> None:
            if event.client is not None:
                self.request(event.client, str(event.target.value))

        self.controls = None if session is None else SceneControls(gui or server.gui, session)

    def request(self, client: viser.ClientHandle, view: str) -> None:
        """Ask for ``view`` in ``client``'s browser tab (from any thread)."""
        if view not in VIEWS:
            raise ValueError(f"unknown view {view!r}; expected one of {', '.join(VIEWS)}")
        with self._lock:
            self._requests.append((client, view))

    def step(self) -> None:
        """Set the cameras asked for; keep the start view on the workspace's paths; show the
        latest drawing's choices in the controls."""
        if self.controls is not None and self.scene.snapshot is not None:
            self.controls.step(self.scene.snapshot)
        with self._lock:
            requests, self._requests = self._requests, []
        for client, view in requests:
            try:
                size = client.camera.image_width, client.camera.image_height
            except AssertionError:  # the browser has not reported its camera yet
                size = CANVAS
            apply(client, self.pose(view, current=_current(client), size=size))
        drawn, now = self.scene.drawn_from, time.monotonic()
        if drawn is not self._drawn:  # the lines changed: their start view, once they settle
            self._drawn, self._drawn_at = drawn, now
        if drawn is not self._initial_for and (
            self._initial_for is None or now - self._drawn_at >= SETTLE_S
        ):
            self._initial_for = drawn
            initial = self.pose(PARTNER)
            camera = self.server.initial_camera
            camera.fov = initial.fov
            camera.position = initial.position
            camera.look_at = initial.look_at
        if drawn:
            self._start_new_tabs()

    def _start_new_tabs(self) -> None:
        """The start view for a browser tab that connected before the workspace was first
        drawn: it got viser's default camera, not the start view (a tab that connects later
        starts at ``initial_camera`` and is left alone). Checked once per tab, at its first
        camera report."""
        clients = self.server.get_clients()
        self._started &= set(clients)  # forget closed tabs
        start = np.asarray(self.server.initial_camera.position, dtype=float)
        for client_id, client in clients.items():
            if client_id in self._started:
                continue
            self._started.add(client_id)
            current = _current(client)
            if current is not None and np.linalg.norm(current.position - start) > 0.01:
                self.request(client, PARTNER)

    def pose(
        self, view: str, current: CameraPose | None = None, size: tuple[int, int] = CANVAS
    ) -> CameraPose:
        """The camera for ``view`` on a ``size`` canvas (``current``: the camera now, whose
        direction *Frame paths* keeps)."""
        width, height = (int(s) for s in size)
        if width < 50 or height < 50:
            width, height = CANVAS
        if view == FRAME:
            points = framed_points(self.scene.paths())
            if points.shape[0] == 0:
                points = scene_points()
            if current is None:
                return preset_pose(PARTNER, points, width, height)
            return frame(points, current.look_at - current.position, width, height, current.fov)
        points = framed_points(self.scene.paths(inference=False))
        if points.shape[0] == 0:
            points = scene_points()
        return preset_pose(view, points, width, height)


def _current(client: viser.ClientHandle) -> CameraPose | None:
    try:
        camera = client.camera
        return CameraPose(np.array(camera.position), np.array(camera.look_at), fov=camera.fov)
    except AssertionError:  # no camera reported yet
        return None


def apply(client: viser.ClientHandle, pose: CameraPose) -> None:
    """Move ``client``'s camera to ``pose`` (one message group)."""
    with client.atomic():
        client.camera.fov = pose.fov
        client.camera.up_direction = pose.up
        client.camera.position = pose.position
        client.camera.look_at = pose.look_at
