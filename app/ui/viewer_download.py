"""A viewer file (:mod:`promp.viewers`) sent to the browser that asked for it: the Data tab's
workspace and the Infer tab's view, for Rerun (``.rrd``) or for Foxglove and PlotJuggler
(``.mcap``), with the commands that open it said in the notification."""

from __future__ import annotations

import viser

from app.io.exchange import export_filename, format_size
from promp.viewers.formats import viewer_file_bytes
from promp.viewers.scene_log import SceneLog

__all__ = ["FORMATS", "OPEN_WITH", "send_viewer_file"]

FORMATS = {"Rerun": ".rrd", "MCAP": ".mcap"}  # the button's word -> the file's suffix
OPEN_WITH = {
    ".rrd": "open it with `rerun {name}` (Rerun's viewer)",
    ".mcap": "open it in Foxglove (Open local file) or PlotJuggler (Load data)",
}


def send_viewer_file(
    client: viser.ClientHandle | None, log: SceneLog, suffix: str, kind: str
) -> tuple[str, bytes, str]:
    """Write ``log`` as a ``suffix`` file named ``<kind>-<time><suffix>``, send it to
    ``client`` (when there is one); returns (file name, its bytes, what to say about it).

    Raises
    ------
    ValueError
        The format's extra is not installed (named), or a bad item.
    """
    content = viewer_file_bytes(log, suffix)
    name = export_filename(kind, suffix.lstrip("."))
    if client is not None:
        client.send_file_download(name, content, save_immediately=True)
    said = f"{name} ({format_size(len(content))}): {OPEN_WITH[suffix].format(name=name)}."
    return name, content, said
