"""Recognition over the whole movement: each primitive's probability against the percentage of
a test demonstration observed, and the earliest point from which the recognition stays right
(the paper's question: how early is it right?). Pure computation, no viser.

:func:`recognition_curve` recognises the first ``p`` % of the demonstration for every ``p`` of
a grid (the Infer tab's rule, :meth:`promp.inference.Observation.first`), with the model, observed
modalities and alpha method of the Infer tab; a percentage the engine cannot explain (it raises
``ValueError``) has no probabilities (NaN) and counts as not right. :class:`CurveCache` keeps
the curves already computed, by what they depend on.
"""

from __future__ import annotations

import threading
import time
import traceback
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass

import numpy as np

from app.core.fits import LruCache
from promp.data import Demonstration
from promp.evidence.pipeline import recognise
from promp.inference import Observation
from promp.model import ProMPModel

PERCENTS = np.arange(1.0, 101.0)  # every whole percent: 100 recognitions, ~0.5 s


@dataclass(frozen=True)
class CurveRequest:
    """What a curve is computed from; ``key`` says what it depends on (demonstration, model,
    observed modalities, alpha method)."""

    key: Hashable
    model: ProMPModel
    demo: Demonstration
    modalities: tuple[str, ...]
    alpha_method: str
    truth: str


@dataclass(frozen=True, eq=False)
class RecognitionCurve:
    """Each primitive's probability over the movement.

    Attributes
    ----------
    names : tuple of str
        The model's primitives, the columns of ``probabilities``.
    percents : array, shape (n,)
        Percentages observed, increasing.
    probabilities : array, shape (n, K)
        NaN rows where the engine could not recognise.
    truth : str or None
        The primitive the movement belongs to.
    """

    names: tuple[str, ...]
    percents: np.ndarray
    probabilities: np.ndarray
    truth: str | None

    @property
    def recognised(self) -> np.ndarray:
        """Index of the most probable primitive at each percentage, -1 where none, (n,)."""
        ok = np.all(np.isfinite(self.probabilities), axis=1)
        out = np.full(self.percents.shape, -1)
        out[ok] = np.argmax(self.probabilities[ok], axis=1)
        return out

    @property
    def right_from(self) -> float | None:
        """The earliest percentage from which the truth is recognised at every later one
        (:func:`earliest_right`); None without a truth or when the last one is wrong."""
        if self.truth is None or self.truth not in self.names:
            return None
        return earliest_right(self.percents, self.recognised, self.names.index(self.truth))


def earliest_right(
    percents: Sequence[float], recognised: Sequence[int], truth: int
) -> float | None:
    """The smallest ``percents[i]`` such that ``recognised[j] == truth`` for every ``j >= i``;
    None when the last recognition is wrong (or there is none).

    Raises
    ------
    ValueError
        ``percents`` and ``recognised`` of different lengths, or percents not increasing.
    """
    percents = np.asarray(percents, dtype=float)
    right = np.asarray(recognised) == truth
    if percents.shape != right.shape or percents.ndim != 1:
        raise ValueError(
            f"one recognition per percentage: got {percents.shape} percents and "
            f"{right.shape} recognitions"
        )
    if percents.size > 1 and not np.all(np.diff(percents) > 0):
        raise ValueError("the percentages must increase")
    if percents.size == 0 or not right[-1]:
        return None
    wrong = np.flatnonzero(~right)
    return float(percents[wrong[-1] + 1]) if wrong.size else float(percents[0])


def recognition_curve(
    model: ProMPModel,
    demo: Demonstration,
    modalities: Sequence[str],
    alpha_method: str,
    truth: str | None = None,
    percents: Sequence[float] = PERCENTS,
    between: Callable[[], None] | None = None,
) -> RecognitionCurve:
    """Recognise the first ``p`` % of ``demo`` (``modalities`` observed, ``alpha_method``)
    for every ``p`` of ``percents``; ``between()``, when given, is called before each (a
    worker computing the curve gives way there to more urgent work)."""
    percents = np.asarray(percents, dtype=float)
    probabilities = np.full((percents.size, len(model.names)), np.nan)
    for i, percent in enumerate(percents):
        if between is not None:
            between()
        try:
            observation = Observation.first(model, demo, percent, modalities)
            probabilities[i] = recognise(model, observation, alpha_method).probabilities
        except ValueError:  # nothing the model can explain: no probabilities there
            continue
    return RecognitionCurve(tuple(model.names), percents, probabilities, truth)


class CurveCache(LruCache[RecognitionCurve]):
    """The latest curves, by the key of what they depend on (least recently used dropped);
    thread-safe."""

    def __init__(self, max_entries: int = 16):
        super().__init__(max_entries)


QUIET_S = 0.15  # the worker waits until the slider has rested this long


class CurveWorker:
    """Computes recognition curves on a thread of its own, the latest request first, into a
    :class:`CurveCache`; it gives way to the slider.

    The studio's loop and this worker are Python threads of one process: while the worker
    runs, the loop's scrub step waits for the interpreter in turns with it (measured with
    ``bench/scrub.py``: the step took twice as long, median 28 ms against 12 ms once the curve
    was done). So between two of its recognitions the worker waits while the loop has
    computed a scrub step in the last :data:`QUIET_S` (:meth:`busy`).
    """

    def __init__(self) -> None:
        self.cache = CurveCache()
        self.computed = 0  # curves computed (not served from the cache)
        self._wanted: CurveRequest | None = None
        self._busy_at = float("-inf")  # when the loop last computed a scrub step
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._work, name="recognition-curve", daemon=True)
        self._thread.start()

    def request(self, wanted: CurveRequest) -> None:
        """Compute the curve of ``wanted`` unless cached (a newer request replaces one not
        started yet)."""
        if self.cache.get(wanted.key) is not None:
            return
        with self._lock:
            if self._wanted is None or self._wanted.key != wanted.key:
                self._wanted = wanted
                self._wake.set()

    def busy(self) -> None:
        """The loop has just computed a scrub step: wait until the slider rests
        (:data:`QUIET_S`) before the next recognition."""
        self._busy_at = time.monotonic()

    def _give_way(self) -> None:
        while not self._stop.is_set():
            rest = self._busy_at + QUIET_S - time.monotonic()
            if rest <= 0:
                return
            self._stop.wait(rest)

    def _work(self) -> None:
        while not self._stop.is_set():
            self._wake.wait()
            if self._stop.is_set():
                return
            with self._lock:
                wanted, self._wanted = self._wanted, None
                self._wake.clear()
            if wanted is None or self.cache.get(wanted.key) is not None:
                continue
            try:
                curve = recognition_curve(
                    wanted.model, wanted.demo, wanted.modalities, wanted.alpha_method,
                    truth=wanted.truth, between=self._give_way,
                )  # fmt: skip
            except Exception:  # a bug here must not end the worker; the chart just waits
                traceback.print_exc()
                continue
            self.cache.put(wanted.key, curve)
            self.computed += 1

    def close(self) -> None:
        self._stop.set()
        self._wake.set()
        self._thread.join(timeout=5.0)
