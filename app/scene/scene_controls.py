"""What the 3D view draws around the data, under the camera buttons: *Simulated scene* (the
table, the object, the bins and the partner's head of the studio's simulated experiment) and,
for a workspace with positions besides the robot's hand, the frame each was recorded in.

- *Simulated scene* shows or hides them (the robot stays): shown by default for the studio's
  own recordings, hidden for data recorded elsewhere, whose paths would run through bins that
  were never there (:func:`app.core.view_state.scene_shown`). A view setting, like the tube
  style: not written to the workspace; it holds for the workspace it was chosen in.
- *Positions*: one choice per position modality other than the hand (a human's hand, a
  marker): recorded in the **robot's** frame (moved with the hand, as every position was) or
  in the **partner's** (its origin the partner: placed beside the scene's partner,
  :func:`robots.icub.placement.partner_placement`). The import guesses it from the names
  (:func:`app.io.hand_frame.guessed_partner`); a choice here places that modality again from
  the data as recorded and rewrites the workspace (the demonstrations before go to the
  trash, as with any replaced workspace; *Recently deleted* brings them back).

A callback makes the user's choice (the view's, or the store's mutation) when it differs from
the state, so that :meth:`SceneControls.step` writing the state into the controls (which runs
their callbacks) changes nothing; it writes them only when the state changed, so that a choice
made after the frame's snapshot was taken is not undone.
"""

from __future__ import annotations

import dataclasses

import viser

from app.core.session import Session
from app.core.snapshot import Snapshot
from app.core.store_state import workspace_data
from app.core.view_state import scene_shown
from robots.icub.layout import HAND, position_modalities

ROBOTS, PARTNERS = "robot's frame", "partner's frame"
SCENE_HINT = (
    "The table, the object, the bins and the partner's head of the studio's simulated "
    "experiment. Shown for the studio's own recordings, hidden by default for data recorded "
    "elsewhere (their paths would cross bins that were not there)."
)


def frame_hint(name: str) -> str:
    return (
        f"Where {name} was recorded: in the robot's frame (moved with the robot's hand) or in "
        "the partner's frame (its origin the partner: drawn beside the partner). A change "
        "places it again from the data as recorded and rewrites the workspace; the "
        "demonstrations before go to Recently deleted."
    )


class SceneControls:
    """The *Simulated scene* checkbox and the *Positions* folder (see the module docstring),
    built in ``gui``'s current container."""

    def __init__(self, gui, session: Session):
        self.gui = gui
        self.view, self.store = session.view, session.store
        self.checkbox = gui.add_checkbox("Simulated scene", initial_value=True, hint=SCENE_HINT)
        self.checkbox.on_update(self._scene_chosen)
        self.folder = gui.add_folder("Positions", visible=False)
        self.frames: dict[str, viser.GuiDropdownHandle] = {}  # by position modality
        self._shown: tuple = (None, None)  # the scene's state and the frame the controls show

    def _scene_chosen(self, _event) -> None:
        shown, store = bool(self.checkbox.value), self.store.state
        if shown != scene_shown(self.view.state, store):
            self.view.show_scene(shown, store)

    def _frame_chosen(self, name: str, event) -> None:
        partner = event.target.value == PARTNERS
        try:
            said = self.place(name, partner)
        except (ValueError, OSError) as exc:
            self._tell(event.client, f"Cannot change {name}'s frame", f"{exc}.", "red")
            return
        if said:
            self._tell(event.client, f"{name}: {event.target.value}", said, "green")

    def place(self, name: str, partner: bool) -> str:
        """Position ``name`` recorded in the partner's frame (``partner``) or the robot's:
        the workspace rewritten with it placed so; what is said of it ("" when it already
        was). ValueError when it cannot be (:meth:`app.io.hand_frame.HandFrame.with_partner`)."""
        state = self.store.state
        frame, layout = state.frame, state.layout
        if (name in frame.partner_names) == partner:
            return ""
        data = workspace_data(state)
        recorded = frame.as_recorded(data.demos, layout)
        new = frame.with_partner(name, partner, recorded, layout)
        self.store.replace(dataclasses.replace(data, demos=new.placed(recorded, layout),
                                               frame=new),
                           f"before {name} was placed in the {PARTNERS if partner else ROBOTS}")
        where = "beside the partner" if partner else "with the robot's hand"
        return (f"{name} is drawn {where}; the demonstrations before are in Recently "
                "deleted.")  # fmt: skip

    @staticmethod
    def _tell(client, title: str, body: str, color: str) -> None:
        if client is not None:
            client.add_notification(title=title, body=body, color=color, auto_close_seconds=8.0)

    def step(self, snapshot: Snapshot) -> None:
        """Show ``snapshot``'s choices."""
        store = snapshot.store
        shown = scene_shown(snapshot.view, store)
        if shown != self._shown[0]:
            if self.checkbox.value != shown:
                self.checkbox.value = shown
        if (store.frame, store.layout) != self._shown[1]:
            self.checkbox.disabled = not store.frame.robot_shown  # no scene without the robot
            names = tuple(m.name for m in position_modalities(store.layout)
                          if m.name != HAND.name) if store.frame.robot_shown else ()  # fmt: skip
            if names != tuple(self.frames):
                self._build(names)
            for name, handle in self.frames.items():
                value = PARTNERS if name in store.frame.partner_names else ROBOTS
                if handle.value != value:
                    handle.value = value
        self._shown = (shown, (store.frame, store.layout))

    def _build(self, names: tuple[str, ...]) -> None:
        """One dropdown per position modality of ``names`` (the workspace changed)."""
        for handle in self.frames.values():
            handle.remove()
        self.frames = {}
        with self.folder:
            for name in names:
                handle = self.gui.add_dropdown(name, (ROBOTS, PARTNERS), hint=frame_hint(name))
                handle.on_update(lambda event, name=name: self._frame_chosen(name, event))
                self.frames[name] = handle
        self.folder.visible = bool(names)
