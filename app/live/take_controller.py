"""A take from the Record button to a demonstration in the workspace.

The Record button is a pure state machine (:class:`RecordingMachine`: idle, counting down,
recording, saving). One button (Record, then Cancel during the countdown, then Stop) and the
passing of time are its only inputs: :meth:`RecordingMachine.press` and
:meth:`RecordingMachine.tick` (the clock is the caller's), plus :meth:`RecordingMachine.fail`
when the recorder breaks and :meth:`RecordingMachine.saved` once a stopped take is saved. Each
returns what happened (an :class:`Event`) and the take it concerns. No viser, no threads:
tested without a browser.

:class:`TakeController` drives that machine with the clock, samples the hand and the head in
the recorder's thread while recording (:class:`app.live.recorder.Recorder`), and, at Stop,
turns the take into a demonstration (:func:`app.live.takes.save_take`, pure) that it hands to
the store on a worker, so that the disk never holds up the studio's loop. The store writes it,
the learner then scores it and refits (:mod:`app.core.learner`). What the latest take came to
is one :class:`Outcome`, which says which workspace it concerns: a message about a take of
another workspace is not shown.
"""

from __future__ import annotations

import math
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

from app.core.store import Store
from app.core.store_state import Key
from app.live.recorder import Recorder, Recording, Sampler, unrecordable
from app.live.takes import TakeOptions, save_take
from promp.data import Demonstration, Layout
from robots.icub.layout import HEAD

COUNTDOWN_S = 3.0
MAX_COUNTDOWN_S = 10.0
RATE_RANGE_HZ = (10.0, 100.0)
HEAD_FAILED = "The head source failed"


class Phase(Enum):
    IDLE = "idle"
    COUNTDOWN = "countdown"
    RECORDING = "recording"
    SAVING = "saving"  # stopped: the take is being saved (a press does nothing meanwhile)


class Event(Enum):
    NONE = "none"  # nothing happened
    REFUSED = "refused"  # a press that cannot start a recording (see refusal())
    COUNTDOWN = "countdown"  # the countdown started
    CANCELLED = "cancelled"  # pressed during the countdown
    STARTED = "started"  # the countdown ended: sample from now on
    STOPPED = "stopped"  # pressed while recording: save what it has; or the recorder failed


@dataclass(frozen=True)
class Take:
    """One recording: into ``primitive``, sampled at ``rate_hz``, starting at ``starts_at``
    (the caller's clock, seconds) once the countdown is over."""

    primitive: str
    starts_at: float
    rate_hz: float


OFF = "Recording is off in this workspace"
OWN_FRAME_REFUSAL = (
    f"{OFF}: its hand stays in the frame it was recorded in (shown without the robot), and a "
    "take of the iCub's hand would not be in that frame. Record in a workspace in the iCub's "
    "frame (or import the data placed in it)."
)
NO_PRIMITIVE = "Create a primitive first: a demonstration belongs to one."


def workspace_refusal(primitive: str | None, layout: Layout, own_frame: bool = False) -> str | None:
    """Why nothing can be recorded here, whatever the head source or the rate (None when a
    take can be): no primitive, a hand in its own frame (:mod:`app.io.hand_frame`), or
    modalities the studio cannot record. The Record button is disabled with this reason beside
    it, and a press (Space) is refused with the same words."""
    if primitive is None:
        return NO_PRIMITIVE
    if own_frame:
        return OWN_FRAME_REFUSAL
    missing = unrecordable(layout)
    if missing:
        return (
            f"{OFF}: its demonstrations also hold {', '.join(missing)}, which the studio cannot "
            "record, so a new demonstration would lack them. Record in a workspace of hand and "
            "head demonstrations."
        )
    return None


def refusal(
    primitive: str | None,
    layout: Layout,
    head_error: str | None,
    rate_hz: float,
    own_frame: bool = False,
) -> str | None:
    """Why a recording cannot start (None when it can): :func:`workspace_refusal`, a failed
    head source when the head is recorded, or a rate outside :data:`RATE_RANGE_HZ`."""
    blocked = workspace_refusal(primitive, layout, own_frame)
    if blocked is not None:
        return blocked
    if HEAD.name in layout.names and head_error is not None:
        return (
            f"{HEAD_FAILED} ({head_error}). Choose another head source (e.g. the simulated "
            "partner) to record."
        )
    low, high = RATE_RANGE_HZ
    if not low <= rate_hz <= high:
        return f"The rate must be within {low:g}-{high:g} Hz, got {rate_hz:g}."
    return None


