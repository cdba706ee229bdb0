"""The speed prior of a primitive and the quadrature over it (paper Eq. 7 and the integral of
Eq. 6 over alpha): the one place of the Student-t, the speed prior and logsumexp.

The evidence of an observation under primitive k integrates the likelihood over its time
modulation alpha (:class:`promp.evidence.Evidence`):

    p(y_o | k) = integral of N(y_o | Phi_o(alpha) mu_k(alpha), S_k(alpha)) p(alpha | k) d alpha

The prior ``p(alpha | k)`` is a Student-t in log alpha fitted to the primitive's training
alphas (location their mean, scale their spread inflated by ``sqrt(1 + 1/n)``, ``n - 1`` degrees
of freedom: the predictive of a normal sample of ``n``), so speeds beyond the slowest and
fastest demonstrations stay possible, just less likely. Alphas whose movement would end before
the observation does are impossible (likelihood 0): the prior is truncated there, and its mass
below the bound enters the evidence, so an observation longer than every demonstration still
gets a recognition (the primitive that most plausibly lasts that long) and a prediction.

The integral is a quadrature on :data:`N_NODES` equally spaced nodes in log alpha spanning the
prior's central 99.6 % (truncated: the nodes past the bound dropped and the bound added,
:func:`anchored_nodes`), refined by :data:`N_REFINE` nodes around the best one
(:func:`refined_nodes`). ``alpha_method="model"`` centres half of the prior's mass on the
Eq. 7 regression from the early displacement (:func:`model_alpha`, a Student-t of the
regression's cross-validated error) and keeps the other half on the training prior, so a wrong
regression (a movement unlike the primitive's demonstrations) costs at most a factor of two in
evidence instead of a confident mistake.

The leave-one-out scorer (:mod:`promp.selection`) uses the same functions in batch form: the
speed prior of many rows at once (:func:`speed_prior`), the Student-t (:func:`t_logpdf`), the
range (:func:`central_range`), the weights (:func:`quadrature_weights`) and
:func:`logsumexp_rows`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import special

from promp._recent import cached_on
from promp.model import Primitive, ProMPModel
from promp.observation import Observation
from promp.quality import winsorized

__all__ = [
    "ALPHA_METHODS", "AlphaMethod", "AlphaPrior", "MAX_SPAN", "N_NODES", "N_REFINE", "TAIL",
    "alpha_prior", "anchored_nodes", "central_range", "logsumexp", "logsumexp_rows",
    "longest_alpha", "modality_columns", "model_alpha", "quadrature", "quadrature_weights",
    "refined_nodes",
    "speed_prior", "t_logpdf",
]  # fmt: skip

AlphaMethod = Literal["ml", "model"]
ALPHA_METHODS: tuple[str, ...] = ("ml", "model")
N_NODES = 32
N_REFINE = 7
TAIL = 0.002  # prior mass left out at each end of the quadrature range
MAX_SPAN = math.log(20.0)  # the quadrature never spans more than x20 around the prior's centre


def t_logpdf(z: np.ndarray, dof: float | np.ndarray) -> np.ndarray:
    """Log density of a standard Student-t with ``dof`` degrees of freedom at ``z`` (any
    shapes that broadcast; closed form: scipy's frozen distributions cost ~0.2 ms each to
    build, too much for a scrub loop). The one Student-t of recognition and of the
    leave-one-out scorer (:mod:`promp.selection.batches`)."""
    const = (
        special.gammaln((dof + 1) / 2) - special.gammaln(dof / 2) - 0.5 * np.log(dof * math.pi)
    )
    return const - (dof + 1) / 2 * np.log1p(z**2 / dof)


def speed_prior(log_alphas: np.ndarray, s_bar: float) -> tuple[np.ndarray, ...]:
    """The speed prior of each row of training log alphas (the module docstring): location,
    scale and degrees of freedom of its Student-t in log alpha.

    Parameters
    ----------
    log_alphas : array, shape (..., n)
        One row of n training log alphas per prior (one row: :meth:`AlphaPrior.from_alphas`;
        a primitive's alphas without each one in turn: the leave-one-out scorer).
    s_bar : float

    Returns
    -------
    loc, scale, dof : arrays, shape (...,)
        ``loc`` the mean of the row winsorized (:func:`promp.quality.winsorized`: a
        demonstration kept despite lasting 30x the others does not stretch the prior),
        ``scale`` its standard deviation times ``sqrt(1 + 1/n)`` and never below one sample's
        worth of duration (``alpha / s_bar``), ``dof = n - 1`` (at least 1).
    """
    logs = winsorized(log_alphas)
    n = logs.shape[-1]
    loc = logs.mean(axis=-1)
    spread = logs.std(axis=-1, ddof=1) if n > 1 else np.zeros_like(loc)
    floor = np.maximum(np.exp(loc) / s_bar, 1e-3)
    scale = np.maximum(spread * math.sqrt(1.0 + 1.0 / n), floor)
    return loc, scale, np.full_like(loc, float(max(n - 1, 1)))


def central_range(
    loc: np.ndarray, scale: np.ndarray, dof: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The quadrature's range of Student-t priors in log alpha (any shapes that broadcast):
    their central mass (:data:`TAIL` left out at each end), never wider than
    :data:`MAX_SPAN` either side of the location."""
    lo = np.maximum(loc + scale * special.stdtrit(dof, TAIL), loc - MAX_SPAN)
    hi = np.minimum(loc + scale * special.stdtrit(dof, 1.0 - TAIL), loc + MAX_SPAN)
    return lo, hi


@dataclass(frozen=True)
class AlphaPrior:
    """A Student-t (or a two-component mixture of them) over log alpha."""

    locs: tuple[float, ...]
    scales: tuple[float, ...]
    dofs: tuple[float, ...]
    weights: tuple[float, ...]

    @classmethod
    def from_alphas(cls, alphas: np.ndarray, s_bar: float) -> AlphaPrior:
        """The predictive of a normal sample of the training log alphas, winsorized
        (:func:`speed_prior` of one row)."""
        loc, scale, dof = speed_prior(np.log(np.asarray(alphas, dtype=float)), s_bar)
        return cls((float(loc),), (float(scale),), (float(dof),), (1.0,))

    def mixed_with(self, loc: float, scale: float, dof: float, weight: float) -> AlphaPrior:
        keep = 1.0 - weight
        return AlphaPrior(
            self.locs + (loc,),
            self.scales + (scale,),
            self.dofs + (dof,),
            tuple(w * keep for w in self.weights) + (weight,),
        )

    def _components(self):
        return zip(self.locs, self.scales, self.dofs, self.weights, strict=True)

    def logpdf(self, log_alpha: np.ndarray) -> np.ndarray:
        x = np.asarray(log_alpha, dtype=float)
        parts = [
            math.log(w) + t_logpdf((x - m) / s, d) - math.log(s)
            for m, s, d, w in self._components()
        ]
        return np.logaddexp.reduce(np.array(parts), axis=0)

    def logcdf(self, log_alpha: float) -> float:
        with np.errstate(divide="ignore"):
            parts = [
                math.log(w) + float(np.log(special.stdtr(d, (log_alpha - m) / s)))
                for m, s, d, w in self._components()
            ]
        return float(logsumexp(np.array(parts)))

    def span(self, log_alpha_max: float) -> tuple[float, float]:
        """The quadrature range: the central mass of every component (:func:`central_range`),
        truncated at the bound."""
        ranges = [central_range(m, s, d) for m, s, d, _ in self._components()]
        lo = min(float(r[0]) for r in ranges)
        hi = max(float(r[1]) for r in ranges)
        hi = min(hi, log_alpha_max)
        if hi <= lo:  # every plausible speed ends too early: the tail just below the bound
            lo = log_alpha_max - 4.0 * max(self.scales)
            hi = log_alpha_max
        return float(lo), float(hi)




def logsumexp(values: np.ndarray) -> float:
    """``log(sum(exp(values)))`` over every entry, stable; ``-inf`` for an empty or all
    ``-inf`` input: :func:`logsumexp_rows` of one row."""
    return float(logsumexp_rows(np.ravel(values)))


def logsumexp_rows(values: np.ndarray) -> np.ndarray:
    """``log(sum(exp(values)))`` along the last axis, stable: shape (...,) for ``values`` of
    shape (..., n); ``-inf`` for an empty or all ``-inf`` row, the row's maximum for a row
    holding ``+inf`` or NaN.

    (scipy's version costs ~0.2 ms of checks per call, too much for a 60 Hz scrub loop.)
    """
    values = np.asarray(values, dtype=float)
    if values.shape[-1] == 0:
        return np.full(values.shape[:-1], -np.inf)
    top = values.max(axis=-1, keepdims=True)
    finite = np.isfinite(top)
    if finite.all():
        return (top + np.log(np.exp(values - top).sum(axis=-1, keepdims=True)))[..., 0]
    safe = np.where(finite, top, 0.0)  # rows without a finite maximum: their maximum
    with np.errstate(divide="ignore", invalid="ignore"):
        out = safe + np.log(np.exp(values - safe).sum(axis=-1, keepdims=True))
    return np.where(finite, out, top)[..., 0]


def modality_columns(model: ProMPModel, obs: Observation, name: str) -> np.ndarray:
    """Columns of ``obs.values`` that hold modality ``name``."""
    start = 0
    for observed in model.layout.modalities:
        if observed.name not in obs.modalities:
            continue
        width = len(observed.columns)
        if observed.name == name:
            return np.arange(start, start + width)
        start += width
    raise ValueError(f"modality {name!r} is not observed")


def longest_alpha(model: ProMPModel, obs: Observation) -> float:
    """The largest alpha whose movement lasts at least as long as the observation."""
    return model.settings.s_bar / (obs.elapsed[-1] / model.sample_period + 1.0)


def model_alpha(model: ProMPModel, primitive: Primitive, obs: Observation) -> tuple[float, float]:
    """Eq. 7: alpha from the early displacement of the observed modalities, and the standard
    deviation of its error in log alpha (the regressions' cross-validated error, combined by
    inverse variance over the observed modalities)."""
    n_obs = int(round(obs.elapsed[-1] / model.sample_period)) + 1
    estimates = []
    for name in obs.modalities:
        cols = modality_columns(model, obs, name)
        delta = obs.values[-1, cols] - obs.values[0, cols]
        estimates.append(primitive.alpha_models[name].predict(delta, n_obs))
    inv = np.array([1.0 / max(var, 1e-12) for _, var in estimates])
    alpha = float((np.array([a for a, _ in estimates]) * inv).sum() / inv.sum())
    lo = 0.5 * float(primitive.alphas.min())
    hi = 2.0 * float(primitive.alphas.max())
    alpha = float(np.clip(alpha, lo, min(hi, longest_alpha(model, obs))))
    return alpha, math.sqrt(1.0 / inv.sum()) / alpha  # delta method into log alpha


def alpha_prior(
    model: ProMPModel, primitive: Primitive, obs: Observation, alpha_method: str
) -> AlphaPrior:
    """The speed prior of ``primitive`` for ``obs``: its training speeds' (computed once per
    primitive, :func:`promp._recent.cached_on`), or for ``alpha_method="model"`` half of it
    moved to the Eq. 7 regression from the observation (module docstring)."""
    s_bar = model.settings.s_bar
    prior = cached_on(
        primitive, "_speed_priors", s_bar, lambda: AlphaPrior.from_alphas(primitive.alphas, s_bar)
    )
    if alpha_method == "ml":
        return prior
    alpha, log_sd = model_alpha(model, primitive, obs)
    return prior.mixed_with(math.log(alpha), max(log_sd, prior.scales[0] / 4), prior.dofs[0], 0.5)


def quadrature(prior: AlphaPrior, bound: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The coarse quadrature in log alpha: :data:`N_NODES` nodes over the prior's central mass,
    truncated at ``bound``, the log of the longest possible alpha (:func:`longest_alpha`;
    :func:`anchored_nodes`), their log prior densities, and the log of the prior mass below
    the bound.

    The lattice and its densities are computed once per prior (:func:`_lattice`): an update
    of a live movement asks for the same prior at a new bound."""
    lattice, density, step = _lattice(prior)
    nodes, kept = _anchored(prior, bound, lattice, step)
    if kept is None:  # the tail below the lattice: nodes of their own
        log_prior = prior.logpdf(nodes)
    elif kept.shape[0] == nodes.shape[0]:  # the whole lattice
        log_prior = density.copy()
    else:  # lattice nodes below the bound, and the bound
        log_prior = np.append(density[kept], prior.logpdf(nodes[-1:]))
    return nodes, log_prior, prior.logcdf(bound)


@functools.lru_cache(maxsize=256)
def _lattice(prior: AlphaPrior) -> tuple[np.ndarray, np.ndarray, float]:
    """The untruncated lattice of ``prior`` (:data:`N_NODES` nodes over its central mass,
    read-only), the log prior density there (read-only) and the lattice's step."""
    lo, hi = prior.span(math.inf)
    lattice = np.linspace(lo, hi, N_NODES)
    density = prior.logpdf(lattice)
    for array in (lattice, density):
        array.setflags(write=False)  # shared by every quadrature of the prior
    return lattice, density, (hi - lo) / (N_NODES - 1)


def anchored_nodes(prior: AlphaPrior, bound: float) -> np.ndarray:
    """The coarse nodes (log alpha) of ``prior`` truncated at ``bound``: :data:`N_NODES` equally
    spaced over its central mass while the bound lies beyond it; past that, the nodes of the
    same lattice below the bound (more than half a step below it), and the bound itself.

    The lattice does not move with the bound (nodes are dropped, never shifted), so as an
    observation grows only the node at the bound is new: the likelihood's sums of the others are
    kept from one update to the next (:meth:`promp.evidence.Evidence.extended`), where spreading the
    nodes over the truncated range made every node new at every sample. When every plausible speed
    ends too early (the bound below the central mass), the nodes are those of a lattice of the same
    origin and half the step below it, within ``4 max(scale)`` of the bound.
    """
    lattice, _, step = _lattice(prior)
    return _anchored(prior, bound, lattice, step)[0]


def _anchored(
    prior: AlphaPrior, bound: float, lattice: np.ndarray, step: float
) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`anchored_nodes` from the prior's ``lattice`` and its ``step``, and which of the
    lattice's nodes they begin with (an index array; all of them when the bound lies beyond
    it; None for the tail's own nodes)."""
    lo, hi = float(lattice[0]), float(lattice[-1])
    if bound >= hi:
        return lattice.copy(), np.arange(N_NODES)
    kept: np.ndarray | None = None
    if bound <= lo:  # every plausible speed ends too early: the tail just below the bound
        step *= 0.5  # half the lattice's: as fine as the tail was
        floor = bound - 4.0 * max(prior.scales)
        k = np.arange(math.ceil((floor - lo) / step), 1)
        lattice = lo + k * step
        lattice = lattice[lattice >= floor]
    # the last gap between half a step and one and a half: the bound's weight steady
    below = np.flatnonzero(lattice < bound - 0.5 * step)
    if below.size == 0:
        below = np.arange(1)
    if bound > lo:
        kept = below
    return np.append(lattice[below], bound), kept


def quadrature_weights(
    nodes: np.ndarray, log_prior: np.ndarray, log_mass: float | np.ndarray
) -> np.ndarray:
    """Log trapezoid weights of increasing ``nodes``, normalised to the prior mass ``log_mass``
    below the bound (so the evidence is ``logsumexp(log_likelihood + weights)``).

    Parameters
    ----------
    nodes : array, shape (..., A)
        Increasing along the last axis (the leave-one-out scorer's batch: (T, 1, A), the nodes
        every primitive of a trial shares).
    log_prior : array, shape (..., A)
        The log prior density at each node (per unit of log alpha).
    log_mass : float or array, shape (...,)

    Returns
    -------
    array, shape (..., A), the shape ``nodes`` and ``log_prior`` broadcast to.
    """
    widths = np.gradient(nodes, axis=-1) if nodes.shape[-1] > 1 else np.ones_like(nodes)
    log_w = log_prior + np.log(widths)
    return log_w + np.asarray(log_mass)[..., None] - logsumexp_rows(log_w)[..., None]


def refined_nodes(nodes: np.ndarray, best: int) -> np.ndarray:
    """The :data:`N_REFINE` nodes that refine the coarse quadrature ``nodes`` (increasing, at
    least two: :func:`quadrature`) around ``nodes[best]``: equally spaced within one coarse
    step either side, strictly inside the coarse range, ``nodes[best]`` itself left out."""
    step = nodes[1] - nodes[0]
    centre = float(nodes[best])
    fine = np.linspace(centre - step, centre + step, N_REFINE + 2)[1:-1]
    keep = (fine > nodes[0]) & (fine < nodes[-1]) & (np.abs(fine - centre) > 1e-9)
    return fine[keep]  # (the last test: numpy's isclose with atol 1e-9, without its checks)
