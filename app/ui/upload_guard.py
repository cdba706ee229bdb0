"""Refuse an upload larger than a limit as soon as it starts, before viser buffers it.

viser assembles an upload in memory (``GuiApi._current_file_upload_states``) from a
``FileTransferStartUpload`` message, which declares the size, then one ``FileTransferPart``
message per 512 KB chunk, and calls the button's ``on_upload`` callbacks with the whole file.
:class:`UploadGuard` adds its own handlers for these two messages on the same websocket
interface. viser's handlers run first (they were registered first), so the guard then drops
the transfer's state when

* the declared size is over the limit (the normal case: nothing is ever buffered), or
* the bytes received so far exceed the limit (a client lying about the size): at most the
  limit plus one message is buffered.

Later parts of a dropped transfer find no state and are ignored by viser. The browser, which
keeps its upload button disabled until every byte is acknowledged, is sent a final
acknowledgement and its "uploading" notification is closed; the ``refused`` callback then tells
the user why.

A file refused *after* it was read (bad content) has already been acknowledged in full, and the
browser has turned its notification into "File uploaded successfully.". The guard remembers
each client's latest transfer on its button; :meth:`UploadGuard.dismiss` closes that
notification, so the refusal does not sit under a contradicting success toast. This relies on
viser internals (checked at construction: :attr:`UploadGuard.active` is False
when they are missing, and callers must then check the size after the upload, as the studio
always does anyway).
"""

from __future__ import annotations

from collections.abc import Callable

import viser
from viser import _messages

from app.ui.element_id import element_id

Refused = Callable[[viser.ClientHandle | None, str, int], None]


class UploadGuard:
    """Size cap on one upload button (see the module docstring).

    Parameters
    ----------
    server : viser.ViserServer
    button : viser.GuiUploadButtonHandle
        The guarded button (a server-level GUI element).
    max_bytes : int
        Largest accepted upload, in bytes; may be changed later through :attr:`max_bytes`.
    refused : callable
        ``refused(client or None, filename, size_bytes)``, called on viser's event loop: keep
        it short (e.g. add a notification).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        button: viser.GuiUploadButtonHandle,
        max_bytes: int,
        refused: Refused,
    ):
        self.max_bytes = int(max_bytes)
        self._server = server
        self._uuid = element_id(button)
        self._refused = refused
        self._interface = getattr(server.gui, "_websock_interface", None)
        self._states = getattr(server.gui, "_current_file_upload_states", None)
        self.active = isinstance(self._states, dict) and hasattr(
            self._interface, "register_handler"
        )
        self.refusals = 0
        self.dismissals = 0  # upload notifications closed by dismiss
        self.parts_seen = 0  # parts of uploads to this button that reached the server
        self._latest: dict[int, str] = {}  # client id -> its latest transfer on this button
        if self.active:
            self._interface.register_handler(_messages.FileTransferStartUpload, self._on_start)
            self._interface.register_handler(_messages.FileTransferPart, self._on_part)

    def close(self) -> None:
        if self.active:
            self._interface.unregister_handler(_messages.FileTransferStartUpload, self._on_start)
            self._interface.unregister_handler(_messages.FileTransferPart, self._on_part)
            self.active = False

    def dismiss(self, client: viser.ClientHandle | None) -> None:
        """Close the upload notification of ``client``'s latest upload on this button (its
        file was refused after it was read)."""
        if client is None or not self.active:
            return
        transfer = self._latest.pop(client.client_id, None)
        connection = getattr(client, "_websock_connection", None)
        if transfer is not None and connection is not None:
            connection.queue_message(_messages.RemoveNotificationMessage(f"upload-{transfer}"))
            self.dismissals += 1

    def _on_start(self, client_id: int, message: _messages.FileTransferStartUpload) -> None:
        if message.source_component_uuid != self._uuid:
            return
        self._latest[client_id] = message.transfer_uuid
        if message.size_bytes > self.max_bytes:
            self._refuse(client_id, message.transfer_uuid, message.filename, message.size_bytes)

    def _on_part(self, client_id: int, message: _messages.FileTransferPart) -> None:
        if message.source_component_uuid != self._uuid:
            return
        self.parts_seen += 1
        state = self._states.get(message.transfer_uuid)
        if state is not None and state["transferred_bytes"] > self.max_bytes:
            self._refuse(
                client_id, message.transfer_uuid, state["filename"], state["transferred_bytes"]
            )

    def _refuse(self, client_id: int, transfer_uuid: str, filename: str, size: int) -> None:
        if self._states.pop(transfer_uuid, None) is None:
            return
        self.refusals += 1
        client = self._server.get_clients().get(client_id)
        connection = getattr(client, "_websock_connection", None)
        if connection is not None:
            # Release the browser's button (it waits for every byte to be acknowledged) and
            # close its "uploading" notification, whose id the browser derives from the
            # transfer id.
            connection.queue_message(
                _messages.FileTransferPartAck(
                    source_component_uuid=self._uuid,
                    transfer_uuid=transfer_uuid,
                    transferred_bytes=size,
                    total_bytes=size,
                )
            )
            connection.queue_message(_messages.RemoveNotificationMessage(f"upload-{transfer_uuid}"))
        self._refused(client, filename, size)


class UploadRefusals:
    """The refusals of one upload button's files, per browser tab, as notifications that a
    later accepted file from the same tab closes: an error about an earlier file does not stay
    beside the success of the next one.

    ``notify(title, body, color, client=..., auto_close_seconds=...)`` makes a notification and
    returns its handles (:attr:`app.ui.context.PanelContext.notify`).
    """

    def __init__(self, notify: Callable[..., list], seconds: float = 20.0):
        self._notify = notify
        self.seconds = seconds
        self._shown: dict[int | None, list] = {}  # client id -> its refusals' notifications

    def refuse(self, client: viser.ClientHandle | None, title: str, body: str) -> None:
        """Tell ``client`` (every tab when None) that a file was refused, and why."""
        handles = self._notify(title, body, "red", client=client, auto_close_seconds=self.seconds)
        key = client.client_id if client is not None else None
        self._shown.setdefault(key, []).extend(handles or [])

    def accepted(self, client: viser.ClientHandle | None) -> None:
        """A file from ``client`` was accepted: its earlier refusals go (all when None)."""
        keys = list(self._shown) if client is None else [client.client_id, None]
        for key in keys:
            for handle in self._shown.pop(key, []):
                try:
                    handle.remove()
                except Exception:  # the tab is gone, or the notification closed already
                    pass
