"""The Teach tab's Live takes folder: takes recorded from the LSL streams (live).

The live source (started in Infer's *LSL streams (live)*, which maps the streams and says how a
movement starts: stillness, a marker stream, or the Begin / End buttons) finds the movements;
with *Record live movements* on, each one is a take of the primitive chosen above (or of the
primitive its start marker names): journalled row by row as it comes, saved through the store
when it ends, written atomically and checked as every take is (:mod:`app.live.live_takes`).
*Begin take* / *End take* start and end a movement from here (in any start mode).

The status says what the take under way holds: the rows **acknowledged**, i.e. in its
journal, which a kill of the studio does not lose. At the start of the studio (and when another
workspace is opened) the journals a kill left are made takes at once, on the save worker, and
the folder says so: recovery is performed, not offered, since what was acknowledged was said
recorded (a take recovered can be discarded as any other, into the trash).
"""

from __future__ import annotations

import collections
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import viser

from app.core.snapshot import Snapshot
from app.live.inference import LSL
from app.live.live_takes import TakeRecorder, recover_takes, save_recorded
from app.live.lsl_source import Running
from app.live.take_controller import NO_PRIMITIVE
from app.ui.context import Frame, PanelContext
from app.ui.text import GREEN, GREY, ORANGE, RED, escape_html
from promp.live.recorder import Recorded

__all__ = ["LiveTakeControls", "LiveTakes", "refusal"]

STATUS_PERIOD_S = 0.2
KEPT = 4  # the latest outcomes shown
COLORS = {"green": GREEN, "yellow": ORANGE, "red": RED, "gray": GREY}
OFF = (f"The live source is off: start it in Infer › Source › {LSL}, where its streams, "
       "their mapping and how movements start are set.")  # fmt: skip
SMALL = "font-size:0.8em;line-height:1.5;padding-right:14px;box-sizing:border-box"


@dataclass(frozen=True, eq=False)
class LiveTakeControls:
    """The handles of the Live takes folder."""

    status: viser.GuiHtmlHandle
    record: viser.GuiCheckboxHandle
    take: viser.GuiButtonGroupHandle


def refusal(running: Running | None, snapshot: Snapshot) -> str | None:
    """Why the live source's movements cannot be takes of this workspace (None: they can)."""
    store = snapshot.store
    if snapshot.primitive is None:
        return NO_PRIMITIVE
    if running is None:
        return OFF
    recorder = running.recorder
    if recorder is None or running.model.layout != store.layout or \
            recorder.root.parent != store.workspace.root:  # fmt: skip
        return "The live source was started for another workspace: Stop and Start it in Infer."
    missing = [m for m in store.layout.names if m not in running.check.modalities]
    if missing:
        return (f"A take holds every modality of the workspace, and the live source maps no "
                f"{', '.join(missing)}: map it in Infer › {LSL}, then Stop and Start.")
    return None


