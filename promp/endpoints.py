"""Where a take starts and ends, against its primitive's other takes: round trips, and starts or
ends far from the others'.

A primitive's takes go from somewhere to somewhere: a take that goes to the goal and comes back
(a round trip), or that starts or ends elsewhere than the others, teaches the primitive a
movement it is not. Each check compares one take with its primitive's other takes, in every
**position** modality (:func:`is_position`: a place in metres, such as a hand's or a marker's;
an orientation is not checked: a partner's head turns to look and back within a good take,
and a force or an EMG has no place to start from), and only where the take moves (a still one
has its own finding, :mod:`promp.quality`):

* ``round_trip``: the take comes back more than half-way (:data:`RETURN_SHARE`) from the
  farthest it went from its start (its excursion) to where it started, its *return* being
  ``1 - |end - start| / excursion`` (no unit: 0 for a reach that ends where it went farthest,
  1 for a return to the very start), while the others' median return is under half-way and the
  take's is far out among theirs (:mod:`promp.outliers`: more than :data:`OUTLIER_Z` robust
  deviations above their median). A primitive whose takes all come back (a wave, a tap) flags
  none.
* ``start``, ``end``: the take's first (last) sample lies farther from where the others start
  (end): the median of their starts (ends), coordinate by coordinate, than
  :data:`PLACE_FACTOR` times the farthest of their own starts (ends) from it, leaving aside
  those that are far out themselves (more than :data:`OUTLIER_Z` robust deviations above their
  median distance: two takes that start elsewhere cannot hide each other), the rule of
  :mod:`promp.quality`'s durations; **and** farther than a floor, :data:`PLACE_SHARE` of the
  others' median excursion. The floor is derived from the data in the modality's own unit and
  scales with the movement (2.5 cm for a 25 cm reach): a primitive whose takes all start at one
  point has almost no spread, and a millimetre of noise on a reach of decimetres is not a
  different start.

Every threshold is a ratio of the data's own quantities, as in :mod:`promp.quality`; the
messages give the sizes in the modality's units (:mod:`promp.units`), e.g. "hand goes 28.8 cm
out and comes 59% of the way back: it ends 11.7 cm from where it started (a round trip);
reach's other takes end 26.8 cm to 29.2 cm from their start".
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from promp.data import Demonstration, Layout, Modality
from promp.finding import Finding
from promp.outliers import MIN_OTHERS, OUTLIER_Z, robust_deviation
from promp.units import amount

__all__ = [
    "PLACE_FACTOR", "PLACE_SHARE", "RETURN_SHARE", "Ends", "endpoint_findings", "is_position",
    "take_ends",
]  # fmt: skip

# A round trip comes back more than half-way from its farthest point to its start (clean
# sets: the largest return of a reach is 25 %, its primitive's median 0 %).
RETURN_SHARE = 0.5
# A start or an end more than twice as far from the others' as the farthest of theirs (clean
# sets: 1.96x at most, but for three ends 2.2-3.5x, each on a path of its own: see the tests).
PLACE_FACTOR = 2.0
# ... and farther than a tenth of how far the primitive's takes go from their start: nearer is
# where they start (end), however alike they start.
PLACE_SHARE = 0.1

def is_position(modality: Modality) -> bool:
    """Whether ``modality`` is a place: linear, in metres (the engine's length; a rig's
    millimetres are read as metres, :mod:`promp.rigs.mapping`)."""
    return modality.unit == "m" and modality.kind == "linear"


@dataclass(frozen=True)
class Ends:
    """Where one take starts and ends in one modality, and how far it goes.

    Attributes
    ----------
    start, end : array, shape (k,)
        The first and the last sample, in the modality's unit.
    excursion : float
        The farthest the take goes from its start.
    turn : int
        The sample where it is farthest from its start.
    back : float
        The end's distance to the start.
    """

    start: np.ndarray
    end: np.ndarray
    excursion: float
    turn: int
    back: float

    @property
    def returned(self) -> float:
        """The share of its excursion it came back to its start: ``1 - back / excursion``
        (0 without an excursion)."""
        return 1.0 - self.back / self.excursion if self.excursion > 0 else 0.0


def take_ends(values: np.ndarray) -> Ends:
    """The :class:`Ends` of one take's values in one modality, shape (n, k)."""
    values = np.asarray(values, dtype=float)
    away = np.linalg.norm(values - values[0], axis=1)
    turn = int(np.argmax(away))
    back = float(np.linalg.norm(values[-1] - values[0]))
    return Ends(values[0], values[-1], float(away[turn]), turn, back)


