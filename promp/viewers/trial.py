"""One inference as a viewer draws it, and each primitive's probability against the share of
the movement observed: what the evaluation's trials and the studio's Infer tab export.

At an observed percent ``p`` (a step of :data:`OBSERVED`), under a trial's path:

* ``observed``: what was seen of the position (metres), a line strip;
* ``region``: the posterior's region, ellipsoids at some phases
  (:func:`promp.viewers.regions.region_ellipsoids`);
* ``predicted``: the predicted mean path, a line strip; ``end``: its last point;
* ``truth`` (static): the whole movement, when known.

``p/<primitive>``: each primitive's probability (unit ``1``) against ``p``.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from promp.viewers.regions import region_ellipsoids
from promp.viewers.scene_log import Color, Item, Points, Series, Stamp, Strips, Timeline

__all__ = [
    "END_RADIUS", "OBSERVED", "OBSERVED_COLOR", "PREDICTED_COLOR", "TRUTH_COLOR", "path_name",
    "probability_series", "trial_items", "whole_percents"
]  # fmt: skip

OBSERVED = Timeline("observed_percent", "sequence", "the percent of the movement observed")
OBSERVED_COLOR: Color = (20, 20, 20)
PREDICTED_COLOR: Color = (230, 120, 20)
TRUTH_COLOR: Color = (120, 120, 120)
END_RADIUS = 0.006  # metres


def path_name(text: str) -> str:
    """``text`` as one name of a viewer path: characters other than letters, digits and
    ``_.-%()+`` become ``_`` (a ``/`` included)."""
    name = re.sub(r"[^A-Za-z0-9_.%()+-]", "_", str(text).strip())
    return name or "_"


def whole_percents(percents: Sequence[float]) -> list[int]:
    """``percents`` as whole numbers; ValueError for one that is not (a sequence timeline,
    Rerun's, counts whole steps)."""
    out = []
    for p in percents:
        if float(p) != round(float(p)):
            raise ValueError(f"viewer files step the observed percent in whole percents; got {p}")
        out.append(int(round(float(p))))
    return out


def trial_items(
    prefix: str,
    percent: int,
    observed: np.ndarray | None,
    region_mean: np.ndarray,
    region_cov: np.ndarray,
    predicted: np.ndarray,
    color: Color,
    probability: float,
) -> list[Item]:
    """The 3-D items of one inference at ``percent`` observed (see the module docstring).

    Parameters
    ----------
    prefix : str
        The trial's path.
    observed : array, shape (n_observed, 3), or None
        The positions seen, metres (None: the position was not observed).
    region_mean, region_cov : arrays, shapes (m, 3) and (m, 3, 3)
        The posterior region's centre and covariance at each of its phases (m, m^2).
    predicted : array, shape (k, 3)
        The predicted mean path, metres.
    color : Color
        The recognised primitive's.
    probability : float
        The share of the region, in (0, 1).
    """
    at = Stamp(OBSERVED.name, percent)
    items: list[Item] = []
    if observed is not None and len(observed) >= 2:
        items.append(Strips(f"{prefix}/observed", (observed,), OBSERVED_COLOR, 0.003, at))
    items.append(region_ellipsoids(f"{prefix}/region", region_mean, region_cov, probability,
                                   color, at))  # fmt: skip
    items.append(Strips(f"{prefix}/predicted", (predicted,), PREDICTED_COLOR, 0.0025, at))
    items.append(Points(f"{prefix}/end", predicted[-1:], PREDICTED_COLOR, END_RADIUS, at))
    return items


def probability_series(
    prefix: str, names: Sequence[str], percents: Sequence[int], probabilities: np.ndarray
) -> list[Series]:
    """``p(<name>)`` against the observed percent, one series per primitive.

    Parameters
    ----------
    names : sequence of str
        The primitives, the columns of ``probabilities``.
    percents : sequence of int
    probabilities : array, shape (len(percents), len(names))
        NaN where nothing was recognised.
    """
    probabilities = np.asarray(probabilities, dtype=float)
    if probabilities.shape != (len(percents), len(names)):
        raise ValueError(f"{prefix}: probabilities of shape ({len(percents)}, {len(names)}) "
                         f"expected, got {probabilities.shape}")  # fmt: skip
    return [
        Series(f"{prefix}/p/{path_name(name)}", f"p({name})", "1", OBSERVED.name,
               np.asarray(percents, dtype=float), probabilities[:, k])  # fmt: skip
        for k, name in enumerate(names)
    ]
