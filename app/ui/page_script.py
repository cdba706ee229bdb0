"""The page's own script (``static/studio.js``), loaded once into every browser tab.

viser has no API for a page script, and sets a GUI HTML element's content with ``innerHTML``,
where a ``<script>`` tag does not run. An ``<img>`` whose source fails to load does run its
``onerror`` handler, so the studio adds one hidden HTML element holding such an image: its
handler stores the configuration in ``window.__icubStudio.config`` and appends the script (as
a base64 ``data:`` URL) to the page's head. The script guards itself against a second load.
What it does, and why, is written at its top: keys meant for the 3D view stay with GUI controls
that have the focus, a click on a chart moves the slider it belongs to, and the studio can
switch one browser to another tab (:func:`tab_switch_html`, added to that client's GUI alone).
"""

from __future__ import annotations

import base64
import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass

import viser

from app.ui.help import STATIC
from app.ui.text import escape_html

SCRIPT = STATIC / "studio.js"


@dataclass(frozen=True)
class ChartSlider:
    """A click on the chart titled ``title`` (plot x range ``x``) moves the slider ``slider``
    (its GUI uuid; range ``min``..``max``) to the x clicked."""

    slider: str
    min: float
    max: float
    x: tuple[float, float]


def loader_html(charts: Mapping[str, ChartSlider], script: str | None = None) -> str:
    """The hidden ``<img>`` that configures and loads the script (see the module docstring)."""
    source = SCRIPT.read_text(encoding="utf-8") if script is None else script
    encoded = base64.b64encode(source.encode("utf-8")).decode("ascii")
    config = json.dumps({"charts": {title: asdict(link) for title, link in charts.items()}})
    handler = (
        "var s=window.__icubStudio=window.__icubStudio||{};"
        f"s.config={config};"
        "if(!s.loaded&&!document.getElementById('icub-studio-js')){"
        "var e=document.createElement('script');e.id='icub-studio-js';"
        f"e.src='data:text/javascript;base64,{encoded}';document.head.appendChild(e);}}"
    )
    return (
        f'<img alt="" src="data:," style="display:none" onerror="{escape_html(handler)}">'
    )


def tab_switch_html(title: str) -> str:
    """A hidden ``<img>`` whose handler shows the tab titled ``title`` (the script's
    ``showTab``). viser cannot choose a browser's tab: added to one client's GUI, this element
    does it in that browser as it appears."""
    handler = f"var s=window.__icubStudio;if(s&&s.showTab){{s.showTab({json.dumps(title)});}}"
    return f'<img alt="" src="data:," style="display:none" onerror="{escape_html(handler)}">'


def add_client_script(
    gui: viser.GuiApi, charts: Mapping[str, ChartSlider]
) -> viser.GuiHtmlHandle:
    """Add the loader to ``gui`` (the studio's top level, so every tab has it)."""
    return gui.add_html(loader_html(charts))
