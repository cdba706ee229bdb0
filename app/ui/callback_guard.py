"""No failure of a GUI callback goes unseen: the user is told what failed.

viser runs a control's callbacks on its thread pool and only prints what they raise in the
server's log: the browser shows nothing, and the user waits for what never comes. Every control
the studio builds goes through :func:`guard_handle` once, where it is added (the panels'
:class:`app.ui.context.PanelGui`, the camera buttons' :class:`GuardedGui`, the dialogs): a
callback a browser set off that raises becomes a red notification in that browser naming what
failed ("Export workspace failed: ValueError: ..."), the traceback goes to the log, and the
studio keeps running. Refusals stay the callbacks' own (a ``ValueError`` they expect is a
"Cannot ..." notification, :meth:`app.ui.context.PanelContext.attempt`); this is for what no
one expected. A callback run from Python (a value set by the studio's code or a test, with no
browser behind it) raises to its caller as before.
"""

from __future__ import annotations

import functools
import traceback
from collections.abc import Callable

import viser

HOOKS = ("on_click", "on_upload", "on_update")  # how viser's controls take callbacks
ERROR_SECONDS = 20.0  # how long the notification of a failure stays


def what_failed(event) -> str:
    """What the user did, in the control's words: the button of a button group pressed, else
    the control's label."""
    target = getattr(event, "target", None)
    if isinstance(target, viser.GuiButtonGroupHandle):
        return str(target.value)
    return str(getattr(target, "label", "") or "A control")


def guarded(callback: Callable, notify: Callable[..., object]) -> Callable:
    """``callback`` (one argument, viser's event) telling the browser behind the event when it
    raises (see the module docstring); ``notify``: :attr:`app.ui.context.PanelContext.notify`."""

    @functools.wraps(callback)
    def run(event):
        try:
            return callback(event)
        except Exception as exc:
            client = getattr(event, "client", None)
            if client is None:  # the studio's own code set it: its caller hears of it
                raise
            traceback.print_exc()
            notify(
                f"{what_failed(event)} failed",
                f"{type(exc).__name__}: {exc}. The studio keeps running (the details are in "
                "its log).",
                "red",
                client=client,
                auto_close_seconds=ERROR_SECONDS,
            )
            return None

    return run


def guard_handle(handle, notify: Callable[..., object]):
    """Make every callback later given to ``handle``'s ``on_click``, ``on_upload`` or
    ``on_update`` a :func:`guarded` one; returns ``handle``."""
    for hook in HOOKS:
        register = getattr(handle, hook, None)
        if register is None:
            continue

        def guarded_register(func, register=register):
            register(guarded(func, notify))
            return func  # as viser's: usable as a decorator

        # An attribute of this handle only (viser's handles take plain attributes).
        object.__setattr__(handle, hook, guarded_register)
    return handle


def to_client(title: str, body: str, color: str = "blue", client=None,
              auto_close_seconds: float = 8.0) -> None:  # fmt: skip
    """``notify`` for controls of one browser tab's own (a dialog's): to ``client``."""
    if client is not None:
        client.add_notification(title=title, body=body, color=color,
                                auto_close_seconds=auto_close_seconds)  # fmt: skip


class GuardedGui:
    """viser's GUI API whose controls are guarded (:func:`guard_handle`; not without
    ``notify``); everything else is viser's own."""

    def __init__(self, gui, notify: Callable[..., object] | None):
        self._gui = gui
        self._notify = notify

    def __getattr__(self, name: str):
        attribute = getattr(self._gui, name)
        if not name.startswith("add_"):
            return attribute

        def add(*args, **kwargs):
            return self._built(attribute(*args, **kwargs))

        return add

    def _built(self, handle):
        """``handle``, just added, as the panel gets it."""
        return handle if self._notify is None else guard_handle(handle, self._notify)
