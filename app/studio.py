"""The studio: one viser server composing the robot, the scene and the panels."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import viser

from app.robot_view import RobotView, add_robot
from robots.icub.model import load_urdf
from robots.icub.scene import DEFAULT_SCENE


@dataclass
class Studio:
    server: viser.ViserServer
    workspace: Path
    robot: RobotView

    @property
    def port(self) -> int:
        return self.server.get_port()

    @classmethod
    def start(cls, host: str, port: int, workspace: Path, robot: str = "iCubNancy01") -> Studio:
        """Serve the studio on (host, port) with its workspace in ``workspace``.

        Raises
        ------
        ValueError
            If the robot name is unknown, the workspace is not a folder, or the port could
            not be bound (viser would silently pick another one).
        """
        workspace = Path(workspace)
        if workspace.exists() and not workspace.is_dir():
            raise ValueError(f"workspace {workspace} exists and is not a folder")
        urdf = load_urdf(robot)  # before binding: an unknown robot fails fast
        workspace.mkdir(parents=True, exist_ok=True)
        server = viser.ViserServer(
            host=host, port=port, label="iCub intention studio", verbose=False
        )
        if port != 0 and server.get_port() != port:
            server.stop()
            raise ValueError(f"port {port} on {host} is already in use")
        view = add_robot(server, urdf, DEFAULT_SCENE)
        return cls(server=server, workspace=workspace, robot=view)

    def stop(self) -> None:
        self.server.stop()
