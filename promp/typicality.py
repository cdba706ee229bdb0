"""How typical a demonstration is of its primitive: "unlike the others" in shape and place,
whatever its speed or sampling rate.

A take is compared with its primitive's other demonstrations **per unit of phase**: it is read
on :data:`GRID` evenly spaced phases per unit (straight lines between its samples), so a take
sampled ten times as densely, or moving ten times as slowly along the same path, is read on the
same points. Its score is the mean squared Mahalanobis distance per point and dimension,

    d2 = (y - Phi mu)^T (Phi Sigma Phi^T + R)^-1 (y - Phi mu) / (n D),

under the primitive's trajectory distribution with the speed integrated out (the weights'
mean and covariance marginalised over the training alphas' spread, so a slower take is not
judged by an extrapolated coupling), ``R`` the observation noise. A take that covers only the
start of the movement (stopped early) is judged on the part it covers: it is read as covering
the first ``f`` of the phase for every ``f`` of :data:`COVERAGES` and the best reading counts.

The score ``-d2`` is ranked among the other demonstrations' scores, each computed by a model
learned without it; ``percentile`` is the share of them that score lower: near 0 means unlike
all the others.

A new take is scored on its own (:func:`typicality`: its primitive's other demonstrations are
the references). A whole primitive's demonstrations, imported together, are scored at once
(:func:`typicalities`): each by the model learned without it, ranked among the others' same
scores, one fit per demonstration rather than one per pair; a demonstration learning leaves
out (a flagged one) is scored by the model of all the others and is no one's reference. The
single form is the batch of the others and the take, the take left out of learning: one piece
of maths.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from promp.content_key import content_order
from promp.data import Demonstration, Layout, sample_period_of
from promp.fitting import fit_with
from promp.model import ProMPModel, Settings
from promp.timing import demo_phases

__all__ = [
    "COVERAGES", "GRID", "MIN_OTHERS", "Typicality", "distance", "phase_grid", "typicalities",
    "typicality",
]  # fmt: skip

GRID = 50  # points per unit of phase
COVERAGES = tuple(np.round(np.linspace(0.2, 1.0, 9), 3))  # the share of the movement a take covers
MIN_OTHERS = 3


@dataclass(frozen=True)
class Typicality:
    """How a demonstration compares with its primitive's other demonstrations.

    Attributes
    ----------
    score : float
        Minus the mean squared Mahalanobis distance per point and dimension (0 is a perfect
        match; about -1 is as far as the model expects a new demonstration to be).
    percentile : float
        Share of the primitive's other demonstrations (each scored by a model learned without
        it) that score lower: near 0 means an outlier.
    coverage : float
        The share of the movement the take is read as covering (1 for a whole movement).
    """

    score: float
    percentile: float
    coverage: float = 1.0

    @property
    def label(self) -> str:
        if self.percentile < 0.05:
            return "outlier"
        if self.percentile < 0.2:
            return "unusual"
        return "typical"

    def to_json(self) -> dict:
        return {"score": self.score, "percentile": self.percentile, "coverage": self.coverage}

    @classmethod
    def from_json(cls, data: Mapping) -> Typicality:
        """The inverse of :meth:`to_json`; ValueError on a malformed entry."""
        try:
            typicality = cls(
                float(data["score"]), float(data["percentile"]), float(data.get("coverage", 1))
            )
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise ValueError(f"not a typicality: {data!r} ({exc})") from None
        if not (
            np.isfinite(typicality.score)
            and 0.0 <= typicality.percentile <= 1.0
            and 0.0 < typicality.coverage <= 1.0
        ):
            raise ValueError(
                f"not a typicality: {data!r} (a finite score, a percentile in [0, 1] and a "
                "coverage in (0, 1] expected)"
            )
        return typicality


def phase_grid(
    times: np.ndarray, values: np.ndarray, coverage: float
) -> tuple[np.ndarray, np.ndarray]:
    """A take (``times`` (n,), ``values`` (n, n_dims)) read as covering phases [0,
    ``coverage``]: the phases and the values on :data:`GRID` points per unit of phase (at
    least 2)."""
    n = max(2, int(round(GRID * coverage)) + 1)
    phases = np.linspace(0.0, coverage, n)
    own = demo_phases(times)
    read = np.column_stack([np.interp(phases / coverage, own, v) for v in values.T])
    return phases, read


def _marginal(model: ProMPModel) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of the first primitive's weights with log alpha integrated out."""
    primitive = model.primitives[0]
    logs = np.log(primitive.alphas)
    spread = float(logs.var(ddof=1)) if logs.size > 1 else 0.0
    slope = primitive.alpha_slope
    return primitive.mean, primitive.cov + spread * np.outer(slope, slope)


