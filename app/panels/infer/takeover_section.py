"""*Robot takes over*: when a live movement commits, the simulated iCub finishes it.

A checkbox beside *Commit to a primitive* in the LSL streams folder, and a status line under
it. With it ticked and the session running the commit rule, the first prediction the Infer
tab sees carrying a movement's commitment (:class:`app.live.takeover.TakeOver`, once per
movement) gives the arm that prediction's remainder of the robot's hand
(:attr:`app.live.inference.InferResult.future`: the posterior mean from the latest observed
sample to the predicted end, timed by the predicted speed), played at once by the Replay
(:meth:`app.panels.infer.replay_section.ReplaySection.take_over`): IK from the hand's current
pose, the first step onto the remainder's start, then along it in real time. The path is the
committed one: later predictions of the movement are drawn (the partner's observed part, the
tube, the bars) but do not move the arm elsewhere. A drag of the hand takes the arm back, as
during a Replay. Where the model has no robot hand (``hand``), the checkbox is disabled, its
hint and the status line saying why.
"""

from __future__ import annotations

import viser

from app.live.inference import InferResult
from app.live.lsl_source import LslSource
from app.live.takeover import NO_HAND, TakeOver, TakeOverStart, unavailable
from app.panels.infer.lsl_view import LslObserved
from app.panels.infer.replay_section import ReplaySection
from app.ui.text import GREEN, GREY, ORANGE, escape_html

__all__ = ["TAKEOVER_HINT", "TakeOverSection", "takeover_html"]

TAKEOVER_HINT = (
    "When a movement commits (Commit to a primitive), the simulated iCub finishes it: its hand "
    "follows the committed prediction's remainder by IK, from where it is, at the predicted "
    "timing. Dragging the hand takes it back."
)
SMALL = "font-size:0.78em;line-height:1.45;padding-right:14px;box-sizing:border-box"


def takeover_html(ticked: bool, reason: str, started: TakeOverStart | None, held: bool) -> str:
    """The status line: why the robot cannot take over, or the latest take-over (empty when
    unticked and available)."""
    if reason == NO_HAND or (ticked and reason):
        return (f'<div data-takeover="unavailable" style="{SMALL};color:{ORANGE}">Robot '
                f"takes over: unavailable: {escape_html(reason)}</div>")  # fmt: skip
    if not ticked:
        return ""
    if started is None:
        return (f'<div data-takeover="waiting" style="{SMALL};color:{GREY}">The robot takes '
                "over when a movement commits</div>")  # fmt: skip
    number = started.movement[-1]
    after = "" if held else " (released: the hand is yours)"
    return (f'<div data-takeover="{number}" style="{SMALL};color:{GREEN}"><b>Movement '
            f"{number}: {escape_html(started.text)}</b>{after}</div>")  # fmt: skip


class TakeOverSection:
    """The checkbox and the status line (see the module docstring).

    Parameters
    ----------
    source : LslSource
        The studio's live source (whether its session runs the commit rule).
    checkbox : viser.GuiCheckboxHandle
    status : viser.GuiHtmlHandle
    playback : ReplaySection
        The Infer tab's Replay, which moves the arm.
    """

    def __init__(self, source: LslSource, checkbox: viser.GuiCheckboxHandle,
                 status: viser.GuiHtmlHandle, playback: ReplaySection) -> None:  # fmt: skip
        self.source = source
        self.checkbox, self.status, self.playback = checkbox, status, playback
        self.state = TakeOver()
        self.failed = ""  # a take-over the Replay refused, said in the status

    def step(self, observed: LslObserved | None, modalities: tuple[str, ...]) -> None:
        """One frame: ``observed``, the LSL source's latest (None: another Source);
        ``modalities``, the workspace's (the session's model's, once started)."""
        box, playback = self.checkbox, self.playback
        model = observed.model if observed is not None else None
        names = tuple(model.layout.names) if model is not None else tuple(modalities)
        no_hand = unavailable(names)
        if box.disabled != bool(no_hand):
            box.disabled = bool(no_hand)
            box.hint = f"Unavailable: {no_hand}" if no_hand else TAKEOVER_HINT
        ticked = bool(box.value) and not no_hand
        if playback.held and (observed is None or not ticked):
            playback.let_go()  # the next inference is the arm's path again
        running = self.source.running
        reason = unavailable(names, running is not None and running.config.commit is not None)
        if observed is not None:
            self.state, start = self.state.decide(observed.prediction, observed.movement,
                                                  ticked, reason)  # fmt: skip
            if start is not None:
                self._start(start, model)
        html = takeover_html(ticked, reason if running is not None or no_hand else "",
                             self.state.started, playback.held)  # fmt: skip
        if self.failed:
            html += f'<div style="{SMALL};color:{ORANGE}">{escape_html(self.failed)}</div>'
        if self.status.content != html:
            self.status.content = html

    def _start(self, start: TakeOverStart, model) -> None:
        p = start.prediction
        future = InferResult(model, p.observation, p.inference).future
        try:
            if future is None:
                raise ValueError(NO_HAND)
            self.playback.take_over(future.times, future.hand)
            self.failed = ""
        except ValueError as exc:
            self.failed = f"Movement {start.movement[-1]}: not taken over: {exc}"
