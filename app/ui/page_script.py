"""The page's own script (``static/studio.js``), loaded once into every browser tab.

viser has no API for a page script, and sets a GUI HTML element's content with ``innerHTML``,
where a ``<script>`` tag does not run. An ``<img>`` whose source fails to load does run its
``onerror`` handler, so the studio adds one hidden HTML element holding such an image: its
handler stores the configuration in ``window.__icubStudio.config`` and appends the script (as
a base64 ``data:`` URL) to the page's head. The script guards itself against a second load.
What it does, and why, is written at its top: keys meant for the 3D view stay with GUI controls
that have the focus, a click on a chart moves the slider it belongs to, the studio hears which
tab a browser shows and can switch one browser to another tab (:class:`BrowserTabs`).
"""

from __future__ import annotations

import base64
import json
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass

import viser

from app.ui.element_id import element_id
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


def loader_html(
    charts: Mapping[str, ChartSlider], tabs: Mapping | None = None, script: str | None = None
) -> str:
    """The hidden ``<img>`` that configures and loads the script (see the module docstring);
    ``tabs``: the tab report's configuration (:attr:`BrowserTabs.config`)."""
    source = SCRIPT.read_text(encoding="utf-8") if script is None else script
    encoded = base64.b64encode(source.encode("utf-8")).decode("ascii")
    config = json.dumps({
        "charts": {title: asdict(link) for title, link in charts.items()}, "tabs": tabs or {},
    })  # fmt: skip
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
    gui: viser.GuiApi, charts: Mapping[str, ChartSlider], tabs: BrowserTabs | None = None
) -> viser.GuiHtmlHandle:
    """Add the loader to ``gui`` (the studio's top level, so every tab has it)."""
    return gui.add_html(loader_html(charts, tabs.config if tabs is not None else None))


class BrowserTabs:
    """The studio's tabs in the browsers: which one a browser shows, and switching one browser
    to another.

    viser tells the server nothing of a tab chosen. The page's script watches the tabs titled
    ``titles`` and, when the one shown changes, clicks the button of that title in a row of
    buttons it hides (this class's reporter, a GUI element at the top level): the click reaches
    the server as any click does, and ``shown(title)`` is called. :meth:`show` switches one
    browser to a tab (:func:`tab_switch_html`, added to that client's GUI alone).
    """

    def __init__(
        self, server: viser.ViserServer, titles: tuple[str, ...], shown: Callable[[str], None]
    ):
        self._switches: dict[int, viser.GuiHtmlHandle] = {}  # the latest, per client
        self.reporter = server.gui.add_button_group("Tab shown", titles)
        self.config = {"report": element_id(self.reporter), "titles": list(titles)}

        @self.reporter.on_click
        def _(event: viser.GuiEvent) -> None:
            shown(str(event.target.value))

        server.on_client_disconnect(lambda client: self._switches.pop(client.client_id, None))

    def show(self, client: viser.ClientHandle, title: str) -> None:
        """Switch ``client``'s browser to the tab titled ``title``."""
        previous = self._switches.pop(client.client_id, None)
        if previous is not None:
            previous.remove()
        self._switches[client.client_id] = client.gui.add_html(tab_switch_html(title))
