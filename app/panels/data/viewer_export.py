"""The Data tab's **Export to Rerun** and **Export to MCAP**: the workspace as the 3D view shows
it (the iCub, every demonstration on its own time, the prior regions:
:func:`app.scene.viewer_logs.workspace_log`) as a Rerun recording, or as MCAP for Foxglove and
PlotJuggler. Both wait for the model of the latest change, as Export workspace does."""

from __future__ import annotations

from collections.abc import Callable

import viser

from app.scene.viewer_logs import workspace_log
from app.ui.context import PanelContext
from app.ui.viewer_download import FORMATS, send_viewer_file
from robots.icub.model_file import robot_glb


class ViewerExport:
    """The two buttons and what they do (see the module docstring).

    Parameters
    ----------
    notify : callable
        ``notify(client, title, body, color)``: the Data tab's notifications.
    model_for_export : callable
        ``model_for_export(client, what)`` -> (model or None, seconds waited).
    """

    def __init__(self, ctx: PanelContext, notify: Callable, model_for_export: Callable):
        self.ctx = ctx
        self.notify = notify
        self.model_for_export = model_for_export
        self.buttons = {}
        for word, suffix in FORMATS.items():
            button = ctx.gui.add_button(
                f"Export to {word}",
                icon=viser.Icon.CUBE_SEND,
                hint=f"Download the workspace as the 3D view shows it ({suffix}): the iCub, "
                "every demonstration on its own time, the prior regions, for "
                + ("Rerun" if suffix == ".rrd" else "Foxglove, PlotJuggler and ROS 2 tools"),
            )  # fmt: skip
            button.on_click(lambda event, s=suffix: self.export(event.client, s))
            self.buttons[suffix] = button

    def export(self, client: viser.ClientHandle | None, suffix: str) -> bytes | None:
        """Send the workspace as a ``suffix`` file to ``client``; returns its bytes (None when
        it could not be written: said in red)."""
        what = f"Export to {'Rerun' if suffix == '.rrd' else 'MCAP'}"
        model, _ = self.model_for_export(client, what)
        store, view = self.ctx.store.state, self.ctx.view.state
        q = self.ctx.arm.robot.q.copy()  # the pose the studio shows
        try:
            log, hidden = workspace_log(store, view, model, lambda: robot_glb(q))
            _, content, said = send_viewer_file(client, log, suffix, "workspace")
        except ValueError as exc:
            self.notify(client, f"{what} failed", f"{exc}. Nothing was written.", "red")
            return None
        n_demos = sum(len(d) for d in store.demos.values()) - hidden
        self.notify(
            client, f"{what}: workspace exported",
            f"{said} {n_demos} demonstrations"
            + (f" ({hidden} hidden left out)" if hidden else "")
            + (", the prior regions." if model is not None else "; no model yet, no priors."),
        )  # fmt: skip
        return content
