"""The outlets sink: each prediction published as streams a robot controller reads.

For ``--out NAME`` the session opens four outlets (their layouts are defined here once, and
docs/live.md lists them): all irregular-rate (one sample, or one chunk, per prediction),
``double64`` except the events, stamped with the time of the **latest observed sample** on
the predictor's LSL clock (a reader's time correction maps it to its own), and joined by
``seq``, the prediction's number:

* ``NAME-probabilities`` (type ``Probabilities``): ``seq``, ``movement``, then one channel per
  primitive (labelled with its name): the probability that the movement is that primitive.
* ``NAME-timing`` (type ``Timing``): ``seq``, ``movement``, ``start`` (the movement's first
  sample, s on the predictor's clock), ``elapsed`` (s observed), ``phase``, ``phase_low``,
  ``phase_high`` (the share observed, 90 % interval), ``duration``, ``duration_low``,
  ``duration_high`` (s, the whole movement), ``remaining``, ``remaining_low``,
  ``remaining_high`` (s left after the stamp), ``primitive`` (the recognised one's index),
  ``n_observed`` (samples observed), ``committed`` (with ``--decide``, the index of the
  primitive the movement committed to; -1 before it commits, and without ``--decide``).
* ``NAME-remainder`` (type ``Trajectory``), with ``--remainder MODALITY``: per prediction one
  **chunk**, every row stamped alike: ``seq``, ``movement``, ``index`` and ``count`` (the row's
  place in the chunk, its number of rows), ``after`` (s after the stamp: ``1/rate, 2/rate,
  ...`` and, last, the predicted end), then the modality's predicted mean per column and its
  standard deviation per column (``x``, ``y``, ``z``, ``x_std``...). The row with ``index ==
  count - 1`` is the predicted end.
* ``NAME-events`` (type ``Markers``, strings): ``movement N started``, ``movement N ended
  (REASON)``, with ``--decide`` ``movement N committed to 'NAME' at T s (P % observed, p
  PROB)`` (once a movement), and each change of an input's condition (``stream
  'MocapHand': stalled ...``).

A session publishes through two sinks (:mod:`promp.live.sinks`), each on its own thread:
:class:`PredictionSink` (the predictions' outlets) and :class:`EventSink` (the events outlet),
so that one failing or blocking does not hold the other back.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np

from promp.live.predictor import LivePrediction
from promp.live.sinks import Output
from promp.live.status import LiveEvent
from promp.live.transport import Outlet, OutletSpec
from promp.model import ProMPModel

__all__ = [
    "EventSink",
    "outlet_specs",
    "PredictionOutlets",
    "Publisher",
    "PredictionSink",
    "probabilities_row",
    "remainder_rows",
    "TIMING_LABELS",
    "timing_row",
    "TIMING_UNITS",
]

TIMING_LABELS = (
    "seq", "movement", "start", "elapsed", "phase", "phase_low", "phase_high", "duration",
    "duration_low", "duration_high", "remaining", "remaining_low", "remaining_high",
    "primitive", "n_observed", "committed",
)  # fmt: skip
TIMING_UNITS = ("count", "count", "s", "s", "share", "share", "share", "s", "s", "s", "s", "s",
                "s", "index", "count", "index")  # fmt: skip


def outlet_specs(model: ProMPModel, out: str, remainder: str | None) -> dict[str, OutletSpec]:
    """The outlets of ``--out out`` (see the module docstring), by kind."""
    if not out or any(c.isspace() for c in out):
        raise ValueError(f"the outputs' name must be a word without spaces, got {out!r}")
    names = tuple(p.name for p in model.primitives)
    specs = {
        "probabilities": OutletSpec(
            f"{out}-probabilities", "Probabilities", f"promp-live-{out}-probabilities",
            ("seq", "movement", *names), ("count", "count", *("probability",) * len(names)),
        ),
        "timing": OutletSpec(f"{out}-timing", "Timing", f"promp-live-{out}-timing",
                             TIMING_LABELS, TIMING_UNITS),
        "events": OutletSpec(f"{out}-events", "Markers", f"promp-live-{out}-events",
                             ("event",), ("",), format="string"),
    }  # fmt: skip
    if remainder is not None:
        modality = model.layout.modality(remainder)
        columns = modality.columns
        specs["remainder"] = OutletSpec(
            f"{out}-remainder", "Trajectory", f"promp-live-{out}-remainder",
            ("seq", "movement", "index", "count", "after", *columns,
             *(f"{c}_std" for c in columns)),
            ("count", "count", "count", "count", "s", *(modality.unit,) * (2 * len(columns))),
        )
    return specs


def probabilities_row(p: LivePrediction) -> np.ndarray:
    return np.concatenate([[p.seq, p.movement], p.probabilities])


def timing_row(p: LivePrediction) -> np.ndarray:
    phase, duration, remaining = p.phase, p.duration, p.remaining
    return np.array([
        p.seq, p.movement, p.start, p.elapsed, phase.value, phase.low, phase.high,
        duration.value, duration.low, duration.high, remaining.value, remaining.low,
        remaining.high, p.inference.index, p.n_observed,
        -1 if p.committed is None else p.committed.index,
    ], dtype=float)  # fmt: skip


def remainder_rows(p: LivePrediction) -> np.ndarray:
    r = p.remainder
    assert r is not None
    k = r.after.shape[0]
    return np.column_stack([np.full(k, p.seq), np.full(k, p.movement), np.arange(k),
                            np.full(k, k), r.after, r.mean, r.std])  # fmt: skip


class PredictionOutlets:
    """Opens the outlets of :func:`outlet_specs` and pushes each prediction and event.

    ``open_outlet``: the transport's (:meth:`promp.live.transport.Transport.outlet`)."""

    def __init__(self, specs: dict[str, OutletSpec], open_outlet: Callable[[OutletSpec], Outlet]):
        self.specs = specs
        self._outlets = {kind: open_outlet(spec) for kind, spec in specs.items()}

    @property
    def source_ids(self) -> tuple[str, ...]:
        """The outlets' source ids (a session does not read its own streams)."""
        return tuple(s.source_id for s in self.specs.values())

    def publish(self, p: LivePrediction) -> None:
        self._outlets["probabilities"].push(probabilities_row(p)[None], p.last)
        self._outlets["timing"].push(timing_row(p)[None], p.last)
        if "remainder" in self._outlets and p.remainder is not None:
            self._outlets["remainder"].push(remainder_rows(p), p.last)

    def event(self, event: LiveEvent) -> None:
        self._outlets["events"].push([event.text], event.time)

    def wait_for_readers(self, timeout: float, kinds: Sequence[str] | None = None) -> bool:
        """Whether the outlets ``kinds`` (default: all) have a reader within ``timeout``
        seconds (an outlet that cannot tell counts as read)."""
        deadline = time.monotonic() + timeout
        for kind in kinds or list(self._outlets):
            outlet = self._outlets[kind]
            wait = getattr(outlet, "wait_for_consumers", None)
            if wait is not None and not wait(max(deadline - time.monotonic(), 0.0)):
                return False
        return True

    def close(self) -> None:
        for outlet in self._outlets.values():
            outlet.close()


