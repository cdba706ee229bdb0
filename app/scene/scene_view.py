"""The 3D view: the robot and its table (:mod:`app.scene.robot`), the partner
(:mod:`app.scene.partner`), the workspace's demonstrations and priors
(:mod:`app.scene.workspace_layer`), the Infer tab's inference
(:mod:`app.scene.inference_layer`) and Teach's start pose (:mod:`app.scene.start_marker`).

:class:`SceneView` owns every node of the last three and is the one place that decides what is
drawn: :func:`app.scene.look.look` of the panel in use and the Infer panel's display options.
Panels never touch the nodes; they tell the scene what they show. Everything runs on the
studio's loop thread except :meth:`SceneView.use_panel`, which only records.
"""

from __future__ import annotations

import numpy as np
import viser

from app.core.session import Session
from app.live.inference import ScrubResult
from app.scene.inference_layer import InferenceLayer
from app.scene.look import PANELS, SHOWN, TEACH, Look, look
from app.scene.partner import PartnerView
from app.scene.start_marker import StartMarker
from app.scene.workspace_layer import WorkspaceLayer
from robots.icub.layout import HEAD


class SceneView:
    """The studio's 3D objects and their look (see the module docstring)."""

    def __init__(self, server: viser.ViserServer, session: Session):
        self.session = session
        self.partner = PartnerView(server)
        self.workspace = WorkspaceLayer(server)
        self.inference = InferenceLayer(server)
        self.start = StartMarker(server)
        self.panel = TEACH  # the panel in use: the first tab until a control is used
        self._inference_on = False
        self._priors = SHOWN
        self._hidden: set[tuple[str, str]] = set()
        self._drawn_version = -1
        self._applied: Look | None = None

    # ------------------------------------------------------------------ what panels say

    def use_panel(self, panel: str) -> None:
        """A control of ``panel`` was used: its look is shown (from any thread)."""
        if panel not in PANELS:
            raise ValueError(f"unknown panel {panel!r}; expected one of {', '.join(PANELS)}")
        self.panel = panel

    def show_inference(
        self, result: ScrubResult | None, color: tuple[int, int, int], shown: bool, priors: str
    ) -> None:
        """The Infer panel's latest result (drawn in ``color``) and its display options: show
        it in 3D or not, and the workspace's ``priors`` meanwhile."""
        self.inference.draw(result if shown else None, color)
        self.set_inference_options(shown, priors)
        self._apply(force=True)

    def show_start(self, position: np.ndarray | None, color: tuple[int, int, int]) -> None:
        """The Teach panel's start pose (its selected primitive's), None when it has none
        (loop thread)."""
        self.start.place(position, color)
        self.start.show(self.look.start)

    def set_inference_options(self, shown: bool, priors: str) -> None:
        self._inference_on, self._priors = bool(shown), priors

    @property
    def drawn_version(self) -> int:
        """The session version the workspace's objects were last drawn from."""
        return self._drawn_version

    @property
    def look(self) -> Look:
        return look(self.panel, self._inference_on and self.inference.has_shape, self._priors)

    # ------------------------------------------------------------------ the loop

    def refresh(self, head_angles: np.ndarray | None) -> bool:
        """Orient the partner, redraw what the session changed and apply the look; True when
        the session's objects were redrawn."""
        redrawn = self._redraw_session()
        self.partner.orient(head_angles)
        self._apply(force=redrawn)
        return redrawn

    def _redraw_session(self) -> bool:
        session = self.session
        with session.lock:
            if session.version == self._drawn_version:
                return False
            self._drawn_version = session.version
            demos = {name: list(items) for name, items in session.demos.items()}
            colors = {p.name: p.color for p in session.primitives}
            self._hidden = set(session.hidden)
            left_out = set(session.left_out())
            model, layout = session.model, session.layout
        self.partner.show(HEAD.name in layout.names)
        self.workspace.draw(demos, colors, layout, model, self.look, self._hidden, left_out)
        return True

    def _apply(self, force: bool = False) -> None:
        current = self.look
        if current == self._applied and not force:
            return
        self._applied = current
        self.workspace.apply(current, self._hidden)
        self.inference.show(current.inference)
        self.start.show(current.start)

    # ------------------------------------------------------------------ what the camera frames

    def paths(self, inference: bool | None = None) -> np.ndarray:
        """The hand paths on show, points (n, 3): the Infer layer's (observation, prediction,
        truth, posterior tube) when ``inference`` (default: when the current look shows it),
        else the demonstration lines (but those the user hid). Empty (0, 3) without any."""
        if inference is None:
            inference = self.look.inference
        if inference:
            nodes = [n for n in self.inference.nodes if n.visible and id(n) in self.inference.drawn]
        else:  # every line but those the user hid, whether the look shows them now or not
            nodes = [line for key, line in self.workspace.lines.items() if key not in self._hidden]
        arrays = []
        for node in nodes:
            points = getattr(node, "points", None)
            if points is None:
                points = getattr(node, "vertices", None)
            if points is None:
                points = np.atleast_2d(getattr(node, "position", np.zeros((0, 3))))
            arrays.append(np.asarray(points, dtype=float).reshape(-1, 3))
        return np.concatenate(arrays) if arrays else np.zeros((0, 3))
