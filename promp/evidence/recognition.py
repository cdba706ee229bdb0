"""Recognition: which primitive, at which speed (paper Eqs. 6-7), with honest probabilities.

Every primitive k is scored by the evidence of the observation, the likelihood of Eq. 6
integrated over its time modulation alpha:

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
:func:`anchored_nodes`), refined by :data:`N_REFINE` nodes around the best one; the
reported alpha is the posterior mode on those nodes. ``alpha_method="model"`` centres half of
the prior's mass on the Eq. 7 regression from the early displacement (a Student-t of the
regression's cross-validated error) and keeps the other half on the training prior, so a wrong
regression (a movement unlike the primitive's demonstrations) costs at most a factor of two in
evidence instead of a confident mistake.

**No certainty beyond what the demonstrations can support.** The Gaussian likelihood is exact
for the model, but real movements are not exactly the model: a movement can look like a slower
reach of another primitive, and with dozens of correlated samples the evidence for the wrong one
grows by tens of nats (a trial of the lab's heights set got p(true) = 2e-7, one of flt 6e-11).
So the class posterior carries an explicit "none of these" hypothesis: with probability
``epsilon`` an observation is not described by the primitive it belongs to, and is then equally
likely to belong to any of them (its predictive is the primitives' average, so it tells the
classes nothing apart): ``p(k | y) = (1 - epsilon) p_model(k | y) + epsilon / K``. Its prior
is Laplace's rule of succession over the N training demonstrations, ``epsilon = 1 / (N + 2)``
(:func:`label_noise`): the more demonstrations, the more certain the model may be. Nothing is
fitted to a dataset; the ranking of the primitives is unchanged, a probability never falls below
``1 / (K (N + 2))`` (-ln p at most ln K (N + 2): 5.9 nats for 122 demonstrations of 3
primitives) and a confident right answer loses at most ``epsilon`` of its probability.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from scipy import special

from promp._likelihood import log_likelihoods, logsumexp, logsumexp_rows
from promp._recent import cached_on
from promp.model import Primitive, ProMPModel
from promp.observation import Observation, check_observation
from promp.quality import winsorized
from promp.timing import alpha_from_duration

if TYPE_CHECKING:
    from promp.incremental import IncrementalStatistics

__all__ = [
    "ALPHA_METHODS", "AlphaMethod", "AlphaPrior", "MAX_SPAN", "N_NODES", "N_REFINE", "Recognition",
    "TAIL", "alpha_prior", "anchored_nodes", "central_range", "label_noise", "longest_alpha",
    "modality_columns", "model_alpha", "quadrature", "quadrature_weights", "recognise",
    "refined_nodes", "speed_prior", "t_logpdf", "with_label_noise"
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


@dataclass(frozen=True, eq=False)
class Recognition:
    """Which primitive the observation belongs to, and at which speed.

    Attributes
    ----------
    index : int
        Index of the recognised primitive in ``model.primitives``.
    primitive : str
    alpha : float
        Time modulation of the recognised primitive (its posterior mode).
    probabilities : array, shape (n_primitives,)
        Posterior probability of each primitive (uniform prior over primitives, each
        primitive's likelihood integrated over its alpha prior), with the "none of these"
        hypothesis (:func:`with_label_noise`).
    candidates : tuple of arrays
        Per primitive, the alpha nodes scored (increasing).
    log_likelihoods : tuple of arrays
        Per primitive, the log-likelihood of the observation at each node (Eq. 6).
    log_prior : tuple of arrays
        Per primitive, the log prior density of each node (per unit of log alpha).
    log_evidence : array, shape (n_primitives,)
        ``log p(y_o | k)``.
    alpha_method : str
    """

    index: int
    primitive: str
    alpha: float
    probabilities: np.ndarray
    candidates: tuple[np.ndarray, ...]
    log_likelihoods: tuple[np.ndarray, ...]
    log_prior: tuple[np.ndarray, ...]
    log_evidence: np.ndarray
    alpha_method: str

    def speed_posterior(
        self, index: int | None = None, temperature: float = 1.0
    ) -> tuple[np.ndarray, np.ndarray]:
        """The posterior over the speed of primitive ``index`` (default: the recognised one)
        on its quadrature nodes: ``(alphas (A,), masses (A,))``, masses summing to 1 (the
        trapezoid weights of the quadrature times the likelihood raised to ``temperature``,
        normalised; see :mod:`promp.duration`)."""
        k = self.index if index is None else index
        alphas = self.candidates[k]
        log_nodes = np.log(alphas)
        widths = np.gradient(log_nodes) if log_nodes.size > 1 else np.ones(1)
        log_mass = temperature * self.log_likelihoods[k] + self.log_prior[k] + np.log(widths)
        if not np.isfinite(log_mass).any():
            raise ValueError(f"primitive {k} does not explain the observation")
        mass = np.exp(log_mass - np.max(log_mass))
        return alphas, mass / mass.sum()


def label_noise(model: ProMPModel) -> float:
    """``epsilon = 1 / (N + 2)``, N the model's training demonstrations (module docstring)."""
    return 1.0 / (sum(p.n_demos for p in model.primitives) + 2.0)


def with_label_noise(probabilities: np.ndarray, epsilon: float) -> np.ndarray:
    """``(1 - epsilon) p + epsilon / K`` along the last axis (K its length)."""
    k = probabilities.shape[-1]
    return (1.0 - epsilon) * probabilities + epsilon / k


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


def quadrature(
    model: ProMPModel, obs: Observation, prior: AlphaPrior
) -> tuple[np.ndarray, np.ndarray, float]:
    """The coarse quadrature in log alpha: :data:`N_NODES` nodes over the prior's central mass,
    truncated at the longest possible alpha (:func:`anchored_nodes`), their log prior
    densities, and the log of the prior mass below that bound."""
    bound = math.log(longest_alpha(model, obs))
    nodes = anchored_nodes(prior, bound)
    return nodes, prior.logpdf(nodes), prior.logcdf(bound)


def anchored_nodes(prior: AlphaPrior, bound: float) -> np.ndarray:
    """The coarse nodes (log alpha) of ``prior`` truncated at ``bound``: :data:`N_NODES` equally
    spaced over its central mass while the bound lies beyond it; past that, the nodes of the
    same lattice below the bound (more than half a step below it), and the bound itself.

    The lattice does not move with the bound (nodes are dropped, never shifted), so as an
    observation grows only the node at the bound is new: the likelihood's sums of the others
    are kept from one update to the next (:mod:`promp.incremental`), where spreading the
    nodes over the truncated range made every node new at every sample. When every plausible
    speed ends too early (the bound below the central mass), the nodes are those of a lattice
    of the same origin and half the step below it, within ``4 max(scale)`` of the bound.
    """
    lo, hi = prior.span(math.inf)
    lattice = np.linspace(lo, hi, N_NODES)
    if bound >= hi:
        return lattice
    step = (hi - lo) / (N_NODES - 1)
    if bound <= lo:  # every plausible speed ends too early: the tail just below the bound
        step *= 0.5  # half the lattice's: as fine as the tail was
        floor = bound - 4.0 * max(prior.scales)
        k = np.arange(math.ceil((floor - lo) / step), 1)
        lattice = lo + k * step
        lattice = lattice[lattice >= floor]
    # the last gap between half a step and one and a half: the bound's weight steady
    below = lattice[lattice < bound - 0.5 * step]
    if below.size == 0:
        below = lattice[:1]
    return np.append(below, bound)


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
    fine = np.linspace(nodes[best] - step, nodes[best] + step, N_REFINE + 2)[1:-1]
    keep = (fine > nodes[0]) & (fine < nodes[-1])
    return fine[keep & ~np.isclose(fine, nodes[best], rtol=0, atol=1e-9)]

def _integrate(
    model: ProMPModel,
    primitive: Primitive,
    obs: Observation,
    prior: AlphaPrior,
    statistics: IncrementalStatistics | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Nodes (log alpha), their log-likelihoods and log prior densities, and the evidence."""
    nodes, lp, log_mass = quadrature(model, obs, prior)
    ll = log_likelihoods(model, primitive, obs, np.exp(nodes), statistics)
    fine = refined_nodes(nodes, int(np.argmax(ll + lp)))
    if fine.size:
        nodes = np.concatenate([nodes, fine])
        ll = np.concatenate([ll, log_likelihoods(model, primitive, obs, np.exp(fine), statistics)])
        lp = np.concatenate([lp, prior.logpdf(fine)])
        order = np.argsort(nodes)
        nodes, ll, lp = nodes[order], ll[order], lp[order]
    evidence = logsumexp(ll + quadrature_weights(nodes, lp, log_mass))
    return nodes, ll, lp, evidence


def recognise(
    model: ProMPModel,
    obs: Observation,
    alpha_method: AlphaMethod = "ml",
    duration: float | None = None,
    statistics: IncrementalStatistics | None = None,
) -> Recognition:
    """Recognise the primitive and its time modulation from an early observation.

    Every primitive k is scored by its evidence, the likelihood of Eq. 6 integrated over its
    speed prior (module docstring), ``p(y_o | k) = int N(y_o | Phi_o(alpha) mu_k(alpha),
    S_k(alpha)) p(alpha | k) d alpha``; the class posterior (a uniform prior over the
    primitives) carries the "none of these" hypothesis (:func:`with_label_noise`).

    Parameters
    ----------
    model : ProMPModel
    obs : Observation
    alpha_method : {"ml", "model"}
        The speed's prior: the primitive's training speeds, or half of it on the Eq. 7
        regression from the early displacement.
    duration : float, optional
        When the whole movement's duration is known (s; the evaluation's oracle row: how far
        a perfect estimate of the speed would take the method): every primitive is scored at
        the speed of that duration alone, and ``alpha_method`` is not used.
    statistics : IncrementalStatistics, optional
        For an observation that grows, what the likelihood kept of its first samples
        (:mod:`promp.incremental`): the same recognition to round-off, at a cost that does not
        grow with the observation's length.

    Returns
    -------
    Recognition
        ``index``/``primitive`` recognised, ``probabilities`` (n_primitives,), ``alpha`` (its
        posterior mode), and per primitive the nodes, log-likelihoods and log prior of the
        quadrature.

    Raises
    ------
    ValueError
        Unknown modality or alpha method, an empty or non-finite observation, a duration
        shorter than the observation.
    """
    check_observation(model, obs)
    if alpha_method not in ALPHA_METHODS:
        raise ValueError(f"alpha_method must be one of {ALPHA_METHODS}, got {alpha_method!r}")
    if duration is not None:
        return _recognise_at(model, obs, float(duration), statistics)
    nodes, tables, priors = [], [], []
    evidence = np.empty(len(model.primitives))
    for k, prim in enumerate(model.primitives):
        x, ll, lp, evidence[k] = _integrate(
            model, prim, obs, alpha_prior(model, prim, obs, alpha_method), statistics
        )
        nodes.append(x)
        tables.append(ll)
        priors.append(lp)
    return _recognition(model, nodes, tables, priors, evidence, alpha_method)


def _recognition(
    model: ProMPModel,
    nodes: list[np.ndarray],
    tables: list[np.ndarray],
    priors: list[np.ndarray],
    evidence: np.ndarray,
    alpha_method: str,
) -> Recognition:
    if not np.isfinite(evidence).any():
        raise ValueError("no primitive explains the observation (every likelihood is zero)")
    probabilities = with_label_noise(np.exp(evidence - logsumexp(evidence)), label_noise(model))
    index = int(np.argmax(evidence))
    best = int(np.argmax(tables[index] + priors[index]))
    return Recognition(
        index=index,
        primitive=model.primitives[index].name,
        alpha=float(math.exp(nodes[index][best])),
        probabilities=probabilities,
        candidates=tuple(np.exp(x) for x in nodes),
        log_likelihoods=tuple(tables),
        log_prior=tuple(priors),
        log_evidence=evidence,
        alpha_method=alpha_method,
    )


def _recognise_at(
    model: ProMPModel,
    obs: Observation,
    duration: float,
    statistics: IncrementalStatistics | None = None,
) -> Recognition:
    """Every primitive scored at the speed of a known ``duration`` (seconds)."""
    if not math.isfinite(duration) or duration < obs.elapsed[-1] * (1.0 - 1e-9):
        raise ValueError(
            f"the duration ({duration} s) must be at least the observation's "
            f"({obs.elapsed[-1]:.3f} s)"
        )
    alpha = alpha_from_duration(max(duration, float(obs.elapsed[-1])), model.sample_period,
                                model.settings.s_bar)  # fmt: skip
    node = np.array([math.log(alpha)])
    tables = [log_likelihoods(model, prim, obs, np.exp(node), statistics)
              for prim in model.primitives]  # fmt: skip
    evidence = np.array([float(t[0]) for t in tables])
    zeros = [np.zeros(1) for _ in model.primitives]
    return _recognition(model, [node] * len(tables), tables, zeros, evidence, "duration given")