def checked_countdown(seconds: float) -> float:
    """``seconds`` as a countdown, or a ValueError when it is not a finite time >= 0."""
    seconds = float(seconds)
    if not math.isfinite(seconds) or seconds < 0:
        raise ValueError(f"the countdown must be >= 0 s, got {seconds}")
    return seconds


class RecordingMachine:
    """The states of the Record button (see the module docstring).

    Parameters
    ----------
    countdown_s : float
        Seconds between Record and the first sample, >= 0.
    """

    def __init__(self, countdown_s: float = COUNTDOWN_S):
        self.countdown_s = checked_countdown(countdown_s)
        self.phase = Phase.IDLE
        self.take: Take | None = None

    def press(
        self,
        now: float,
        primitive: str | None = None,
        rate_hz: float = 0.0,
        refused: str | None = None,
        countdown_s: float | None = None,
    ) -> tuple[Event, Take | None]:
        """The button was pressed at ``now``. When idle, a recording into ``primitive`` at
        ``rate_hz`` counts down for ``countdown_s`` seconds (default: the machine's), unless
        ``refused`` says why not (see :func:`refusal`)."""
        if self.phase is Phase.IDLE:
            if refused is not None:
                return Event.REFUSED, None
            if primitive is None:
                raise ValueError("a recording needs a primitive")
            countdown = self.countdown_s if countdown_s is None else checked_countdown(countdown_s)
            self.take = Take(primitive, now + countdown, float(rate_hz))
            self.phase = Phase.COUNTDOWN
            return Event.COUNTDOWN, self.take
        if self.phase is Phase.SAVING:
            return Event.NONE, None
        if self.phase is Phase.COUNTDOWN:
            take, self.phase, self.take = self.take, Phase.IDLE, None
            return Event.CANCELLED, take
        take, self.phase = self.take, Phase.SAVING
        return Event.STOPPED, take

    def tick(self, now: float) -> tuple[Event, Take | None]:
        """Time passed: the countdown ends at the take's ``starts_at``."""
        if self.phase is Phase.COUNTDOWN and now >= self.take.starts_at:
            self.phase = Phase.RECORDING
            return Event.STARTED, self.take
        return Event.NONE, self.take

    def saved(self) -> None:
        """The stopped take is saved (or refused): ready for the next one."""
        if self.phase is Phase.SAVING:
            self.phase, self.take = Phase.IDLE, None

    def fail(self) -> tuple[Event, Take | None]:
        """The recorder stopped by itself (its sampler failed): the take ends, unsaved."""
        if self.phase is not Phase.RECORDING:
            return Event.NONE, None
        take, self.phase, self.take = self.take, Phase.IDLE, None
        return Event.STOPPED, take

    def remaining(self, now: float) -> int:
        """The countdown's digit: whole seconds left, rounded up (0 when not counting)."""
        if self.phase is not Phase.COUNTDOWN:
            return 0
        return max(0, math.ceil(self.take.starts_at - now))


@dataclass(frozen=True)
class Outcome:
    """What a take came to, as the Record folder says it and notifies it.

    Attributes
    ----------
    root : Path
        The workspace it concerns.
    kind : str
        ``refused`` (the press could not start a take; ``head`` when the head source had
        failed), ``cancelled``, ``failed`` (the recorder broke or the take was refused: nothing
        saved), ``saved`` or ``discarded``.
    text : str
        The line (markdown, escaped) under the Record button.
    title, body, color : str
        Its notification (no notification when ``title`` is empty).
    saved : (primitive, demo) or None
        The demonstration saved (what *Discard last take* moves to the trash).
    """

    root: Path
    kind: str
    text: str
    title: str = ""
    body: str = ""
    color: str = "blue"
    saved: Key | None = None


