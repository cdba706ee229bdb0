"""The figure of ``--decide`` (matplotlib, PNG): when each method would act.

Left, the earliness/accuracy trade-off of the commit rule over its thresholds (in-sample: every
trial at every threshold), one curve per method, observed set and alpha method, with the
headline decision (each trial's threshold chosen without it) marked on it. Right, the harmonic
mean of accuracy and 1 - earliness against the threshold, in decades of doubt
(:mod:`promp.evaluate.decisions`), with the median threshold chosen without each trial marked.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from promp.evaluate.plots import _pyplot, series_label

__all__ = ["decision_figure", "doubt_decades"]


def doubt_decades(threshold: float | np.ndarray, n_primitives: int) -> np.ndarray:
    """``-log10((1 - p) / (1 - 1/K))``: a threshold ``p`` in decades of doubt (0 for ``1/K``,
    inf for 1)."""
    doubt = (1.0 - np.asarray(threshold, dtype=float)) / (1.0 - 1.0 / max(n_primitives, 2))
    with np.errstate(divide="ignore"):
        return -np.log10(np.clip(doubt, 0.0, None))


def decision_figure(
    rows: Sequence[Mapping], curve: Sequence[Mapping], n_primitives: int, path: Path, title: str
) -> None:
    """Draw the decisions (``rows``: the headline, ``curve``: in-sample, as
    :func:`promp.evaluate.decisions.decide` gives them) to ``path``."""
    plt = _pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.6))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    named = len({str(r["method"]) for r in rows}) > 1
    for i, row in enumerate(rows):
        key = (row["method"], tuple(row["observed"]), row["alpha_method"])
        points = [c for c in curve
                  if (c["method"], tuple(c["observed"]), c["alpha_method"]) == key]  # fmt: skip
        colour = colours[i % len(colours)]
        label = series_label(row["observed"], row["alpha_method"],
                             str(row["method"]) if named else "")  # fmt: skip
        earliness = np.array([c["earliness"] for c in points])
        accuracy = np.array([c["accuracy"] for c in points])
        x = doubt_decades([c["threshold"] for c in points], n_primitives)
        hm = np.array([c["harmonic_mean"] for c in points])
        left.plot(100 * earliness, 100 * accuracy, ".-", color=colour, lw=1, ms=3,
                  label=f"{label} (in-sample)")  # fmt: skip
        right.plot(x, hm, "-", color=colour, lw=1.2, label=label)
        if math.isfinite(row["harmonic_mean"]):
            held_out = f"{label}: held-out, harmonic mean {row['harmonic_mean']:.2f}"
            left.plot(100 * row["earliness"], 100 * row["accuracy"], "*", color=colour, ms=13,
                      mec="k", mew=0.6, label=held_out)  # fmt: skip
            chosen = float(doubt_decades(row["threshold"], n_primitives))
            right.axvline(min(chosen, float(x.max())), color=colour, ls=":", lw=1)
    left.set_xlabel("earliness: % of the movement observed when it commits (never: 100)")
    left.set_ylabel("accuracy: % of trials committed to the true primitive")
    left.set_title("earliness / accuracy over thresholds (in-sample);\n*: each trial's "
                   "threshold chosen without it", fontsize=10)  # fmt: skip
    left.set_xlim(0, 100)
    left.set_ylim(0, 100)
    right.set_xlabel("threshold, decades of doubt: -log10((1 - p) / (1 - 1/K))")
    right.set_ylabel("harmonic mean of accuracy and 1 - earliness")
    right.set_title("harmonic mean against the threshold (in-sample);\ndotted: the median "
                    "threshold chosen without each trial", fontsize=10)  # fmt: skip
    right.set_ylim(0, 1)
    for ax in (left, right):
        ax.grid(alpha=0.3)
    left.legend(fontsize=7, loc="lower right")
    window = rows[0].get("window_s", math.nan) if rows else math.nan
    fig.suptitle(f"when the robot acts, {title}: commit once p >= threshold for {window:g} s")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
