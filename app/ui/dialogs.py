"""Dialogs shown to one browser tab."""

from __future__ import annotations

from collections.abc import Callable

import viser

from app.ui.callback_guard import guard_handle, to_client


def confirm(
    client: viser.ClientHandle,
    title: str,
    text: str,
    action: str,
    on_confirm: Callable[[], object],
    on_cancel: Callable[[], object] | None = None,
) -> None:
    """A modal in ``client``'s tab asking ``text`` (markdown), with a red ``action`` button
    that runs ``on_confirm()`` and a Cancel button (``on_cancel()``); either closes it."""
    with client.gui.add_modal(title) as modal:
        client.gui.add_markdown(text)
        yes = guard_handle(client.gui.add_button(action, color="red"), to_client)
        no = guard_handle(client.gui.add_button("Cancel"), to_client)

    @yes.on_click
    def _(_) -> None:
        modal.close()
        on_confirm()

    @no.on_click
    def _(_) -> None:
        modal.close()
        if on_cancel is not None:
            on_cancel()
