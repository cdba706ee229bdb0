"""The "?" folder at the end of each tab: a short help text, kept in ``static/help/<tab>.md``.

The texts are plain markdown files beside the code, so they can be edited without touching
Python. The studio reads them from its source tree (``make run`` installs it in place); where
one is missing, the folder says so instead.
"""

from __future__ import annotations

from pathlib import Path

import viser

from app.ui.text import escape

STATIC = Path(__file__).resolve().parents[2] / "static"
HELP = STATIC / "help"


def help_text(tab: str) -> str:
    """The help of ``tab`` (``teach``, ``infer`` or ``data``), markdown.

    Raises
    ------
    ValueError
        If ``static/help/<tab>.md`` is missing.
    """
    path = HELP / f"{tab}.md"
    if not path.is_file():
        raise ValueError(f"the help of the {tab} tab is missing: {path}")
    return path.read_text(encoding="utf-8")


def add_help(gui: viser.GuiApi, tab: str) -> viser.GuiFolderHandle:
    """A collapsed "?" folder holding the help of ``tab`` (in the current container)."""
    try:
        text = help_text(tab)
    except ValueError as exc:
        text = f"No help: {escape(str(exc))}."
    folder = gui.add_folder("?", expand_by_default=False)
    with folder:
        gui.add_markdown(text)
    return folder
