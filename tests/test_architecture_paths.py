"""docs/ARCHITECTURE.md's two user actions, checked against what a running studio really calls:
one step of the Observed % slider (to the tube in 3D) and one take (from Stop to the redrawn
prior). The studio runs with a call trace installed (tests/call_trace.py); each documented step
must be a function the trace entered during that action, in the documented order, on the thread
the document names (the loop, the save worker, the learner), and the counts the text states
must be the list's. The path itself is bounded as traced, not as written: the functions and
modules of ours the documented calls were made through (each one's stack from its thread's
first function of ours) are no more than SLIDER_PATH and RECORD_PATH."""

from __future__ import annotations

import re

import numpy as np
import pytest

from robots.icub.scene import head_orientation_looking_at
from tests.call_trace import Call, CallTrace
from tests.conftest import REPO, start_studio, wait_frames, wait_until

STEP = re.compile(r"^\d+\. `(?P<path>[^`]+)` `(?P<name>[^`]+)` — (?P<text>.*)$")
COUNTS = re.compile(r"(\d+) calls over (\d+) modules")
# The threads a step may name ("on the learner's worker"): the thread's name in the studio.
THREADS = {"the loop": "studio-loop", "the save worker": "save-take", "the learner": "learner"}
# The functions and modules of ours a documented path is traced through (traced_path): what
# was measured when it was last made shorter; an indirection added on the way fails the test.
SLIDER_PATH = (12, 9)
RECORD_PATH = (21, 11)
THREAD_OF = re.compile(r"\[(the loop|the save worker|the learner)\]")


def documented_path(title: str) -> tuple[list[tuple[str, str, str]], tuple[int, int]]:
    """The numbered steps of the section ``title`` of docs/ARCHITECTURE.md, (file, qualified
    name, thread), and the (calls, modules) its text states."""
    text = (REPO / "docs" / "ARCHITECTURE.md").read_text(encoding="utf-8")
    section = text.split(f"## {title}", 1)[1].split("\n## ", 1)[0]
    steps = []
    for line in section.splitlines():
        if m := STEP.match(line):
            thread = THREAD_OF.search(m["text"])
            steps.append((m["path"], m["name"], THREADS[thread[1]] if thread else ""))
    calls, modules = COUNTS.search(" ".join(section.split())).groups()
    return steps, (int(calls), int(modules))


def match(steps: list[tuple[str, str, str]], calls: list[Call], start: int) -> list[int]:
    """The positions in ``calls`` of the first of ``steps`` found in order from ``start`` on
    (each entered after the one before it, on its thread)."""
    positions = [start - 1]
    for path, name, thread in steps:
        found = next((i for i in range(positions[-1] + 1, len(calls))
                      if (calls[i].path, calls[i].name) == (path, name)
                      and calls[i].thread.startswith(thread)), None)  # fmt: skip
        if found is None:
            break
        positions.append(found)
    return positions[1:]


def traced_path(calls: list[Call]) -> tuple[int, int]:
    """(functions, modules) of ours that ``calls`` were made through: each call's stack from
    its thread's first function of ours, and the call itself. An indirection added on the way
    to any of them is one function more."""
    functions = {frame for call in calls for frame in (*call.stack, (call.path, call.name))}
    print("traced through", sorted(functions))  # shown when the bound fails
    return len(functions), len({path for path, _ in functions})


