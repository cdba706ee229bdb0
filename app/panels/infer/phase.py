"""The phase estimate as the Infer tab shows it: how much of the movement the method believes it
has seen, and when it believes the movement ends (:class:`promp.duration.Timing`, posterior
medians and central intervals), beside the truth of a test demonstration (its whole duration
is known). Pure functions of an :class:`app.live.inference.InferResult`.

- :func:`phase_html`: "Phase: observed ≈ 38 % (90 %: 31–47 %) · true 40 %, inside".
- :func:`duration_html`: the predicted duration with its interval, and the true one.
- :func:`end_interval`: the predicted end and its interval for the charts
  (:class:`app.ui.charts.TimeInterval`: a vertical line and a shaded band).

The true share is in time, as the method's is (``elapsed / T``): the observation's last sample
time over the demonstration's duration.
"""

from __future__ import annotations

import math

from app.live.inference import InferResult
from app.scene.inference_layer import darker
from app.ui.charts import TimeInterval
from promp.duration import Estimate

END_LABEL = "predicted end"
INSIDE, OUTSIDE = "#2b8a3e", "#c92a2a"  # the truth inside or outside the interval


def level_text(estimate: Estimate) -> str:
    """``90 %``: the interval's level."""
    return f"{100 * estimate.level:.0f} %"


def true_fraction(result: InferResult) -> float | None:
    """The share of the test demonstration observed, in time (None for the live stream)."""
    truth = result.truth
    if truth is None or not truth.duration > 0:
        return None
    return min(result.inference.observed_until / truth.duration, 1.0)


def _verdict(estimate: Estimate, true: float) -> str:
    inside = estimate.covers(true)
    color, word = (INSIDE, "inside") if inside else (OUTSIDE, "outside")
    return f'<span style="color:{color}">{word}</span>'


def phase_html(result: InferResult) -> str:
    """The observed share of the movement as the method believes it, with its interval, and
    the true share of a test demonstration (inside the interval or not)."""
    share = result.inference.timing.observed_fraction
    text = (
        f"Phase: observed ≈ {100 * share.value:.0f} % ({level_text(share)}: "
        f"{100 * share.low:.0f}–{100 * share.high:.0f} %)"
    )
    true = true_fraction(result)
    if true is not None:
        text += f" · true {100 * true:.0f} %, {_verdict(share, true)}"
    return text


def duration_html(result: InferResult) -> str:
    """The predicted duration with its interval, and the true one (with a truth)."""
    duration = result.inference.timing.duration
    text = (
        f"Duration: predicted {duration.value:.2f} s ({level_text(duration)}: "
        f"{duration.low:.2f}–{duration.high:.2f} s)"
    )
    truth = result.truth
    if truth is not None and math.isfinite(truth.duration):
        text += f" · true {truth.duration:.2f} s, {_verdict(duration, truth.duration)}"
    return text


def end_interval(result: InferResult, color: tuple[int, int, int]) -> TimeInterval:
    """The predicted end of the movement and its interval, in the posterior's ``color``
    (darker, as the predicted path in 3D), seconds from its start."""
    duration = result.inference.timing.duration
    label = f"{END_LABEL} ({level_text(duration)})"
    return TimeInterval(label, duration.value, duration.low, duration.high, darker(color))