class LiveTakes:
    """The Live takes folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext):
        self.ctx = ctx
        gui = ctx.gui
        with gui.add_folder("Live takes (LSL)", expand_by_default=False):
            status = gui.add_html("")
            record = gui.add_checkbox(
                "Record live movements", False,
                hint="Each movement the live source finds becomes a take of the primitive "
                "chosen above (or of the one its start marker names)",
            )  # fmt: skip
            take = gui.add_button_group("Take", ("Begin take", "End take"))
        self.controls = LiveTakeControls(status, record, take)
        take.on_click(lambda event: self._pressed.append(str(event.target.value)))
        self._pressed: list[str] = []
        self._saves = ThreadPoolExecutor(max_workers=1, thread_name_prefix="live-takes")
        self._jobs: list[Future] = []
        self._seen: set[tuple[int, int]] = set()  # (session, movement) handed to the worker
        self._root: Path | None = None  # the workspace recovered
        self.outcomes: collections.deque = collections.deque(maxlen=KEPT)  # (colour, text)
        self._next = 0.0

    def step(self, frame: Frame) -> None:
        snapshot = frame.snapshot
        root = snapshot.store.workspace.root
        if root != self._root:
            self._root = root
            self._jobs.append(self._saves.submit(recover_takes, root, self.ctx.store))
        self._collect()
        running = self.ctx.live.running
        refused = refusal(running, snapshot)
        armed = bool(self.controls.record.value) and refused is None
        target = snapshot.primitive if armed else None
        recorder = running.recorder if running is not None else None
        if recorder is not None and recorder.target != target:
            recorder.arm(target)
        pressed, self._pressed = self._pressed, []
        for press in pressed:
            if running is None:
                self.ctx.notify("Cannot start a live take", OFF, color="red")
            elif press == "Begin take":
                self.ctx.live.begin()
            else:
                self.ctx.live.end()
        if recorder is not None:
            self._save_new(running, recorder)
        if frame.now >= self._next:
            self._next = frame.now + STATUS_PERIOD_S
            html = status_html(refused, armed, target, recorder, self.outcomes,
                               bool(self.controls.record.value))  # fmt: skip
            if self.controls.status.content != html:
                self.controls.status.content = html

    def _save_new(self, running: Running, recorder: TakeRecorder) -> None:
        for recorded in running.session.snapshot().recorded:
            key = (running.number, recorded.number)
            if key not in self._seen:
                self._seen.add(key)
                self._jobs.append(self._saves.submit(self._save, recorder, recorded))

    def _save(self, recorder: TakeRecorder, recorded: Recorded) -> list[tuple[str, str]]:
        """On the worker: the movement a take, its journal removed once it is."""
        primitive = recorder.primitive_of(recorded)
        try:
            demo = save_recorded(self.ctx.store, primitive, recorded.demo)
        except (ValueError, OSError) as exc:
            return [("red", f"Live movement {recorded.number} not saved ({exc}); its samples "
                            f"stay in {recorded.journal}, saved at the next start if they "
                            "can be")]  # fmt: skip
        recorder.release(recorded)
        text = (f"Saved {demo.name} into {primitive} from live movement {recorded.number}: "
                f"{demo.n_samples} samples, {demo.duration:.1f} s")  # fmt: skip
        findings = self.ctx.store.state.findings_of(primitive, demo.name)
        if findings:
            reasons = "; ".join(f.message for f in findings)
            return [("yellow", f"{text}; left out of learning: {reasons}")]
        return [("green", text)]

    def _collect(self) -> None:
        """The outcomes of the jobs done: shown, and notified."""
        done = [job for job in self._jobs if job.done()]
        for job in done:
            self._jobs.remove(job)
            for color, text in job.result():
                self.outcomes.append((color, text))
                title = "Live take saved" if color in ("green", "yellow") else "Live take"
                self.ctx.notify(title, text, color=color)

    def close(self) -> None:
        self._saves.shutdown(wait=True)


def status_html(refused: str | None, armed: bool, target: str | None,
                recorder: TakeRecorder | None, outcomes, checked: bool) -> str:  # fmt: skip
    """The folder's status: why nothing is recorded, or into what; the take under way (the
    rows acknowledged: in its journal); the latest outcomes."""
    lines = []
    if refused is not None and (checked or refused == OFF):
        lines.append(f'<span style="color:{ORANGE}">{escape_html(refused)}</span>')
    elif armed:
        lines.append(f"Recording each live movement into <b>{escape_html(str(target))}</b> (or "
                     "the primitive its start marker names).")  # fmt: skip
    else:
        lines.append("The live source is on: check <i>Record live movements</i> to make its "
                     "movements takes.")  # fmt: skip
    under_way = recorder.under_way() if recorder is not None else None
    if under_way is not None:
        number, primitive, rows = under_way
        lines.append(f'<span data-acknowledged="{rows}" style="color:{RED};font-weight:600">'
                     f"● Recording live movement {number} into {escape_html(primitive)}: "
                     f"{rows} samples acknowledged</span>")  # fmt: skip
    for color, text in reversed(outcomes):
        lines.append(f'<span style="color:{COLORS.get(color, GREY)}">{escape_html(text)}</span>')
    return f'<div style="{SMALL}">' + "<br>".join(lines) + "</div>"
