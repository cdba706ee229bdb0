"""Icons changed on a button while the studio runs, read once.

viser reads an icon's SVG from its zip of icons at every assignment of ``button.icon`` (25-40
ms on this machine, on the studio's loop: a Record button that turns into Stop, then back, held
up a frame each time). :func:`set_icon` reads each icon once and sets what the assignment
would (viser's ``_icon`` and ``_icon_html``; a plain assignment if viser no longer has them).
"""

from __future__ import annotations

import functools

import viser
from viser._icons import svg_from_icon


@functools.cache
def icon_svg(icon: str) -> str:
    """The SVG of ``icon``, read from viser's icons once."""
    return svg_from_icon(icon)


def set_icon(button: viser.GuiButtonHandle, icon: str | None) -> None:
    """``button.icon = icon``, without reading the icon again."""
    if not (hasattr(button, "_icon") and hasattr(button, "_icon_html")):
        button.icon = icon
        return
    button._icon = icon
    button._icon_html = None if icon is None else icon_svg(icon)
