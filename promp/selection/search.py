"""The search walk of the leave-one-out rule: M from the reference value to its neighbours and
on while the loss drops, then the width, then the noise scale (a coarse-to-fine line search
over the grids of :mod:`promp.selection.candidates`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from promp.model import FALLBACK
from promp.selection.candidates import BASIS_GRID, NOISE_GRID, WIDTH_GRID, Candidates
from promp.selection.trials import LOO_MAX_TRIALS, PERCENTS

__all__ = ["LOO_RULE", "neighbours_walk", "walk"]


LOO_RULE = (
    "recognition log-loss of the training demonstrations, each left out of its model in "
    f"closed form ({', '.join(map(str, PERCENTS))} % observed, every modality alone and all "
    f"together, the speed integrated over its prior; at most {LOO_MAX_TRIALS} trials, one fit "
    f"per basis); a walk from the reference: M over {list(BASIS_GRID)} from 7 and both its "
    f"neighbours on while the loss drops, then the width over {list(WIDTH_GRID)}, then the "
    f"noise scale over {list(NOISE_GRID)}; the lowest mean loss among the candidates whose "
    "mean trajectories stay within the box the demonstrations span, widened by its extent"
)


def neighbours_walk(grid: Sequence, start: int, loss, both_sides: bool = True) -> None:
    """Score ``grid[start]`` and its neighbours, then walk on from the best in its direction
    while ``loss`` (a function of the grid's index) drops: a coarse-to-fine line search that
    stops at a local minimum. ``both_sides``: both neighbours first (the loss of a basis is not
    always unimodal: 5 and 10 functions may both beat 7); else one side, the other only when
    the first is not downhill."""
    values = {start: loss(start)}
    best = start
    for step in (-1, 1):
        i = start + step
        if 0 <= i < len(grid):
            values[i] = loss(i)
            if values[i] < values[best]:
                best = i
            if best != start and not both_sides:
                break
    step = best - start
    while step and 0 <= best + step < len(grid):
        value = loss(best + step)
        if not value < values[best]:
            break
        values[best + step] = value
        best += step


def walk(
    candidates: Candidates,
    scales: Sequence[float],
    basis_grid: Sequence[int],
    width_grid: Sequence[float],
    scores: dict,
) -> None:
    """The leave-one-out rule's search, filling ``scores`` ({(M, width): {scale: losses}}):
    M from the grid's value nearest the reference 7, then both its neighbours, then on while
    the loss drops (width 1, at the better of the two noise scales either side of the grid's
    middle for the reference basis); then the width the same way at that M and the noise
    scale at that basis, one side first (:func:`neighbours_walk`). Each candidate basis is
    fitted once (:class:`Candidates`)."""
    # the reference basis is scored at two noise scales either side of the grid's middle, the
    # other bases at the better of the two (the scale's own walk comes last)
    middle = len(scales) // 2
    search = sorted({max(middle - 1, 0), min(middle + 1, len(scales) - 1)})

    def loss(n_basis: int, width: float, levels: Sequence[int] | None = None) -> float:
        levels = search if levels is None else levels
        by_scale = scores.setdefault((n_basis, width), {})
        missing = [scales[i] for i in levels if scales[i] not in by_scale]
        if missing:
            by_scale.update(zip(missing, candidates(n_basis, width)(missing), strict=True))
        values = [float(by_scale[scales[i]].mean()) for i in levels]
        value = min(values)
        return value if np.isfinite(value) else math.inf

    def nearest(grid: Sequence[float], value: float) -> int:
        return min(range(len(grid)), key=lambda i: abs(math.log(grid[i] / value)))

    start_width = width_grid[nearest(width_grid, FALLBACK["width"])]
    start_basis = nearest(basis_grid, FALLBACK["n_basis"])
    reference = basis_grid[start_basis], start_width
    search[:] = [min(search, key=lambda i: (loss(*reference, (i,)), i))]
    basis_scores: dict[int, float] = {}

    def basis_loss(i: int) -> float:
        basis_scores[i] = loss(basis_grid[i], start_width)
        return basis_scores[i]

    neighbours_walk(basis_grid, start_basis, basis_loss)
    n_basis = basis_grid[min(basis_scores, key=lambda i: (basis_scores[i], i))]
    width_scores: dict[int, float] = {}

    def width_loss(i: int) -> float:
        width_scores[i] = loss(n_basis, width_grid[i])
        return width_scores[i]

    neighbours_walk(width_grid, nearest(width_grid, start_width), width_loss, both_sides=False)
    width = width_grid[min(width_scores, key=lambda i: (width_scores[i], i))]
    neighbours_walk(scales, search[0], lambda i: loss(n_basis, width, (i,)), both_sides=False)
