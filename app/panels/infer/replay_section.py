"""The Infer tab's Replay: the robot finishes the predicted movement.

Every new inference loads its predicted future hand path (:class:`app.live.replay.Replay`;
none without a hand, or when nothing of the movement remains); "Play", "Pause" and "Reset"
move the arm's hand along it from the observation point, and the progress bar follows. The
user taking the hand (a drag in 3D) releases the arm. The panel owns the buttons and says
which was pressed (:meth:`ReplaySection.press`): it stops observing the live stream before a
replay moves the hand.

The robot taking over a live movement (:mod:`app.panels.infer.takeover_section`) plays the
committed prediction's path at once and **holds** it (:meth:`ReplaySection.take_over`): the
predictions that follow are shown, but the arm keeps to the path it committed to, until the
user takes the hand, the next take-over, or :meth:`ReplaySection.let_go`.
"""

from __future__ import annotations

import viser

from app.live.inference import InferResult
from app.live.replay import Phase, Replay
from app.ui.context import PanelContext


class ReplaySection:
    """The replay of the predicted movement and its progress bar (see the module docstring).

    Parameters
    ----------
    ctx : PanelContext
        The Infer panel's (the arm, notifications).
    bar : viser.GuiProgressBarHandle
        The replay's progress bar (of :class:`app.panels.infer.controls.InferControls`).
    """

    def __init__(self, ctx: PanelContext, bar: viser.GuiProgressBarHandle) -> None:
        self.ctx = ctx
        self.bar = bar
        self.replay = Replay(ctx.arm.move_hand_to)
        self.held = False  # a take-over's path, kept whatever the next inferences

    def take_over(self, times, hand) -> None:
        """Play the path ``times`` (m,) s, ``hand`` (m, 3) m now, from where the hand is (the
        first step goes onto its start), and hold it (see the module docstring).

        Raises
        ------
        ValueError
            A path :meth:`app.live.replay.Replay.load` refuses (nothing moves then).
        """
        self.held = False
        self.replay.release()
        self.replay.load(times - times[0], hand)
        self.replay.play()
        self.held = True
        self._show_progress()

    def let_go(self) -> None:
        """The next inference's path is loaded again (the arm stays where it is)."""
        self.held = False

    def press(self, command: str) -> None:
        """Run ``command`` ("Play", "Pause" or "Reset"); a replay without a path is a
        notification."""
        replay = self.replay
        try:
            if command == "Play":
                replay.play()
            elif command == "Pause":
                replay.pause()
            elif command == "Reset":
                replay.reset()
        except ValueError as exc:
            self.ctx.notify("Nothing to replay", str(exc), color="yellow")
        self._show_progress()

    def load(self, result: InferResult | None) -> None:
        """The path of ``result``'s prediction (none without a result, a hand path or a
        remaining movement); nothing while a take-over holds the arm."""
        if self.held:
            return
        future = result.future if result is not None else None
        if future is None or result.inference.remaining < 1e-3:
            self.replay.clear()
        else:
            self.replay.load(future.times - future.times[0], future.hand)
        self._show_progress()

    def step(self) -> None:
        """One frame: the hand released when the user took it, else moved on while playing."""
        if self.replay.phase is not Phase.IDLE and self.ctx.arm.dragging:
            self.replay.release()  # the user took the hand
            self.held = False
        if self.replay.step():
            self._show_progress()

    def _show_progress(self) -> None:
        self.bar.value = 100.0 * self.replay.progress