class TakeController:
    """The Record button's states, the recorder and the save (see the module docstring).

    Parameters
    ----------
    sample : callable
        ``sample(t) -> (hand (3,), head angles (3,) or None)`` at monotonic time ``t``, read
        from the recorder's thread (see :class:`app.live.recorder.Recorder`).
    store : Store
        Where a take is saved.
    countdown_s : float
        The default countdown.
    """

    def __init__(self, sample: Sampler, store: Store, countdown_s: float = COUNTDOWN_S):
        self.machine = RecordingMachine(countdown_s)
        self.recorder: Recorder | None = None
        self.outcome: Outcome | None = None
        self._sample = sample
        self._store = store
        self._saves = ThreadPoolExecutor(max_workers=1, thread_name_prefix="save-take")
        self._saving: Future | None = None

    @property
    def phase(self) -> Phase:
        return self.machine.phase

    @property
    def take(self) -> Take | None:
        """The take under way (counting down, recording or being saved); None when idle."""
        return self.machine.take

    def press(
        self, now: float, primitive: str | None, rate_hz: float, countdown_s: float,
        refused: str | None,
    ) -> Event:  # fmt: skip
        """Record (unless ``refused`` says why not), Cancel or Stop, at ``now``."""
        event, take = self.machine.press(now, primitive, rate_hz, refused, countdown_s)
        if event is Event.REFUSED:
            kind = "head" if refused.startswith(HEAD_FAILED) else "refused"
            self._say(kind, refused, "Cannot record", "red")
        elif event is Event.COUNTDOWN:
            self.outcome = None
        elif event is Event.CANCELLED:
            self._say("cancelled", "Recording cancelled.")
        return event

    def step(self, now: float, options: TakeOptions) -> tuple[Event, Outcome | None]:
        """Move on with the clock at ``now``: start sampling when the countdown ends, end a
        take whose recorder failed, save a stopped take (``options``: how), and say how its
        save went once it has. Returns what happened and the outcome it brought, if any."""
        phase = self.machine.phase
        if phase is Phase.COUNTDOWN:
            event, take = self.machine.tick(now)
            if event is Event.STARTED:
                self.recorder = Recorder(self._sample, take.rate_hz)
                self.recorder.start()
            return event, None
        if phase is Phase.RECORDING and self.recorder.error is not None:
            self.machine.fail()
            recorder, self.recorder = self.recorder, None
            recorder.stop()
            text = f"The recording failed: {recorder.error}"
            return Event.STOPPED, self._say("failed", text, "Nothing saved", "red")
        if phase is Phase.SAVING:
            if self._saving is None:
                self._begin_save(options)
            elif self._saving.done():
                return Event.NONE, self._end_save()
        return Event.NONE, None

    def recording(self) -> Recording | None:
        """The samples so far of the take being recorded."""
        return self.recorder.snapshot() if self.recorder is not None else None

    def discard(self) -> Outcome:
        """Move the last take saved to the trash.

        Raises
        ------
        ValueError
            No take saved in this workspace, or the store refuses (it is gone already).
        """
        outcome, root = self.outcome, self._store.state.workspace.root
        if outcome is None or outcome.saved is None or outcome.root != root:
            raise ValueError("no take saved in this workspace since the studio started")
        primitive, demo = outcome.saved
        self._store.delete_demo(primitive, demo)
        return self._say(
            "discarded", f"Discarded **{demo}**: in the trash (*Undo delete* below).",
            "Take discarded", "gray",
            body=f"{demo} moved to the workspace's trash (Undo delete brings it back).",
        )  # fmt: skip

    def close(self) -> None:
        if self.recorder is not None:
            self.recorder.stop()
        self._saves.shutdown(wait=True)

    # ------------------------------------------------------------------ the save

    def _begin_save(self, options: TakeOptions) -> None:
        recorder, self.recorder = self.recorder, None
        primitive = self.machine.take.primitive
        self._saving = self._saves.submit(self._save, primitive, recorder, options)

    def _save(
        self, primitive: str, recorder: Recorder, options: TakeOptions
    ) -> tuple[Demonstration | None, str]:
        """On the worker: the recorder stopped (its thread joined), the take saved; or None
        and why not."""
        new, text = save_take(recorder.stop(), options)
        if new is None:
            return None, text
        try:
            demo = self._store.add_demo(primitive, new.times, new.values, raw=new.raw)
        except (ValueError, OSError) as exc:
            return None, str(exc)
        return demo, text

    def _end_save(self) -> Outcome:
        primitive = self.machine.take.primitive
        demo, text = self._saving.result()
        self._saving = None
        self.machine.saved()
        if demo is None:
            return self._say("failed", f"Nothing saved: {text}", "Nothing saved", "red")
        findings = self._store.state.findings_of(primitive, demo.name)
        color, body = "green", f"{demo.name}: {text}"
        if findings:
            color = "yellow"
            body = f"{demo.name} is left out of learning: " + "; ".join(f.message for f in findings)
        return self._say(
            "saved", f"Saved **{demo.name}**: {text}", "Demonstration saved", color, body=body,
            saved=(primitive, demo.name),
        )  # fmt: skip

    def _say(
        self, kind: str, text: str, title: str = "", color: str = "blue", body: str = "",
        saved: Key | None = None,
    ) -> Outcome:  # fmt: skip
        self.outcome = Outcome(
            self._store.state.workspace.root, kind, text, title, body or text, color, saved
        )
        return self.outcome

