"""What a panel may read and do (:class:`PanelContext`), what it is given each frame
(:class:`Frame`), and what the studio asks of a panel (:class:`Panel`).

The studio builds each panel inside its tab with a context of its own: the store (the
workspace's mutations), the view state, the learner (its background work), the arm, the
partner's head, notifications, the GUI to build its controls with, and the few requests one
panel may make of another through the studio (:class:`InferRequest`). At every iteration of
its loop the studio hands each panel one :class:`Frame`: the snapshot of the state, read once,
and what the hand and the head are at. The panel reads its controls, computes what to show
from the two, writes it to its controls and returns what the 3D view should show
(:class:`app.scene.look.Shown`). Panels import nothing of the studio.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import viser

from app.core.learner import Learner
from app.core.snapshot import Snapshot
from app.core.store import Store
from app.core.view_state import View
from app.live.head import HeadInput
from app.live.lsl_source import LslSource
from app.scene.arm import ArmController
from app.scene.inference_layer import InferenceLayer
from app.scene.look import TEACH, Shown
from app.ui.callback_guard import HOOKS, GuardedGui
from app.ui.upload_guard import Refused, UploadGuard
from promp.model import ProMPModel


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


@dataclass(frozen=True, eq=False)
class Frame:
    """One iteration of the studio's loop, as the scene and every panel see it.

    Attributes
    ----------
    snapshot : Snapshot
        The state, taken once for the whole frame.
    now : float
        Monotonic seconds.
    hand : array, shape (3,)
        The hand's position (m, the robot's root frame).
    head : array, shape (3,), or None
        The partner's latest head angles (rad), None without a face.
    head_error : str or None
        Why the head source failed, if it did.
    panel : str
        The panel in use (the tab a browser shows: :class:`app.scene.scene_view.SceneView`);
        one not in use may leave work that only its own tab shows for when it is.
    """

    snapshot: Snapshot
    now: float
    hand: np.ndarray
    head: np.ndarray | None
    head_error: str | None = None
    panel: str = TEACH


class Panel(Protocol):
    """One tab of the studio. Its GUI callbacks only record what was pressed."""

    def step(self, frame: Frame) -> Shown | None:
        """Show ``frame``: read the controls, compute, write the controls; return what the 3D
        view should show for this panel (the studio's loop calls it at every iteration)."""

    def close(self) -> None:
        """Stop background work and release what the panel holds (the studio is stopping)."""


class PanelGui(GuardedGui):
    """viser's GUI API as one panel uses it: every control it adds tells ``used()`` when a
    browser uses it, so that the scene shows the look of the panel in use (viser does not tell
    the server which tab a browser shows; see :mod:`app.scene.look`), and, given ``notify``,
    tells the user when one of its callbacks fails (:mod:`app.ui.callback_guard`). Everything
    else is viser's own ``GuiApi``."""

    def __init__(
        self,
        gui: viser.GuiApi,
        used: Callable[[], None],
        notify: Callable[..., object] | None = None,
    ):
        super().__init__(gui, notify)
        self._used = used

    def _built(self, handle):
        for hook in HOOKS:
            register = getattr(handle, hook, None)
            if register is not None:
                register(self._on_event)
                break
        return super()._built(handle)

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
    store : Store
        The workspace's mutations (each validated, written, then published).
    view : View
        What the user looks at (hidden demonstrations, the primitive taught, an imported model).
    learner : Learner
        Background work: held-out models, the model of the latest change.
    arm : ArmController
    head : HeadInput
    notify : callable
        ``notify(title, body, color="blue", client=None, auto_close_seconds=8.0)``: a
        notification in ``client``'s browser tab, or in every connected tab when None
        (:meth:`app.studio.Studio.notify`); returns their handles.
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
    wait_for_model : callable
        ``wait_for_model()``: the model of the workspace as it is now, once learned
        (:meth:`app.core.session.Session.wait_for_model`; e.g. the exports).
    live : LslSource
        The live source over LSL (one per studio): Infer starts it and shows its
        predictions, Teach records its movements as takes.
    inference_layer : InferenceLayer or None
        The 3D view's Infer layer, where the Infer panel draws its result (its
        :attr:`~app.scene.inference_layer.InferenceLayer.drawn` says what is drawn; the scene
        shows or hides it); None for every other panel.
    """

    gui: PanelGui
    store: Store
    view: View
    learner: Learner
    arm: ArmController
    head: HeadInput
    notify: Callable[..., None]
    atomic: Callable[[], AbstractContextManager]
    guard_upload: Callable[[viser.GuiUploadButtonHandle, int, Refused], UploadGuard]
    open_in_infer: Callable[[InferRequest, viser.ClientHandle | None], None]
    wait_for_model: Callable[[], ProMPModel | None]
    live: LslSource
    inference_layer: InferenceLayer | None = None

    def hand_and_head(self, t: float) -> tuple[np.ndarray, np.ndarray | None]:
        """The hand position (3,) and the head angles (3,) or None at monotonic time ``t``
        (thread-safe: the recorder's thread reads them, at its ticks, however late it runs);
        ``LookupError`` when ``t`` is older than what is kept."""
        return self.arm.hand_at(t), self.head.angles_at(t)

    def tell(self, event, title: str, body: str, color: str = "red") -> None:
        """A notification to the client behind ``event`` (every client when unknown)."""
        self.notify(title, body, color, client=getattr(event, "client", None))

    def attempt(self, event, what: str, action: Callable[[], object]) -> bool:
        """Run one mutation; a refusal (``ValueError``, ``OSError``) is a notification
        "Cannot <what>" to the client behind ``event``, and nothing changes."""
        try:
            action()
        except (ValueError, OSError) as exc:
            self.tell(event, f"Cannot {what}", str(exc))
            return False
        return True