class Publisher(Protocol):
    """What the sinks need of the outlets (:class:`PredictionOutlets`, or the studio's outlets
    switched on and off)."""

    def publish(self, p: LivePrediction) -> None: ...

    def event(self, event: LiveEvent) -> None: ...

    def close(self) -> None: ...


class PredictionSink:
    """The sink of the predictions' outlets (probabilities, timing, remainder); it closes the
    outlets when the session ends (the events outlet with them)."""

    name = "prediction outlets"
    lossless = False
    prompt = True  # delivered before the next inference (promp.live.sinks: prompt sinks)

    def __init__(self, outlets: Publisher):
        self.outlets = outlets

    def view(self, output: Output) -> Output | None:
        return Output(output.time, predictions=output.predictions) if output.predictions \
            else None  # fmt: skip

    def take(self, output: Output) -> tuple[()]:
        for prediction in output.predictions:
            self.outlets.publish(prediction)
        return ()

    def close(self) -> None:
        self.outlets.close()


class EventSink:
    """The sink of the events outlet (its outlets are closed by :class:`PredictionSink`)."""

    name = "events outlet"
    lossless = False

    def __init__(self, outlets: Publisher):
        self.outlets = outlets

    def view(self, output: Output) -> Output | None:
        return Output(output.time, events=output.events) if output.events else None

    def take(self, output: Output) -> tuple[()]:
        for event in output.events:
            self.outlets.event(event)
        return ()

    def close(self) -> None:
        pass
