"""The help of each tab ("?" folder): a short text per tab in static/help, and a folder that
says so when one is missing."""

from __future__ import annotations

from types import SimpleNamespace

import pytest


def test_every_tab_has_its_help_and_a_missing_one_says_so(monkeypatch, tmp_path) -> None:
    import app.ui.help as help_module

    for tab in ("teach", "infer", "data"):
        text = help_module.help_text(tab)
        assert 100 < len(text) < 1200 and text.count("\n\n") <= 2  # two or three short lines
    monkeypatch.setattr(help_module, "HELP", tmp_path)
    with pytest.raises(ValueError, match="help of the teach tab is missing"):
        help_module.help_text("teach")
    shown = []
    gui = SimpleNamespace(
        add_folder=lambda label, expand_by_default: _Folder(),
        add_markdown=shown.append,
    )
    help_module.add_help(gui, "teach")
    assert shown and shown[0].startswith("No help: the help of the teach tab is missing")


class _Folder:
    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None