def assert_path(title: str, calls: list[Call]) -> list[Call]:
    """The documented steps of ``title`` are a subsequence of ``calls`` (in time order),
    starting at one of the calls of its first step (the trace may begin in the middle of a
    frame): each step entered after the step before it, on the thread the document names.
    The counts the text states are the list's, and the path is short. Returns the calls that
    matched the steps."""
    steps, stated = documented_path(title)
    counted = (len(steps), len({path for path, _, _ in steps}))
    assert counted == stated, (title, counted, stated)
    assert counted[0] <= 12 and counted[1] <= 8, (title, counted)
    first = steps[0][:2]
    starts = [i for i, c in enumerate(calls) if (c.path, c.name) == first]
    assert starts, f"{title}: its first step {first} was not called"
    found = max((match(steps, calls, start) for start in starts), key=len)
    best = len(found)
    if best < len(steps):
        path, name, thread = steps[best]
        threads = sorted({c.thread for c in calls if c.name == name})
        raise AssertionError(f"{title}, step {best + 1}: {path} {name} was not called "
                             f"{'on ' + thread + ' ' if thread else ''}after step {best} (it was "
                             f"called on {threads})")  # fmt: skip
    return [calls[i] for i in found]


def within(traced: tuple[int, int], bound: tuple[int, int]) -> bool:
    """No more functions and no more modules than ``bound``."""
    return traced[0] <= bound[0] and traced[1] <= bound[1]


def watch(trace: CallTrace, title: str) -> None:
    """Keep the stacks of the documented steps of ``title``."""
    trace.watch({(path, name) for path, name, _ in documented_path(title)[0]})


@pytest.fixture(scope="module")
def traced(tmp_path_factory):
    """A studio on the default workspace, started with a call trace installed (idle until
    switched on): every thread it starts is watched."""
    trace = CallTrace()
    trace.install()
    try:
        studio = start_studio(tmp_path_factory.mktemp("paths") / "ws")
        try:
            yield studio, trace
        finally:
            studio.stop()
    finally:
        trace.uninstall()


def panel_of(studio, kind):
    return next(p for p in studio.panels if type(p).__name__ == kind)


def test_one_slider_step_calls_the_documented_path(traced) -> None:
    studio, trace = traced
    infer = panel_of(studio, "InferPanel")
    controls = infer.controls

    def shown_at(percent: int):
        view = infer.view
        if view is None or view.result is None or view.state.percent != percent:
            return None
        return view.result if studio.scene.inference.drawn.result is view.result else None

    watch(trace, "The slider's path")
    controls.percent.value = 30  # the held-out model fitted first: not part of a step
    wait_until(lambda: shown_at(30), timeout=120, what="the first view drawn")
    trace.on()
    # the frame under way when the trace began is not traced from its start: the step must
    # fall in a frame that is, or no documented start (`Studio._frame`) precedes it
    wait_frames(studio, 1)
    controls.percent.value = 60
    wait_until(lambda: shown_at(60), timeout=60, what="the step at 60 % drawn")
    calls = trace.off()
    traced = traced_path(assert_path("The slider's path", calls))
    assert within(traced, SLIDER_PATH), traced


