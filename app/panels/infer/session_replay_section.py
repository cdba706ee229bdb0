"""The Infer tab's *Replay a session file* folder, in the Live streams source: a live session
recorded by ``python -m promp.live ... --session FILE.mcap`` replayed through the studio's
model, as ``python -m promp.live --replay FILE --model M`` does, and shown as a live session is
(the 3D view, the readout, the live chart).

The user gives the file's path on the server and presses *Replay*; the file is checked first
(:func:`app.live.session_replay.read_header`: it exists, is a whole session file, was recorded
with the model the studio has now): a refusal is a red notification and a red line, and
nothing changes. It replays at the recorded timing, or as fast as it goes. At the end the
line says whether every prediction equalled the recorded one, bit for bit, or the first
difference. The file is only read. A replay stands in the live source's place
(:meth:`app.live.lsl_source.LslSource.replay`): while it runs (or is shown, finished) live
streams are not started, and while a live session runs no file is replayed; the source's
Stop ends either.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import viser

from app.core.snapshot import Snapshot
from app.live.lsl_source import LslSource, Running
from app.ui.context import PanelContext, PanelGui
from app.ui.text import GREEN, GREY, RED, escape_html

__all__ = ["ReplayControls", "SessionReplaySection", "replay_html"]

TITLE = "Replay a session file"
SMALL = "font-size:0.78em;line-height:1.45;padding-right:14px;box-sizing:border-box"
HINT = ("Path on the server of a session file: an .mcap written by python -m promp.live "
        "--session FILE.mcap with the model the studio has now")  # fmt: skip
EXCLUSIVE = ("While a replay runs (or is shown), live streams are not started; while they "
             "run, no file is replayed. Stop ends either.")  # fmt: skip


@dataclass(frozen=True, eq=False)
class ReplayControls:
    """The handles of the replay folder."""

    folder: viser.GuiFolderHandle
    path: viser.GuiTextHandle
    fast: viser.GuiCheckboxHandle
    replay: viser.GuiButtonHandle
    status: viser.GuiHtmlHandle


def build_controls(gui: PanelGui) -> ReplayControls:
    with gui.add_folder(TITLE, expand_by_default=False) as folder:
        path = gui.add_text("Session file", "", hint=HINT)
        fast = gui.add_checkbox("As fast as it goes", False,
                                hint="Not at the recorded timing: every step at once")
        replay = gui.add_button("Replay", color="blue", icon=viser.Icon.PLAYER_PLAY,
                                hint=EXCLUSIVE)  # fmt: skip
        status = gui.add_html(replay_html(None, ""))
    return ReplayControls(folder, path, fast, replay, status)


def replay_html(running: Running | None, refused: str) -> str:
    """What the folder says: the replay under way or its outcome, or why one cannot start."""
    lines = []
    if refused:
        lines.append(f'<span style="color:{RED}">{escape_html(refused)}</span>')
    replay = running.replay if running is not None else None
    if running is not None and replay is None:
        lines.append(f'<span style="color:{GREY}">A live session runs: Stop it to replay a '
                     "file.</span>")  # fmt: skip
    elif replay is not None:
        header, name = replay.header, escape_html(Path(replay.header.path).name)
        result = replay.result
        if result is None:
            pace = "as fast as it goes" if replay.fast else "at its recorded timing"
            lines.append(f"<b>Replaying {name}</b> ({pace}): step {replay.steps} of "
                         f"{header.steps}, {replay.snapshot().predictions} of "
                         f"{header.predictions} predictions. Live streams wait for Stop.")
        elif result.error:
            lines.append(f'<span style="color:{RED}" data-replay="failed">The replay of {name} '
                         f"failed: {escape_html(result.error)}</span>")  # fmt: skip
        elif result.stopped:
            lines.append(f'<span data-replay="stopped">The replay of {name} was stopped at '
                         f"step {result.steps} of {header.steps}.</span>")  # fmt: skip
        elif result.equal:
            lines.append(f'<span style="color:{GREEN}" data-replay="equal"><b>Replayed {name}: '
                         f"every one of the {result.predictions} predictions equalled the "
                         "recorded one, bit for bit.</b></span>")  # fmt: skip
        else:
            lines.append(f'<span style="color:{RED}" data-replay="differs"><b>Replayed {name}: '
                         f"not the recorded predictions</b>: "
                         f"{escape_html(result.difference)}.</span>")  # fmt: skip
        if result is not None:
            lines.append(f'<span style="color:{GREY}">Stop (above) closes the replay.</span>')
    if not lines:
        lines.append(f'<span style="color:{GREY}">{escape_html(EXCLUSIVE)}</span>')
    return f'<div style="{SMALL}">' + "<br>".join(lines) + "</div>"


class SessionReplaySection:
    """The replay folder (see the module docstring); the callback only records the press,
    :meth:`step` acts on it on the studio's loop."""

    def __init__(self, ctx: PanelContext, source: LslSource):
        self.ctx = ctx
        self.source = source
        self.controls = build_controls(ctx.gui)
        self._pressed = False
        self._refused = ""
        self.controls.replay.on_click(lambda _: self._press())

    def _press(self) -> None:
        self._pressed = True

    def step(self, snapshot: Snapshot) -> None:
        """Act on a press; say what runs."""
        c, running = self.controls, self.source.running
        if self._pressed:
            self._pressed = False
            self._replay(snapshot)
            running = self.source.running
        busy = running is not None
        if c.replay.disabled != busy:
            c.replay.disabled = busy
        html = replay_html(running, self._refused)
        if c.status.content != html:
            c.status.content = html

    def _replay(self, snapshot: Snapshot) -> None:
        model = snapshot.inference_model
        try:
            if model is None:
                error = snapshot.learner.error or "teach some primitives"
                raise ValueError(f"no model yet: {error}")
            self.source.replay(model, self.controls.path.value, bool(self.controls.fast.value))
        except ValueError as exc:
            self._refused = f"Not replayed: {exc}"
            self.ctx.notify("Cannot replay the session file", str(exc), color="red")
            return
        self._refused = ""