def distance(model: ProMPModel, demo: Demonstration) -> tuple[float, float]:
    """The smallest mean squared Mahalanobis distance over :data:`COVERAGES` (module
    docstring) of ``demo`` under ``model``'s first primitive, and the coverage that gives it."""
    mean, cov = _marginal(model)
    n_dims, m = model.n_dims, model.basis.n_basis
    noise = model.primitives[0].noise_var
    cov_inv = np.linalg.inv(cov)
    mean_rows = mean.reshape(n_dims, m)
    values = model.layout.extract(demo)
    best = (np.inf, 1.0)
    for coverage in COVERAGES:
        phases, y = phase_grid(demo.times, values, coverage)
        phi = model.basis(phases)  # (n, M)
        residual = y - phi @ mean_rows.T  # (n, D)
        # Woodbury in weight space: r^T S^-1 r = r^T R^-1 r - b^T (Sigma^-1 + Phi^T R^-1 Phi)^-1 b
        gram = phi.T @ phi
        precision = cov_inv.copy()
        b = np.empty(n_dims * m)
        for d in range(n_dims):
            block = slice(d * m, (d + 1) * m)
            precision[block, block] += gram / noise[d]
            b[block] = phi.T @ residual[:, d] / noise[d]
        quad = float((residual**2 / noise).sum() - b @ np.linalg.solve(precision, b))
        per_point = quad / residual.size
        if per_point < best[0]:
            best = (per_point, float(coverage))
    return best


def typicality(
    demo: Demonstration,
    others: Sequence[Demonstration],
    layout: Layout,
    settings: Settings,
) -> Typicality | None:
    """Typicality of ``demo`` against the model learned from ``others`` (its primitive's other
    demonstrations; ``settings`` fully given, nothing is chosen), ranked among the others each
    scored by a model learned without it; None with fewer than :data:`MIN_OTHERS` others."""
    others = list(others)
    return typicalities([*others, demo], layout, settings, [True] * len(others) + [False])[-1]


def typicalities(
    demos: Sequence[Demonstration],
    layout: Layout,
    settings: Settings,
    learned: Sequence[bool] | None = None,
) -> list[Typicality | None]:
    """The typicality of each of ``demos``, one primitive's demonstrations, in their order
    (module docstring): each scored by the model learned from the ``learned`` others
    (``learned``: which of ``demos`` learning uses, all by default), ranked among the learned
    others' scores by a model learned without each; None where there are fewer than
    :data:`MIN_OTHERS` such others or the model cannot be learned. ``settings`` fully given,
    nothing is chosen."""
    demos = list(demos)
    learned = [True] * len(demos) if learned is None else [bool(k) for k in learned]
    if len(learned) != len(demos):
        raise ValueError(f"{len(learned)} learned flags for {len(demos)} demonstrations")
    taught = [i for i, k in enumerate(learned) if k]
    if len(taught) < MIN_OTHERS or (all(learned) and len(taught) <= MIN_OTHERS):
        return [None] * len(demos)
    settings = settings.with_fallback()
    dt = sample_period_of([demos[i] for i in taught])

    def model_without(left_out: int | None) -> ProMPModel:
        rest = [demos[i] for i in taught if i != left_out]
        rest = {"primitive": [rest[i] for i in content_order(rest)]}  # the same in any order
        return fit_with(rest, layout, settings, dt, alpha_models=False)

    try:
        # each learned one by the model of the other learned ones: the references
        scored = {i: distance(model_without(i), demos[i]) for i in taught}
        if not all(learned):  # the others by the model of every learned one
            model = model_without(None)
            scored |= {i: distance(model, d) for i, d in enumerate(demos) if not learned[i]}
    except (ValueError, np.linalg.LinAlgError):
        return [None] * len(demos)
    out: list[Typicality | None] = []
    for i in range(len(demos)):
        references = np.array([-scored[j][0] for j in taught if j != i])
        if references.size < MIN_OTHERS:
            out.append(None)
            continue
        d2, coverage = scored[i]
        out.append(Typicality(-d2, float(np.mean(references < -d2)), coverage))
    return out
