"""Text for the GUI's markdown and HTML elements, defined once.

User-provided text (file names, paths, error messages) is shown literally: :func:`escape` for
markdown, :func:`escape_html` for HTML elements; :func:`display_name` shortens an uploaded
file's name to something safe to show. A name that a control may cut is given whole in its
tooltip (:func:`chosen_hint`, a ``title`` in HTML).
"""

from __future__ import annotations

import html
import re

RED, ORANGE, GREEN, GREY = "#c0392b", "#d35400", "#1e8449", "#7f8c8d"


def escape(text: str) -> str:
    """``text`` shown literally in markdown (paths and error messages hold '_' and '*')."""
    text = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    for char in "\\`*_[]#":
        text = text.replace(char, "\\" + char)
    return text


def escape_html(text: str) -> str:
    """``text`` shown literally in an HTML element (and in an attribute's quotes)."""
    return html.escape(text, quote=True)


def colored(text: str, color: str, bold: bool = False) -> str:
    """Markdown (inline HTML) of ``text`` in ``color``."""
    weight = "font-weight:600;" if bold else ""
    return f'<span style="color:{color};{weight}">{text}</span>'


def display_name(filename: str) -> str:
    """An uploaded file's name, safe to show in markdown (at most 60 characters)."""
    name = re.sub(r"[^A-Za-z0-9._ ()+-]", "_", filename.rsplit("/", 1)[-1]) or "file"
    return name if len(name) <= 60 else name[:57] + "..."


def chosen_hint(hint: str, chosen: str) -> str:
    """A dropdown's ``hint`` (its tooltip) that names the ``chosen`` option in full: a narrow
    panel cuts a long name in the field ("base_to_front_...")."""
    return f"{hint} Chosen: {chosen}"
