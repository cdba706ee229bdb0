"""The live pipeline's core: one step of the stages on what arrived, no threads, no I/O.

``source -> time base -> segmenter -> online predictor`` (:mod:`promp.live`):
:func:`step` takes a :class:`PipelineState` and the :class:`Arrivals` of one step (the
clock's time, the streams a look opened, the samples pulled, the calls of a Record button)
and returns the next state, the step's events, the movements' boundaries and the
predictions. It reads no clock, opens and pulls no stream, writes no file and calls no sink:
the runner (:class:`promp.live.session.LiveSession`) gathers the arrivals, and hands the
outputs to the sinks (:mod:`promp.live.sinks`) after the step, where their failures are
collected. A test drives it with hand-made arrivals.

The stages keep their buffers (the time base's samples, the segmenter's rows, the
predictor's sums) in objects the state owns: :func:`step` advances them in place and returns
the state with its own fields replaced, so a state is stepped once, by one thread; the
values it returns (events, boundaries, movements, predictions) are immutable and may be read
anywhere. Everything a step keeps is bounded: rows while nothing moves
(:data:`promp.live.segmenter.HISTORY_S`), a movement's rows (``max_movement_s``), each input's
last samples (:data:`promp.live.timebase.KEEP_S`), and the samples that wait for an input that
lags: a row needs every input, so while one input is silent (stalled, vanished) the others'
samples wait for it, but never longer than a movement may last (``max_movement_s``): past
that, the input is said to lag, the movement under way ends, and the others' samples that
waited are dropped (their rows could only have been given once it came back). Each step's
events come from what arrived (a condition that changed, a marker, a boundary), and it
predicts at most once per boundary and once for the movement going on. The prediction
given last on an ended movement is on its final rows: an end that cut the movement back to
fewer rows than its latest prediction saw is predicted once more. With ``options.decide``,
each prediction also updates the commit rule of its movement (:mod:`promp.live.commitment`):
the one that commits adds one ``decision`` event to the step's events.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

from promp.live.commitment import Committing
from promp.live.options import LiveOptions, live_inputs
from promp.live.predictor import LivePrediction, OnlinePredictor, observed_columns
from promp.live.segmenter import Belief, Boundary, Movement, Segmenter, StillRule
from promp.live.source import Opened, Pulled, Source
from promp.live.status import LiveEvent
from promp.live.timebase import TimeBase
from promp.live.transport import Selector
from promp.model import ProMPModel

__all__ = ["Arrivals", "belief", "build", "Call", "PipelineState", "shown", "step", "StepOutputs"]


@dataclass(frozen=True)
class Call:
    """A movement started (``kind`` ``"start"``, with its class ``label``) or ended
    (``"end"``) at ``time`` (the session's clock): a Record button's press."""

    kind: str
    time: float
    label: str = ""


@dataclass(frozen=True, eq=False)
class Arrivals:
    """What reached the pipeline since the last step.

    Attributes
    ----------
    now : float
        The session's clock, seconds.
    opened : tuple of Opened
        What a look for the missing streams found (:class:`promp.live.source.Opened`).
    pulled : mapping of int to Pulled
        Per connected stream (by its feed's index), the samples pulled or its loss.
    calls : tuple of Call
    notes : tuple of LiveEvent
        Said by the runner itself (a look that failed, a step that failed): passed on first.
    """

    now: float
    opened: tuple[Opened, ...] = ()
    pulled: Mapping[int, Pulled] = field(default_factory=lambda: MappingProxyType({}))
    calls: tuple[Call, ...] = ()
    notes: tuple[LiveEvent, ...] = ()


@dataclass(frozen=True, eq=False)
class PipelineState:
    """The stages, and what the pipeline knows of its own predictions.

    Attributes
    ----------
    source, timebase, segmenter, predictor
        The stages (their buffers advance in place: module docstring).
    min_observed : int
        Rows a movement needs before its first prediction.
    wait_s : float
        The longest the rows wait for an input that lags (seconds: ``max_movement_s``).
    predicted : (int, int)
        The movement and the number of rows of the latest prediction.
    prediction : LivePrediction or None
        The latest prediction.
    newest : mapping of str to float
        Each input's newest sample (the session's clock; the session's start before any).
    heard : mapping of str to float
        When each input's newest samples arrived (the session's clock; its start before any).
    lagging : frozenset of str
        The inputs said to lag (see the module docstring).
    committing : Committing or None
        With ``--decide``, the commit rule's state in the latest prediction's movement.
    """

    source: Source
    timebase: TimeBase
    segmenter: Segmenter
    predictor: OnlinePredictor
    min_observed: int = 2
    wait_s: float = 30.0
    predicted: tuple[int, int] = (0, 0)
    prediction: LivePrediction | None = None
    newest: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    heard: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    lagging: frozenset[str] = frozenset()
    committing: Committing | None = None


StepOutputs = tuple[PipelineState, tuple[LiveEvent, ...], tuple[Boundary, ...],
                    tuple[LivePrediction, ...]]  # fmt: skip


def build(model: ProMPModel, inputs: Sequence, options: LiveOptions, now: float = 0.0
          ) -> PipelineState:  # fmt: skip
    """The stages of a session observing ``inputs`` (:class:`promp.live.source.LiveInput`
    or their mapping text) of ``model`` as ``options`` say; ``now`` the clock at the start.

    Raises
    ------
    ValueError
        An input, an option or the remainder the stages refuse.
    """
    inputs = live_inputs(model, inputs)
    names = [i.name for i in inputs]
    widths = [len(i.modality.fields) for i in inputs]
    columns = observed_columns(names, widths)
    units = [model.layout.modality(n).unit for n in names]
    markers = Selector.parse(options.markers) if options.markers else None
    source = Source(inputs, markers, now)
    timebase = TimeBase(names, widths, options.rate)
    watched = [n for n, u in zip(names, units, strict=True) if u in ("m", "rad")]
    segmenter = Segmenter(options.start, sum(widths),
                          [(columns[n], u) for n, u in zip(names, units, strict=True)],
                          options.max_movement_s, StillRule.of(model, watched))  # fmt: skip
    predictor = OnlinePredictor(model, columns, options.alpha_method, options.remainder,
                                options.remainder_rate, options.n_points,
                                options.helper)  # fmt: skip
    newest = MappingProxyType(dict.fromkeys(names, float(now)))  # none yet: since the start
    committing = None if options.decide is None else \
        Committing(options.decide, tuple(p.name for p in model.primitives))  # fmt: skip
    return PipelineState(source, timebase, segmenter, predictor, options.min_observed,
                         float(options.max_movement_s), newest=newest, heard=newest,
                         committing=committing)  # fmt: skip


def step(state: PipelineState, arrivals: Arrivals) -> StepOutputs:
    """Each stage once on ``arrivals``: the next state, the events, the boundaries and the
    predictions, in the order they happened (see the module docstring)."""
    source, timebase, segmenter = state.source, state.timebase, state.segmenter
    now = arrivals.now
    events = list(arrivals.notes)
    boundaries: list[Boundary] = []
    events += source.adopt(arrivals.opened, now)
    for call in arrivals.calls:
        if call.kind == "start":
            segmenter.begin(call.time, call.label)
        else:
            segmenter.end(call.time)
    batch = source.poll(arrivals.pulled, now)
    events += batch.events
    for name in sorted(batch.broken):
        timebase.restart(name)
        boundaries += segmenter.abort(f"input {name!r} broke off")
    for name, (times, values, units) in batch.samples.items():
        gap = timebase.push(name, times, values, units, source.nominal_rate(name),
                            source.lateness(name, now))  # fmt: skip
        if gap:
            events.append(LiveEvent(now, gap))
            boundaries += segmenter.abort(gap)
    state = _waited(state, batch.samples, now, events, boundaries)
    segmenter.markers(batch.markers)
    events += [LiveEvent(time, f"marker {shown(label)} left out (not start/end CLASS)")
               for time, label in segmenter.unknown]  # fmt: skip
    segmenter.unknown.clear()
    rates = None if timebase.base is not None else {n: source.nominal_rate(n)
                                                     for n in timebase.names}  # fmt: skip
    rows = timebase.advance(rates)  # the rates choose the rows' input, once
    boundaries += segmenter.feed(rows, belief(state.prediction))
    predictions: list[LivePrediction] = []
    for b in boundaries:
        if b.movement is not None:  # its final rows: the prediction published last on it
            state = _predict(state, b.movement, predictions, events, final=True)
        events += _said(b)
    movement = segmenter.movement
    if movement is not None:
        state = _predict(state, movement, predictions, events)
    return state, tuple(events), tuple(boundaries), tuple(predictions)


def _waited(state: PipelineState, samples: Mapping, now: float, events: list[LiveEvent],
            boundaries: list[Boundary]) -> PipelineState:  # fmt: skip
    """The samples that waited too long for an input that lags, dropped (module docstring).

    An input lags when nothing of it arrived for over ``wait_s`` on the session's clock while
    another's did (stalled, vanished, refused), or else when its newest stamp is over
    ``wait_s`` behind the newest of all. The first rule does not compare stamps: an input
    silent since before another's clock jumped back, or whose stamps ran ahead, would
    otherwise not lag while the other's samples waited for it (the live session machine's
    test: a hand 15 s behind a silent head's last stamp held 16 s of samples)."""
    if not samples and not state.lagging:  # nothing arrived: nothing lags more than before
        return state
    newest = {**state.newest, **{n: float(t[-1]) for n, (t, _, _) in samples.items()}}
    heard = {**state.heard, **dict.fromkeys(samples, float(now))}
    names, lead = state.timebase.names, max(newest.values(), default=-math.inf)
    lagging = frozenset(n for n in names if now - heard.get(n, now) > state.wait_s)
    if not lagging or len(lagging) == len(names):  # none silent (or all): by the stamps
        lagging = frozenset(n for n in names if lead - newest.get(n, lead) > state.wait_s)
    if not lagging and not state.lagging:
        return dataclasses.replace(state, newest=MappingProxyType(newest),
                                   heard=MappingProxyType(heard))  # fmt: skip
    for name in sorted(lagging - state.lagging):
        reason = (f"input {name!r} lags the others by over {state.wait_s:g} s: their samples "
                  "no longer wait for it")  # fmt: skip
        events.append(LiveEvent(lead, reason))
        boundaries += state.segmenter.abort(reason)
    for name in state.timebase.names if lagging else ():
        if name not in lagging:
            state.timebase.drop(name)
    return dataclasses.replace(state, newest=MappingProxyType(newest),
                               heard=MappingProxyType(heard), lagging=lagging)  # fmt: skip


def _predict(state: PipelineState, movement: Movement, predictions: list[LivePrediction],
             events: list[LiveEvent], final: bool = False) -> PipelineState:  # fmt: skip
    """A prediction from ``movement``'s rows, unless they were predicted from. A movement
    going on only grows; an ended one (``final``) may have been cut back to fewer rows than
    its latest prediction saw (a still end keeps only the stillness learned after its
    motion): it is predicted once more, on its final rows."""
    n = len(movement)
    number, done = state.predicted
    seen = number == movement.number and (n == done if final else n <= done)
    if n < state.min_observed or seen:
        return state
    state = dataclasses.replace(state, predicted=(movement.number, n))
    try:
        prediction = state.predictor.predict(movement.number, movement.times, movement.values)
    except ValueError as exc:
        events.append(LiveEvent(float(movement.times[-1]), f"no prediction: {exc}"))
        prediction = None
    if why := state.predictor.news():
        events.append(LiveEvent(float(movement.times[-1]), f"the recognition's helper process "
                                f"stopped ({why}): every update is computed in one process"))
    if prediction is None:
        if state.committing is not None:  # an update without a prediction breaks the run
            missed = state.committing.missed(movement.number,
                                             float(movement.times[-1] - movement.times[0]))
            state = dataclasses.replace(state, committing=missed)
        return state
    if state.committing is not None:
        p = prediction
        committing, made = state.committing.update(p.movement, p.elapsed, p.probabilities,
                                                   p.phase.value, p.last)  # fmt: skip
        prediction = dataclasses.replace(prediction, committed=committing.commitment)
        state = dataclasses.replace(state, committing=committing)
        if made is not None:
            events.append(made.event())
    predictions.append(prediction)
    return dataclasses.replace(state, prediction=prediction)


def belief(prediction: LivePrediction | None) -> Belief | None:
    """What ``prediction`` says of its movement (the segmenter's pause allowed depends on it)."""
    p = prediction
    return None if p is None else Belief(p.movement, p.primitive, p.phase.high)


def _said(b: Boundary) -> list[LiveEvent]:
    if b.kind == "start":
        return [LiveEvent(b.time, f"movement {b.number} started")]
    return [LiveEvent(b.time, f"movement {b.number} ended ({b.reason})")]


def shown(label: str, limit: int = 60) -> str:
    """A marker's label as an event quotes it (cut to ``limit`` characters)."""
    return repr(label if len(label) <= limit else label[:limit] + "...")
