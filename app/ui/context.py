"""What a panel may read and do (:class:`PanelContext`), and what the studio asks of a panel
(:class:`Panel`).

The studio builds each panel inside its tab with a context of its own: the session (state and
mutations), the scene (told what the panel shows, never edited), the arm, the partner's head,
notifications, the GUI to build its controls with, and the few requests one panel may make of
another through the studio (:class:`InferRequest`). Panels import nothing of the studio.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import viser

from app.core.session import Session
from app.live.head import HeadInput
from app.scene.arm import ArmController
from app.scene.scene_view import SceneView
from app.ui.upload_guard import Refused, UploadGuard


@dataclass(frozen=True)
class InferRequest:
    """A held-out demonstration to inspect in the Infer tab, as one trial of the evaluation saw
    it (the Data tab's "Open in Infer").

    Attributes
    ----------
    primitive : str
        The demonstration's primitive (the truth).
    demo : str
        The demonstration's name.
    percent : float
        Percentage of the movement observed, in (0, 100].
    observed : tuple of str
        The observed modalities, e.g. ``("hand", "head")``.
    alpha_method : str
        ``"ml"`` or ``"model"`` (:data:`app.ui.display.ALPHA_LABELS`).
    """

    primitive: str
    demo: str
    percent: float
    observed: tuple[str, ...]
    alpha_method: str


class Panel(Protocol):
    """One tab of the studio. Its GUI callbacks only record what changed."""

    def step(self) -> None:
        """Recompute and redraw what changed (the studio's loop calls it at every iteration)."""

    def close(self) -> None:
        """Stop background work and release what the panel holds (the studio is stopping)."""


class PanelGui:
    """viser's GUI API as one panel uses it: every control it adds tells ``used()`` when a
    browser uses it, so that the scene shows the look of the panel in use (viser does not tell
    the server which tab a browser shows; see :mod:`app.scene.look`). Everything else is
    viser's own ``GuiApi``."""

    def __init__(self, gui: viser.GuiApi, used: Callable[[], None]):
        self._gui = gui
        self._used = used

    def __getattr__(self, name: str):
        attribute = getattr(self._gui, name)
        if not name.startswith("add_"):
            return attribute

        def add(*args, **kwargs):
            handle = attribute(*args, **kwargs)
            for hook in ("on_click", "on_upload", "on_update"):
                register = getattr(handle, hook, None)
                if register is not None:
                    register(self._on_event)
                    break
            return handle

        return add

    def _on_event(self, event: viser.GuiEvent) -> None:
        if event.client is not None:  # a browser, not the studio's own code, used it
            self._used()


@dataclass(frozen=True)
class PanelContext:
    """What a panel may read and do (see the module docstring).

    Attributes
    ----------
    gui : PanelGui
        Builds the panel's controls (inside its tab).
    session : Session
    scene : SceneView
    arm : ArmController
    head : HeadInput
    notify : callable
        ``notify(title, body, color="blue", client=None, auto_close_seconds=8.0)``: a
        notification in ``client``'s browser tab, or in every connected tab when None
        (:meth:`app.studio.Studio.notify`).
    atomic : callable
        ``with atomic():`` sends the GUI and scene updates made inside as one group.
    guard_upload : callable
        ``guard_upload(button, max_bytes, refused)``: an :class:`app.ui.upload_guard.UploadGuard`
        on one of the panel's upload buttons.
    open_in_infer : callable
        ``open_in_infer(request, client)``: the Infer tab shows ``request``
        (:class:`InferRequest`), and ``client``'s browser tab switches to it; a request the
        Infer tab cannot show (the demonstration was deleted since) is a notification to
        ``client``. Returns at once (the studio's loop does it).
    """

    gui: PanelGui
    session: Session
    scene: SceneView
    arm: ArmController
    head: HeadInput
    notify: Callable[..., None]
    atomic: Callable[[], AbstractContextManager]
    guard_upload: Callable[[viser.GuiUploadButtonHandle, int, Refused], UploadGuard]
    open_in_infer: Callable[[InferRequest, viser.ClientHandle | None], None]

    def hand_and_head(self) -> tuple[np.ndarray, np.ndarray | None]:
        """The hand position (3,) now, and the latest head angles (3,) or None (thread-safe)."""
        return self.arm.hand_position(), self.head.angles

    def tell(self, event, title: str, body: str, color: str = "red") -> None:
        """A notification to the client behind ``event`` (every client when unknown)."""
        self.notify(title, body, color, client=getattr(event, "client", None))

    def attempt(self, event, what: str, action: Callable[[], object]) -> bool:
        """Run one session mutation; a refusal (``ValueError``, ``OSError``) is a notification
        "Cannot <what>" to the client behind ``event``, and nothing changes."""
        try:
            action()
        except (ValueError, OSError) as exc:
            self.tell(event, f"Cannot {what}", str(exc))
            return False
        return True
