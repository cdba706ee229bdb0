"""The "?" folder at the end of each tab: a short help text, kept in ``static/help/<tab>.md``.

The texts are plain markdown files beside the code, so they can be edited without touching
Python; a missing file is an error at start (the studio runs from its source tree).
"""

from __future__ import annotations

from pathlib import Path

import viser

STATIC = Path(__file__).resolve().parent.parent / "static"
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
    folder = gui.add_folder("?", expand_by_default=False)
    with folder:
        gui.add_markdown(help_text(tab))
    return folder
