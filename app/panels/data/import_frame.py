"""The import's question for data recorded elsewhere: where is its hand, for the iCub?

A dataset's ``hand`` is drawn as if it were in the iCub's root frame. When less than
:data:`robots.icub.placement.IN_REACH` of its path lies within the iCub's reach
(:func:`robots.icub.placement.reach_share`), the preview says so and the user chooses:

* **Place in the iCub's frame**: a turn about the vertical and a translation, guessed from the
  data's extent (:func:`robots.icub.placement.guess_placement`) and shown in number fields
  (yaw in degrees, x, y, z in cm) the user may edit; the preview gives the share in reach once
  placed. The workspace keeps the placement (``studio.json``) and its export gives the data
  back in its own frame (:mod:`app.io.hand_frame`).
* **Show in its own frame**: the demonstrations are drawn where they are, without the robot.

A placement out of bounds (or not a number) is refused with a notification, and the fields go
back to the placement before it.
"""

from __future__ import annotations

import math

import numpy as np

from app.io.hand_frame import (
    ICUB_FRAME,
    HandFrame,
    placement_from_fields,
    placement_text,
    reach_sentence,
)
from app.ui.context import PanelGui
from robots.icub.placement import IN_REACH, Placement, guess_placement, reach_share

PLACE, OWN = "Place in the iCub's frame", "Show in its own frame"
FIELD_CM = 1000.0  # the number fields' bounds: the placement's own (app.io.hand_frame)


def reach_line(share: float) -> str:
    """What the preview says of a hand path ``share`` within reach (markdown)."""
    return (
        f"**{reach_sentence(share)}** Place it in the iCub's frame (a turn about the vertical "
        "and a shift, guessed from its extent; edit them below) or show it in its own frame, "
        "without the robot."
    )


class FrameChoice:
    """The reach message, the choice and the placement's fields (see the module docstring);
    shown only for a hand mostly out of reach."""

    def __init__(self, gui: PanelGui):
        self.quiet = False  # set while the code itself changes the fields
        self.points = np.zeros((0, 3))  # the previewed hand's samples, as recorded
        self.share = 1.0  # of them within reach, as recorded
        self.good = Placement()  # the placement the fields hold (the latest accepted)
        self.message = gui.add_markdown("", visible=False)
        self.choice = gui.add_dropdown(
            "Hand's frame", (PLACE, OWN), visible=False,
            hint="Place the hand in the iCub's frame (stored with the workspace, undone on "
            "export), or keep it where it was recorded and hide the robot",
        )  # fmt: skip
        self.yaw = gui.add_number(
            "Yaw (°)", 0.0, min=-360.0, max=360.0, step=1.0, visible=False,
            hint="A turn about the vertical, first",
        )  # fmt: skip
        self.xyz = tuple(
            gui.add_number(
                f"{axis} (cm)",
                0.0,
                min=-FIELD_CM,
                max=FIELD_CM,
                step=0.1,
                visible=False,
                hint=f"Then a shift along the iCub's {axis}",
            )  # fmt: skip
            for axis in "xyz"
        )
        self.handles = (self.choice, self.yaw, *self.xyz)

    @property
    def asked(self) -> bool:
        """The hand is mostly out of reach: the user chooses its frame."""
        return self.share < IN_REACH

    def reset(self, points: np.ndarray) -> None:
        """A new preview whose hand samples (n, 3) are ``points``: asked when out of reach,
        with the guessed placement."""
        self.points = np.asarray(points, dtype=float).reshape(-1, 3)
        self.share = reach_share(self.points)
        if self.asked:
            guess = guess_placement(self.points)
            # The fields show 0.1 cm: the placement is what they show.
            self.good = placement_from_fields(
                0.0, *(round(v * 100.0, 1) for v in guess.translation)
            )
            self._write(PLACE, self.good)
        self.show()

    def update(self) -> str | None:
        """Read the fields after a change: None when accepted, else why the placement was
        refused (the fields are back to the one before)."""
        if self.choice.value == PLACE:
            try:
                self.good = placement_from_fields(
                    float(self.yaw.value), *(float(h.value) for h in self.xyz)
                )
            except (TypeError, ValueError) as exc:
                self._write(PLACE, self.good)
                self.show()
                return f"{exc}. The placement was not changed."
        self.show()
        return None

    def frame(self) -> HandFrame:
        """The frame chosen: the iCub's when not asked."""
        if not self.asked:
            return ICUB_FRAME
        return HandFrame(own=True) if self.choice.value == OWN else HandFrame(self.good)

    def show(self, visible: bool = True) -> None:
        """The message and the controls for an out-of-reach hand (none otherwise)."""
        asked = visible and self.asked
        placing = asked and self.choice.value == PLACE
        self.message.content = self.text() if asked else ""
        self.message.visible = self.choice.visible = asked
        for handle in (self.yaw, *self.xyz):
            handle.visible = placing

    def hide(self) -> None:
        self.points, self.share = np.zeros((0, 3)), 1.0
        self.show(False)

    def text(self) -> str:
        """The reach message, and what the choice does (markdown)."""
        lines = [reach_line(self.share)]
        if self.choice.value == OWN:
            lines.append("Shown in its own frame: the demonstrations are drawn where they "
                         "are, without the robot.")  # fmt: skip
        else:
            placed = reach_share(self.good.apply(self.points))
            lines.append(
                f"Placed ({placement_text(self.good)}): **{placed * 100:.0f} % within reach**. "
                "The workspace keeps the placement; its export gives the data back as recorded."
            )
        return "  \n".join(lines)

    def _write(self, choice: str, placement: Placement) -> None:
        self.quiet = True
        try:
            self.choice.value = choice
            self.yaw.value = round(math.degrees(placement.yaw), 6)
            for handle, value in zip(self.xyz, placement.translation, strict=True):
                handle.value = round(value * 100.0, 6)
        finally:
            self.quiet = False
