"""Recognition over the whole movement: each primitive's probability against the percentage of
a test demonstration observed, and the earliest point from which the recognition stays right
(the paper's question: how early is it right?). Pure computation, no viser.

:func:`recognition_curve` recognises the first ``p`` % of the demonstration for every ``p`` of
a grid (the Infer tab's rule, :func:`app.live.inference.demo_observation`), with the model, observed
modalities and alpha method of the Infer tab; a percentage the engine cannot explain (it raises
``ValueError``) has no probabilities (NaN) and counts as not right. :class:`CurveCache` keeps
the curves already computed, by what they depend on.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from app.core.fits import LruCache
from app.live.inference import demo_observation
from promp.data import Demonstration
from promp.model import ProMPModel
from promp.recognition import recognise

PERCENTS = np.arange(1.0, 101.0)  # every whole percent: 100 recognitions, ~0.5 s


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
            observation = demo_observation(model, demo, percent, modalities)
            probabilities[i] = recognise(model, observation, alpha_method).probabilities
        except ValueError:  # nothing the model can explain: no probabilities there
            continue
    return RecognitionCurve(tuple(model.names), percents, probabilities, truth)


class CurveCache(LruCache[RecognitionCurve]):
    """The latest curves, by the key of what they depend on (least recently used dropped);
    thread-safe."""

    def __init__(self, max_entries: int = 16):
        super().__init__(max_entries)
