"""What the session looks like in 3D: demonstrations as thin lines, priors as tubes, and the
partner's head avatar with its gaze ray.

Lines and tubes are the ``hand`` modality's (a workspace without one has none). Redrawn by the
studio's loop when the session's version changes; tubes keep their mesh topology (100 rings of
12 vertices), so a refit only replaces vertices.
"""

from __future__ import annotations

import numpy as np
import viser

from app.inference_view import hand_dims
from app.session import Session
from app.tubes import resample, tube_faces, tube_vertices
from promp.inference import predict
from robots.icub.scene import DEFAULT_SCENE, head_rotation

TUBE_POINTS = 100
HEAD_NODE = "/partner"
GAZE_LENGTH = 0.9


class SceneView:
    """Scene nodes derived from the session (see the module docstring)."""

    def __init__(self, server: viser.ViserServer, session: Session):
        self.server = server
        self.session = session
        self.drawn_version = -1
        self.lines: dict[tuple[str, str], viser.SceneNodeHandle] = {}
        self._drawn_demo: dict[tuple[str, str], object] = {}  # the demonstration each line shows
        self.tubes: dict[str, viser.MeshHandle] = {}
        self.faces = tube_faces(TUBE_POINTS)
        head = np.array(DEFAULT_SCENE.partner_head)
        self.head_frame = server.scene.add_frame(HEAD_NODE, position=head, show_axes=False)
        server.scene.add_icosphere(f"{HEAD_NODE}/skull", radius=0.09, color=(236, 200, 170))
        server.scene.add_box(
            f"{HEAD_NODE}/nose", dimensions=(0.05, 0.025, 0.035), position=(0.09, 0.0, -0.01),
            color=(220, 180, 150),
        )  # fmt: skip
        self.gaze = server.scene.add_spline_catmull_rom(
            f"{HEAD_NODE}/gaze",
            points=np.array([[0.0, 0.0, 0.0], [GAZE_LENGTH, 0.0, 0.0]]),
            color=(255, 200, 0),
            thickness=3.0,
            thickness_units="screen",
        )
        self.head_status = "no face"

    # ------------------------------------------------------------------ partner

    def show_head(self, angles: np.ndarray | None) -> None:
        """Orient the avatar (angles: roll, pitch, yaw) or grey it out when there is no face."""
        if not self.head_frame.visible:  # the workspace has no head modality
            return
        if angles is None:
            self.gaze.visible = False
            self.head_status = "no face"
            return
        rotation = head_rotation(*angles)
        self.head_frame.wxyz = _wxyz(rotation)
        self.gaze.visible = True
        self.head_status = "tracking"

    # ------------------------------------------------------------------ session

    def refresh(self) -> bool:
        """Redraw demonstrations and priors if the session changed; True when redrawn."""
        session = self.session
        with session.lock:
            if session.version == self.drawn_version:
                return False
            self.drawn_version = session.version
            demos = {name: list(items) for name, items in session.demos.items()}
            colors = {p.name: p.color for p in session.primitives}
            hidden = set(session.hidden)
            model = session.model
            layout = session.layout
        if hand_dims(layout) is None:  # nothing of this workspace lives in 3D
            demos, model = {}, None
        has_head = "head" in layout.names  # the partner is shown when the head is a modality
        if self.head_frame.visible != has_head:
            self.head_frame.visible = has_head
        self._draw_lines(demos, colors, hidden, layout)
        self._draw_tubes(model, colors)
        return True

    def _draw_lines(self, demos, colors, hidden, layout) -> None:
        wanted = set()
        cols = hand_dims(layout)
        for name, items in demos.items():
            for demo in items:
                key = (name, demo.name)
                wanted.add(key)
                if key in self.lines and self._drawn_demo.get(key) is demo:
                    self.lines[key].visible = key not in hidden
                    continue
                if key in self.lines:  # same name, other data (a restored or new workspace)
                    self.lines.pop(key).remove()
                self._drawn_demo[key] = demo
                points = layout.extract(demo)[:, cols]
                self.lines[key] = self.server.scene.add_spline_catmull_rom(
                    f"/demos/{name}/{demo.name}",
                    points=resample(points, min(len(points), 60)),
                    color=colors[name],
                    thickness=1.5,
                    thickness_units="screen",
                    visible=key not in hidden,
                )
        for key in list(self.lines):
            color = colors.get(key[0])
            if key not in wanted:
                self.lines.pop(key).remove()
                self._drawn_demo.pop(key, None)
            elif color is not None and tuple(self.lines[key].color) != tuple(color):
                self.lines[key].color = color

    def prior_tube(self, model, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Mean and std (TUBE_POINTS, 3) of the prior hand path of primitive ``name``."""
        prim = model.primitive(name)
        alpha = float(np.exp(prim.log_alpha_mean))
        prediction = predict(model, prim, alpha, n_points=TUBE_POINTS)
        cols = hand_dims(model.layout)
        return prediction.mean[:, cols], prediction.std[:, cols]

    def _draw_tubes(self, model, colors) -> None:
        names = set(model.names) if model is not None else set()
        for name in list(self.tubes):
            if name not in names:
                self.tubes.pop(name).remove()
        for name in names:
            mean, std = self.prior_tube(model, name)
            vertices = tube_vertices(mean, std)
            color = colors.get(name, (200, 200, 200))
            tube = self.tubes.get(name)
            if tube is None:
                self.tubes[name] = self.server.scene.add_mesh_simple(
                    f"/priors/{name}",
                    vertices=vertices,
                    faces=self.faces,
                    color=color,
                    opacity=0.25,
                    flat_shading=False,
                    side="double",
                )
            else:
                tube.vertices = vertices
                tube.color = color


def _wxyz(rotation: np.ndarray) -> np.ndarray:
    import viser.transforms as vtf

    return vtf.SO3.from_matrix(rotation).wxyz