def test_one_take_calls_the_documented_path(traced) -> None:
    studio, trace = traced
    teach = panel_of(studio, "TeachPanel")
    record, store = teach.record, studio.session.store
    record.controls.countdown.value = 0.0
    record.controls.trim.value = False
    tubes = studio.scene.workspace.tubes
    wait_until(lambda: "curved" in tubes and studio.session.snapshot().model is not None,
               timeout=120, what="the priors drawn")  # fmt: skip
    before = np.array(tubes["curved"].vertices)
    n_before = len(store.state.demos["curved"])
    watch(trace, "The record path")
    # A curved take: the hand along curved_000's path, from its start to its end (a take that
    # starts or ends elsewhere is flagged and left out, and the prior is never redrawn), in
    # steps, the simulated partner looking at the hand itself (not 0.6 s ahead of it) and
    # turned to it, within 0.2 degrees, before the hand's next step. The recorder holds the
    # head's last reading while the loop is late, so on a busy machine a whole step of the
    # gaze can be recorded as one step, which the checks take for a glitch when it exceeds a
    # fifth of the head's extent (and leave the take out). Steps even in time along the path
    # turn the head by up to 26 % of its extent near the end (one busy-core CI run recorded
    # 25 % in one step). Twenty steps even along the hand's and the head's paths together,
    # each measured against its extent, keep every step of both near a tenth of its extent
    # (checked below against 15 %), so that even a whole step recorded at once is no glitch.
    hand = store.state.demos["curved"][0].select(("x", "y", "z"))
    partner = studio.head.source
    gaze = np.array([head_orientation_looking_at(p, partner.head_position) for p in hand])
    along = np.concatenate([[0.0], np.cumsum(np.maximum(*(
        np.linalg.norm(np.diff(v, axis=0), axis=1) / np.linalg.norm(np.ptp(v, axis=0))
        for v in (hand, gaze))))])  # fmt: skip
    steps = np.searchsorted(along, np.linspace(0.0, along[-1], 21)).clip(0, len(hand) - 1)
    path = hand[steps]
    shares = [np.linalg.norm(np.diff(v, axis=0), axis=1).max() / np.linalg.norm(np.ptp(v, axis=0))
              for v in (path, gaze[steps])]  # fmt: skip
    assert max(shares) < 0.15, shares  # the steps' largest, against each one's extent
    lead, partner.lead_s = partner.lead_s, 0.0

    def turned(target) -> bool:
        looking = head_orientation_looking_at(studio.arm.hand_position(), partner.head_position)
        angles = studio.head.angles
        return bool(np.linalg.norm(studio.arm.hand_position() - target) < 0.002
                    and angles is not None and np.abs(angles - looking).max() < 3.5e-3)

    try:
        studio.loop.call(lambda: studio.arm.move_hand_to(path[0]))
        wait_until(lambda: turned(path[0]), what="the hand at curved's start, the head turned")
        record.press()  # Record
        wait_until(lambda: record.take is not None and record.takes.recording() is not None
                   and record.takes.recording().n_samples > 5, what="a recording")  # fmt: skip
        for target in path[1:]:
            studio.loop.call(lambda t=target: studio.arm.move_hand_to(t))
            wait_until(lambda t=target: turned(t), what="the hand moved on, the head turned")
    finally:
        partner.lead_s = lead
    wait_until(lambda: record.takes.recording().duration > 3.0,  # as long as the others
               what="three seconds of recording")  # fmt: skip
    trace.on()
    record.press()  # Stop
    wait_until(lambda: len(store.state.demos["curved"]) == n_before + 1, what="the take saved")

    def why() -> str:
        state, learner = store.state, studio.session.learner.state
        return (f"the prior of curved redrawn (left out: {dict(state.left_out)}; learned from "
                f"version {learner.learn_version} of {state.learn_version}, {learner.n_demos} "
                f"demonstrations; error {learner.error})")  # fmt: skip

    name = store.state.demos["curved"][-1].name

    def redrawn() -> bool:
        return not np.allclose(np.array(tubes["curved"].vertices), before)

    def flagged_for_its_length() -> bool:
        return {f.kind for f in store.state.findings_of("curved", name)} == {"duration"}

    # On a busy machine the 16 steps above may take so long that the take lasts over twice the
    # others (8.5 s against 3.9 s, seen in a busy-core CI run): the checks rightly flag it and
    # leave it out, and the prior is not redrawn. A researcher who knows why the take is long
    # keeps it (Teach's "learn from it anyway"), and so does this test; any other finding
    # still leaves it out and fails the test.
    wait_until(lambda: redrawn() or flagged_for_its_length(), timeout=120, what=why)
    if not redrawn() and flagged_for_its_length():
        store.set_kept("curved", name, True)
    wait_until(redrawn, timeout=120, what=why)
    wait_until(lambda: (("curved", name) in studio.session.snapshot().typicality),
               timeout=120, what="the take's typicality")  # fmt: skip
    wait_until(lambda: name in record.controls.status.content, what="the take's outcome shown")
    calls = trace.off()
    traced = traced_path(assert_path("The record path", calls))
    assert within(traced, RECORD_PATH), traced
