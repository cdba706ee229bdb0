"""The Infer tab's **Export view to Rerun** and **Export view to MCAP**: the inference shown
(what was observed, the posterior region, the predicted path and end, the true rest) and the
Recognition chart's curve (each primitive's probability against the percent observed), as a
file for Rerun, or for Foxglove and PlotJuggler (:func:`app.scene.viewer_logs.infer_log`).
Beside the view they export, under the tab's readout."""

from __future__ import annotations

from collections.abc import Callable

import viser

from app.live.inference import InferView
from app.live.recognition_curve import RecognitionCurve
from app.scene.viewer_logs import infer_log
from app.ui.context import PanelContext
from app.ui.viewer_download import FORMATS, send_viewer_file


class InferExport:
    """The two buttons and what they do (see the module docstring).

    Parameters
    ----------
    shown : callable
        Gives the view the tab shows now and the recognition curve of it (None until
        computed).
    color_of : callable
        A primitive's colour.
    """

    def __init__(
        self,
        ctx: PanelContext,
        shown: Callable[[], tuple[InferView | None, RecognitionCurve | None]],
        color_of: Callable[[str], tuple[int, int, int]],
    ):
        self.ctx = ctx
        self.shown = shown
        self.color_of = color_of
        group = ctx.gui.add_button_group("Export view to", tuple(FORMATS))
        group.on_click(lambda event: self.export(event.client, FORMATS[str(event.target.value)]))
        self.group = group

    def export(self, client: viser.ClientHandle | None, suffix: str) -> bytes | None:
        """Send the view shown as a ``suffix`` file to ``client``; returns its bytes (None,
        said in red, when there is no inference to export)."""
        view, curve = self.shown()
        what = f"Export view to {'Rerun' if suffix == '.rrd' else 'MCAP'}"
        try:
            if view is None:
                raise ValueError("the Infer tab shows no inference yet")
            log = infer_log(view, self.color_of, self.ctx.view.state.tube_style, curve)
            _, content, said = send_viewer_file(client, log, suffix, "infer")
        except ValueError as exc:
            self.ctx.notify(f"{what} failed", f"{exc}. Nothing was written.", color="red",
                            client=client, auto_close_seconds=20.0)  # fmt: skip
            return None
        state = view.state
        source = "the live stream" if state.live else f"{state.primitive}/{state.demo}"
        curve_said = ("with the recognition over the whole movement" if curve is not None
                      else "the recognition at this percent (the curve was not computed yet)")
        self.ctx.notify(f"{what}: view exported",
                        f"{said} {source} at {state.percent} % observed, {curve_said}.",
                        client=client, auto_close_seconds=10.0)  # fmt: skip
        return content