def endpoint_findings(
    primitive: str,
    demos: Sequence[Demonstration],
    layout: Layout,
    still: np.ndarray,
    files: Mapping[tuple[str, str], str] | None = None,
) -> list[Finding]:
    """The ``round_trip``, ``start`` and ``end`` findings of ``demos``, the takes of
    ``primitive`` (module docstring), by take, then modality.

    ``still`` (bool, shape (n_demos, n_modalities)) marks the modalities a take does not move
    in (:func:`promp.quality.dataset_findings`): those are neither checked nor compared with.
    """
    files = files or {}
    found: dict[int, list[Finding]] = {}
    for m, modality in enumerate(layout.modalities):
        moving = np.flatnonzero(~np.asarray(still, dtype=bool)[:, m])
        if not is_position(modality) or moving.size - 1 < MIN_OTHERS:
            continue
        dims = layout.dims([modality.name])
        ends = [take_ends(layout.extract(demos[i])[:, dims]) for i in moving]
        # every take against the others, all at once: row k holds the others of take k
        others = np.array([np.delete(np.arange(moving.size), k) for k in range(moving.size)])
        checks = (_round_trips(ends, others), _places(ends, others, "start"),
                  _places(ends, others, "end"))  # fmt: skip
        for k, i in enumerate(moving):
            demo = demos[i]
            for check in checks:
                if (said := check(k, demo, primitive, modality)) is not None:
                    kind, time, size, message = said
                    file = files.get((primitive, demo.name), "")
                    found.setdefault(int(i), []).append(
                        Finding(primitive, demo.name, kind, time, size, modality.unit, message,
                                file)  # fmt: skip
                    )
    return [f for i in sorted(found) for f in found[i]]


def _far_bounds(values: np.ndarray) -> np.ndarray:
    """Above these, a value of each row of ``values`` (n, n_others) is far out among that
    row: :data:`OUTLIER_Z` robust deviations above its median, shape (n,)."""
    return np.median(values, axis=1) + OUTLIER_Z * robust_deviation(values, axis=1)[:, 0]


def _round_trips(ends: list[Ends], others: np.ndarray):
    """The round trip check of each take against ``others`` (row k: the others of take k): a
    function of (k, demo, primitive, modality) giving (kind, time, size, message) or None."""
    returned = np.array([e.returned for e in ends])
    theirs = returned[others]
    flagged = (
        (returned > RETURN_SHARE)
        & (np.median(theirs, axis=1) < RETURN_SHARE)
        & (returned > _far_bounds(theirs))
    )

    def said(k: int, demo: Demonstration, primitive: str, modality: Modality) -> tuple | None:
        if not flagged[k]:
            return None
        mine, unit = ends[k], modality.unit
        reaches = [ends[i].back for i in others[k] if ends[i].returned <= RETURN_SHARE]
        return (
            "round_trip",
            float(demo.times[mine.turn] - demo.times[0]),
            mine.back,
            f"{modality.name} goes {amount(mine.excursion, unit)} out and comes "
            f"{mine.returned:.0%} of the way back: it ends {amount(mine.back, unit)} from where "
            f"it started (a round trip); {primitive}'s other takes end "
            f"{amount(min(reaches), unit)} to {amount(max(reaches), unit)} from their start",
        )

    return said


def _places(ends: list[Ends], others: np.ndarray, which: str):
    """The ``which`` ("start" or "end") check of each take against ``others`` (as
    :func:`_round_trips`)."""
    points = np.array([getattr(e, which) for e in ends])  # (n, k)
    theirs = points[others]  # (n, n - 1, k)
    centre = np.median(theirs, axis=1)  # coordinate by coordinate
    spread = np.linalg.norm(theirs - centre[:, None], axis=2)  # (n, n - 1)
    # the others that are not far out themselves: two far takes cannot hide each other
    ordinary = np.where(spread <= _far_bounds(spread)[:, None], spread, np.nan)
    distance = np.linalg.norm(points - centre, axis=1)
    floor = PLACE_SHARE * np.median(np.array([e.excursion for e in ends])[others], axis=1)
    flagged = distance > np.maximum(PLACE_FACTOR * np.nanmax(ordinary, axis=1), floor)

    def said(k: int, demo: Demonstration, primitive: str, modality: Modality) -> tuple | None:
        if not flagged[k]:
            return None
        unit, verb = modality.unit, "starts" if which == "start" else "ends"
        low, high = float(np.nanmin(ordinary[k])), float(np.nanmax(ordinary[k]))
        return (
            which,
            0.0 if which == "start" else float(demo.times[-1] - demo.times[0]),
            float(distance[k]),
            f"{modality.name} {verb} {amount(float(distance[k]), unit)} from where "
            f"{primitive}'s other takes {verb[:-1]} (the median of their {which}s; theirs lie "
            f"{amount(low, unit)} to {amount(high, unit)} from it)",
        )

    return said
