"""The iCub in the 3D view: URDF meshes, ground grid, table, object, bins.

Moving the robot (a drag, a replay) updates only the frames of the joints whose angle changed:
viser's ``ViserUrdf.update_cfg`` recomputes every joint's transform (about 25 ms for the iCub's
59 joints, at every frame of a drag); a joint's frame is relative to its parent, so the others
stay as they are. The partner's head avatar is :mod:`app.scene.partner`. A workspace whose
hand stays in its own frame (:mod:`app.io.hand_frame`) is drawn without the robot and its scene;
the simulated scene (table, object, bins) can be hidden with the robot kept
(:meth:`RobotView.show`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh.transformations as tra
import viser
import viser.transforms as vtf
import yourdfpy
from viser.extras import ViserUrdf

from robots.icub.model import ground_height, natural_pose
from robots.icub.scene import Scene

ROBOT_ROOT = "/robot"
# The scene in neutral tones, so that the primitives' colours (app.io.workspace_index.PALETTE)
# stand out: the paths cross the bins and the table, and start at the object.
TABLE_COLOR = (212, 202, 186)
LEG_COLOR = (170, 162, 150)
OBJECT_COLOR = (92, 92, 98)
BIN_COLOR = (150, 152, 158)
# Lighting: viser's directional lights without shadows, plus an even ambient light, instead of
# its image-based environment map. The picture is nearly the same, but a browser without a GPU
# (software WebGL) draws a frame of this scene with a third of the CPU: measured in headless
# Chromium, 1.85 cores with the environment map and shadows, 1.0 without (docs/speed.md).
AMBIENT_INTENSITY = 1.5


@dataclass
class RobotView:
    """Handles of the robot's scene nodes."""

    urdf: yourdfpy.URDF
    viser_urdf: ViserUrdf
    root: viser.FrameHandle
    q: np.ndarray
    # Per actuated joint, the joint and its frames in the scene (None: update every frame).
    _frames: list | None = field(default=None, repr=False)
    # What is shown and hidden with the robot (the hand's gizmo), and the simulated scene
    # around it (table, object, bins), which can be hidden on its own.
    props: list = field(default_factory=list, repr=False)
    scene: list = field(default_factory=list, repr=False)
    shown: bool = True
    scene_shown: bool = True

    def show(self, visible: bool, scene: bool = True) -> None:
        """Show or hide the robot, and its simulated scene with it when ``scene`` (nothing
        sent for what is so already)."""
        scene = visible and scene
        if visible != self.shown:
            self.shown = visible
            for node in (self.root, *self.props):
                node.visible = visible
        if scene != self.scene_shown:
            self.scene_shown = scene
            for node in self.scene:
                node.visible = scene

    def set_configuration(self, q: np.ndarray) -> None:
        """Show the actuated joint vector ``q``, shape (n_actuated,): the frames of the joints
        whose angle changed (all of them the first time)."""
        q = np.asarray(q, dtype=float).copy()
        if self._frames is None or self.q.shape != q.shape:
            self.viser_urdf.update_cfg(q)
            self._frames = joint_frames(self.urdf, self.viser_urdf)
        else:
            for i in np.flatnonzero(q != self.q):
                joint, frames = self._frames[i]
                transform = joint_transform(joint, float(q[i]))
                wxyz = vtf.SO3.from_matrix(transform[:3, :3]).wxyz
                for frame in frames:
                    frame.wxyz, frame.position = wxyz, transform[:3, 3]
        self.q = q


def joint_transform(joint: yourdfpy.Joint, value: float) -> np.ndarray:
    """The transform (4, 4) from a joint's parent link to its child at ``value`` (rad or m),
    as yourdfpy computes it."""
    origin = np.eye(4) if joint.origin is None else joint.origin
    if joint.type == "prismatic":
        return origin @ tra.translation_matrix(value * np.asarray(joint.axis))
    return origin @ tra.rotation_matrix(value, joint.axis)


def joint_frames(urdf: yourdfpy.URDF, view: ViserUrdf) -> list | None:
    """Per actuated joint of ``urdf``, (the joint, its frames in ``view``); None when viser's
    frames cannot be told apart (its internals changed) or a joint mimics another (updated
    with it): every frame is updated then."""
    joints = getattr(view, "_joint_map_values", None)
    frames = getattr(view, "_joint_frames", None)
    if joints is None or frames is None or getattr(view, "_scale", 1.0) != 1.0:
        return None
    if any(j.mimic is not None for j in urdf.joint_map.values()):
        return None
    by_name: dict[str, list] = {}
    for joint, frame in zip(joints, frames, strict=True):
        by_name.setdefault(joint.name, []).append(frame)
    return [(joint, by_name.get(joint.name, [])) for joint in urdf.actuated_joints]


def add_robot(server: viser.ViserServer, urdf: yourdfpy.URDF, scene: Scene) -> RobotView:
    """Add the robot, the ground, the table, the object and the bins (the camera is
    :mod:`app.scene.camera_buttons`'s)."""
    server.scene.set_up_direction("+z")
    server.scene.configure_environment_map(hdri=None)
    server.scene.configure_default_lights(enabled=True, cast_shadow=False)
    server.scene.add_light_ambient("/light/ambient", intensity=AMBIENT_INTENSITY)
    ground = ground_height(urdf)
    server.scene.add_grid(
        "/ground",
        width=4.0,
        height=4.0,
        cell_size=0.1,
        section_size=0.5,
        position=(0.0, 0.0, ground),
    )
    root = server.scene.add_frame(ROBOT_ROOT, show_axes=False)
    viser_urdf = ViserUrdf(server, urdf, root_node_name=ROBOT_ROOT)
    view = RobotView(urdf=urdf, viser_urdf=viser_urdf, root=root, q=natural_pose(urdf))
    view.set_configuration(view.q)

    def add_box(name: str, **kwargs) -> None:  # the simulated scene: hidden with the robot
        view.scene.append(server.scene.add_box(name, **kwargs))

    table = scene.table
    add_box("/scene/table/top", dimensions=table.size, position=table.center, color=TABLE_COLOR)
    leg_height = table.center[2] - table.size[2] / 2 - ground
    for i, (sx, sy) in enumerate(((-1, -1), (-1, 1), (1, -1), (1, 1))):
        x = table.center[0] + sx * (table.size[0] / 2 - 0.03)
        y = table.center[1] + sy * (table.size[1] / 2 - 0.03)
        add_box(
            f"/scene/table/leg{i}",
            dimensions=(0.04, 0.04, leg_height),
            position=(x, y, ground + leg_height / 2),
            color=LEG_COLOR,
        )
    add_box("/scene/object", dimensions=scene.object.size, position=scene.object.center,
            color=OBJECT_COLOR)  # fmt: skip
    for i, bin_ in enumerate(scene.bins):
        for j, part in enumerate(bin_.parts()):
            add_box(f"/scene/bin{i}/part{j}", dimensions=part.size, position=part.center,
                    color=BIN_COLOR)  # fmt: skip
    return view
