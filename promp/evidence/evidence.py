"""The evidence of an observation under a model: one object that owns what the observation says
and answers every question asked of it (like a frozen distribution, or a Gaussian process's
posterior holding its factorisation).

:class:`Evidence` is built from a model and an observation (the first samples of a movement, in
any of the model's modalities). It holds the observed dimensions, the bound on the speeds that
still contain the observation, and the whitened sums of the samples at every candidate speed it
was asked about (:mod:`promp.evidence.sums`), kept so that the evidence of the same movement
observed longer (:meth:`Evidence.extended`) adds only the new samples' terms. From them it
answers:

* the likelihood of Eq. 6 at any speeds and noise levels (:meth:`Evidence.log_likelihoods`, in
  the cheaper of two exact forms: :mod:`promp.evidence.woodbury`,
  :mod:`promp.evidence.weight_space`);
* the recognition (:attr:`Evidence.recognition`): every primitive's likelihood integrated over
  its speed prior (:mod:`promp.evidence.speed`), the class posterior with the "none of these"
  hypothesis (:mod:`promp.recognition`);
* the timing (:attr:`Evidence.timing`): the duration and the observed share of the movement as
  a posterior (:mod:`promp.duration`), and the speed the predictions are drawn at;
* the posterior of the weights (Eq. 8, :meth:`Evidence.condition`, from the same sums), and
  with the via-points a user gives (:mod:`promp.via_points`) in one :meth:`Evidence.infer`: the
  :class:`Inference` that holds the recognition, the timing, the posterior, the prior and
  posterior predictions of every dimension, the region and future path of every position
  modality (:mod:`promp.region`), how far the prediction passes from each via-point, and, given
  the whole movement, the errors (:func:`promp.metrics.measure`).

The prediction is drawn at the speed whose duration is the posterior median of the recognised
primitive's duration (:mod:`promp.duration`), not at the posterior mode: the mode of a long
observation often sits at the shortest duration that still contains it, a movement ending now.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

import numpy as np

from promp.data import Demonstration
from promp.duration import Timing, timing, timing_of
from promp.evidence import mixture, weight_space, woodbury
from promp.evidence.classes import recognition_of
from promp.evidence.inference import PATH_POINTS, Inference
from promp.evidence.speed import (
    ALPHA_METHODS,
    AlphaPrior,
    alpha_prior,
    logsumexp,
    longest_alpha,
    quadrature,
    quadrature_weights,
    refined_nodes,
)
from promp.evidence.sums import KeptSums, ObservationSums
from promp.inference import (
    Gaussian,
    Posterior,
    condition_dense,
    observed_duration,
    predict,
)
from promp.metrics import measure
from promp.model import Primitive, ProMPModel, recognition_bandwidth
from promp.observation import Observation, check_observation
from promp.recognition import Recognition, speed_masses
from promp.timing import alpha_from_duration, check_alpha
from promp.via_points import ViaPoint, condition_on_via_points

__all__ = ["Evidence", "Integral"]


class Integral(NamedTuple):
    """A primitive's likelihood integrated over its speed prior (:meth:`Evidence.integral`):
    the quadrature's nodes (log alpha, increasing), their log-likelihoods and log prior
    densities, and the log-evidence."""

    nodes: np.ndarray
    log_likelihoods: np.ndarray
    log_prior: np.ndarray
    log_evidence: float


class Evidence:
    """What ``observation`` says under ``model`` (see the module docstring).

    Parameters
    ----------
    model : ProMPModel
    observation : Observation
        The first samples of the movement, in any of the model's modalities.
    alpha_method : {"ml", "model"}
        The speed's prior: each primitive's, fitted to its training speeds (``"ml"``), or half
        of it centred on the Eq. 7 regression from the early displacement (``"model"``).
    duration : float, optional
        The movement's duration when it is known (s; the evaluation's oracle row): every
        primitive is scored at the speed of that duration alone.

    Attributes
    ----------
    model, observation, alpha_method, duration
    dims : int array, shape (Do,)
        The model dimensions observed.
    elapsed : array, shape (n,)
        The observation's times from its first sample, seconds.

    Raises
    ------
    ValueError
        An unknown modality or alpha method, an observation whose columns do not match its
        modalities, a duration shorter than the observation.
    """

    def __init__(
        self,
        model: ProMPModel,
        observation: Observation,
        alpha_method: str = "ml",
        duration: float | None = None,
        *,
        _kept: KeptSums | None = None,
        _refined: dict[Primitive, np.ndarray] | None = None,
    ) -> None:
        self.dims = check_observation(model, observation)
        if alpha_method not in ALPHA_METHODS:
            raise ValueError(f"alpha_method must be one of {ALPHA_METHODS}, got {alpha_method!r}")
        self.elapsed = observation.elapsed
        if duration is not None:
            duration = float(duration)
            if not math.isfinite(duration) or duration < self.elapsed[-1] * (1.0 - 1e-9):
                raise ValueError(
                    f"the duration ({duration} s) must be at least the observation's "
                    f"({self.elapsed[-1]:.3f} s)"
                )
        self.model, self.observation = model, observation
        self.alpha_method, self.duration = alpha_method, duration
        self._bound = math.log(longest_alpha(model, observation))  # log alpha, the fastest
        self._sums = ObservationSums(model, observation, self.dims, _kept)
        self._forms: dict[Primitive, Callable[..., np.ndarray]] = {}  # likelihood forms
        # the refined nodes of each primitive: this evidence's (once its recognition is
        # computed), and those of the evidence it extends (read, never written)
        self._refined: dict[Primitive, np.ndarray] = {}
        self._refined_before = {} if _refined is None else _refined
        self._integrals: dict[int, Integral] = {}  # by primitive: computed or adopted
        self._timings: dict[int, Timing] = {}  # by primitive: its timing were it recognised
        self._posteriors: dict[int, Posterior] = {}  # the same, its conditioned weights
        self._drawn: dict[tuple[int, int | None], tuple] = {}  # (prior, posterior) predictions

    def extended(self, observation: Observation) -> Evidence:
        """The evidence of ``observation``: the same movement observed longer (this one's
        samples, then new ones). The sums this evidence computed are kept, and extended by the
        new samples' terms alone: the numbers of a new evidence to round-off, at a cost that
        grows with the new samples. Threads may extend one evidence at once. An observation
        that does not extend this one is an evidence computed from every sample."""
        return Evidence(self.model, observation, self.alpha_method, self.duration,
                        _kept=self._sums.kept, _refined=self._refined)  # fmt: skip

    @property
    def n_kept(self) -> int:
        """Candidate speeds whose sums are kept for the next :meth:`extended`."""
        return len(self._sums.kept)

    def log_likelihoods(
        self,
        primitive: Primitive,
        alphas: np.ndarray,
        noise_factors: np.ndarray | None = None,
    ) -> np.ndarray:
        """Log marginal likelihood of the observation under ``primitive`` (one of the
        model's) at each of ``alphas`` (Eq. 6).

        ``log N(y | A mu, S)`` with ``S = A Sigma_w A^T + R``, from the whitened sums, in the
        cheaper of two exact forms (:func:`promp.evidence.weight_space.cheaper_than_woodbury`):
        Woodbury's identity on the structure of ``Sigma_w`` (:mod:`promp.evidence.woodbury`)
        or weight space (:mod:`promp.evidence.weight_space`).

        Parameters
        ----------
        alphas : array, shape (A,)
        noise_factors : array, shape (L, n_dims), optional
            Each row multiplies the primitive's noise variance of every model dimension: the
            likelihood at L noise levels (what the choice of the noise scale reads).

        Returns
        -------
        array, shape (A,), or (L, A) with ``noise_factors``
            ``-inf`` where the candidate's duration is shorter than the observation.
        """
        alphas = np.atleast_1d(np.asarray(alphas, dtype=float))
        check_alpha(alphas)
        return self._log_likelihoods(primitive, alphas, noise_factors)

    def _log_likelihoods(
        self, primitive: Primitive, alphas: np.ndarray, noise_factors: np.ndarray | None = None
    ) -> np.ndarray:
        """:meth:`log_likelihoods` at ``alphas`` (A,) known to be positive and finite (the
        quadrature's nodes: checked once, by construction, rather than at every call)."""
        dims = self.dims
        durations, valid = self._durations(alphas)
        scaled = noise_factors is not None
        noise_var = primitive.noise_var[dims][None, :]
        if scaled:
            factors = np.atleast_2d(np.asarray(noise_factors, dtype=float))
            noise_var = noise_var * factors[:, dims]
        out = np.full((noise_var.shape[0], alphas.shape[0]), -np.inf)
        if valid.all():
            out[...] = self._form(primitive)(self._sums(primitive, alphas, durations),
                                             primitive, dims, noise_var)  # fmt: skip
        elif valid.any():
            sums = self._sums(primitive, alphas[valid], durations[valid])
            out[:, valid] = self._form(primitive)(sums, primitive, dims, noise_var)
        return out if scaled else out[0]

    def _durations(self, alphas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The duration of each speed of ``alphas`` (s; the arithmetic of
        :func:`promp.timing.duration_from_alpha`), and whether it contains the observation."""
        model = self.model
        durations = (model.settings.s_bar / alphas - 1.0) * model.sample_period
        return durations, self.elapsed[-1] <= durations * (1.0 + 1e-9)

    def _form(self, primitive: Primitive) -> Callable[..., np.ndarray]:
        """The ``log_likelihoods`` of the cheaper exact form of ``primitive``'s likelihood for
        the observed dimensions (:func:`promp.evidence.weight_space.cheaper_than_woodbury`),
        chosen once (the function kept, not its module: an evidence holds no module)."""
        form = self._forms.get(primitive)
        if form is None:
            u = primitive.observed_factor(self.dims)
            cheaper = weight_space.cheaper_than_woodbury(u.shape[0] * u.shape[1], u.shape[2])
            form = (weight_space if cheaper else woodbury).log_likelihoods
            self._forms[primitive] = form
        return form

    @functools.cached_property
    def recognition(self) -> Recognition:
        """Which primitive, at which speed: every primitive's evidence, its likelihood
        integrated over its speed prior (:mod:`promp.evidence.speed`: a quadrature on nodes in
        log alpha, refined around the best), the class posterior with the "none of these"
        hypothesis (:mod:`promp.recognition`); with a known
        duration, every primitive at that speed alone.

        Raises
        ------
        ValueError
            No primitive explains the observation (every likelihood is zero).
        """
        model = self.model
        if self.duration is not None:
            return self._recognition_at(self.duration)
        integrals = [self.integral(k) for k in range(len(model.primitives))]
        evidence = np.array([i.log_evidence for i in integrals], dtype=float)
        return recognition_of(model, [i.nodes for i in integrals],
                            [i.log_likelihoods for i in integrals],
                            [i.log_prior for i in integrals], evidence,
                            self.alpha_method)  # fmt: skip

    def integral(self, index: int) -> Integral:
        """Primitive ``index``'s likelihood integrated over its speed prior, the part of
        :attr:`recognition` that is the primitive's alone (computed once, or adopted)."""
        got = self._integrals.get(index)
        if got is None:
            primitive = self.model.primitives[index]
            prior = alpha_prior(self.model, primitive, self.observation, self.alpha_method)
            got = Integral(*self._integrate(primitive, prior))
            self._integrals[index] = got
        return got

    def adopt(self, integrals: Mapping[int, Integral]) -> None:
        """Take primitives' :meth:`integral` from another evidence of the same observation
        (another process's, :mod:`promp.live.helper`): :attr:`recognition` reads them
        instead of computing them. The numbers are the same when that evidence extended the
        same observations as this one (the same kept sums).

        Raises
        ------
        RuntimeError
            The recognition was already computed.
        """
        if "recognition" in self.__dict__:
            raise RuntimeError("the recognition is computed: adopt integrals before reading it")
        for index, integral in integrals.items():
            self._integrals[int(index)] = Integral(*integral)

    def prepare(self, index: int, n_points: int | None = None) -> bool:
        """Compute ahead what :meth:`infer` (``n_points``, without via-points) needs if
        primitive ``index`` is the one recognised: its timing, its conditioned weights and
        their predictions, from its :meth:`integral` alone, before the other primitives' are
        known (the live predictor does it while a helper process integrates the others).
        :meth:`infer` uses them when the recognition names ``index``; the same numbers as
        computed after it. False (nothing prepared) when the primitive does not explain the
        observation."""
        if not math.isfinite(self.integral(index).log_evidence):
            return False
        posterior = self._posterior_of(index)
        self._predictions(index, posterior, n_points)
        return True

    def _integrate(
        self, primitive: Primitive, prior: AlphaPrior
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """The quadrature of ``primitive``'s likelihood over its speed ``prior``: the nodes
        (log alpha, increasing), their log-likelihoods and log prior densities, and the
        log-evidence; with the mixture recognition, the mixture's
        (:func:`promp.evidence.mixture.integrate`)."""
        bandwidth = recognition_bandwidth(self.model.settings.recognition)
        if bandwidth < 1.0:
            table = functools.partial(self._components, primitive, bandwidth)
            return mixture.integrate(table, primitive, prior, self._bound, bandwidth)
        x, lp, log_mass = quadrature(prior, self._bound)  # (finite nodes: alphas > 0)
        # The refined nodes of the evidence this one extends are scored with the coarse ones:
        # the same nodes again while the best node stays (one call instead of two); those
        # that are not refined nodes now are left out.
        guess = self._refined_before.get(primitive, x[:0])
        guess = guess[(guess > x[0]) & (guess < x[-1])]
        scored = self._log_likelihoods(primitive, np.exp(np.concatenate([x, guess])))
        ll = scored[: x.shape[0]]
        known = dict(zip(guess.tolist(), scored[x.shape[0] :], strict=True))
        fine = refined_nodes(x, int(np.argmax(ll + lp)))
        self._refined[primitive] = fine
        if fine.size:
            missing = np.array([f not in known for f in fine.tolist()])
            fine_ll = np.empty(fine.shape[0])
            if missing.any():
                fine_ll[missing] = self._log_likelihoods(primitive, np.exp(fine[missing]))
            fine_ll[~missing] = [known[f] for f in fine[~missing].tolist()]
            x = np.concatenate([x, fine])
            ll = np.concatenate([ll, fine_ll])
            lp = np.concatenate([lp, prior.logpdf(fine)])
            order = np.argsort(x)
            x, ll, lp = x[order], ll[order], lp[order]
        return x, ll, lp, logsumexp(ll + quadrature_weights(x, lp, log_mass))

    def _components(self, primitive: Primitive, bandwidth: float, x: np.ndarray) -> np.ndarray:
        """Every mixture component's log-likelihood at nodes ``x`` (log alpha), (A, J)
        (:func:`promp.evidence.mixture.log_likelihoods`): ``-inf`` where the duration is
        shorter than the observation."""
        alphas = np.exp(x)
        durations, valid = self._durations(alphas)
        out = np.full((x.shape[0], primitive.residuals.shape[0]), -np.inf)
        if valid.any():
            sums = self._sums(primitive, alphas[valid], durations[valid])
            out[valid] = mixture.log_likelihoods(sums, primitive, self.dims,
                                                 primitive.noise_var[self.dims], bandwidth)
        return out

    def _recognition_at(self, duration: float) -> Recognition:
        """Every primitive scored at the speed of a known ``duration`` (seconds)."""
        model = self.model
        alpha = alpha_from_duration(max(duration, float(self.elapsed[-1])), model.sample_period,
                                    model.settings.s_bar)  # fmt: skip
        node = np.array([math.log(alpha)])
        tables = [self.log_likelihoods(p, np.exp(node)) for p in model.primitives]
        evidence = np.array([float(t[0]) for t in tables])
        zeros = [np.zeros(1) for _ in model.primitives]
        return recognition_of(model, [node] * len(tables), tables, zeros, evidence,
                            "duration given")  # fmt: skip

    @functools.cached_property
    def timing(self) -> Timing:
        """The recognised primitive's duration and observed share, with their intervals
        (:func:`promp.duration.timing`, the likelihood tempered by the model's
        ``duration_temperature``), and the speed of the predictions."""
        if self.duration is None:
            return self._timing_of(self.recognition.index)
        return self._timing_from(self.recognition)

    def _timing_from(self, recognition: Recognition) -> Timing:
        model, settings = self.model, self.model.settings
        return timing(recognition, float(self.elapsed[-1]), model.sample_period,
                      settings.s_bar, settings.duration_temperature or 1.0)  # fmt: skip

    def _timing_of(self, index: int) -> Timing:
        """The timing were primitive ``index`` recognised (:func:`promp.duration.timing_of`
        on its quadrature: the same as :meth:`timing` when it is the one recognised)."""
        got = self._timings.get(index)
        if got is None:
            i, model, settings = self.integral(index), self.model, self.model.settings
            alphas, temperature = np.exp(i.nodes), settings.duration_temperature or 1.0
            plain, tempered = (speed_masses(index, alphas, i.log_likelihoods, i.log_prior, tau)
                               for tau in (1.0, temperature))  # fmt: skip
            best = int(np.argmax(i.log_likelihoods + i.log_prior))
            got = self._timings[index] = timing_of(
                alphas, plain, tempered, float(math.exp(i.nodes[best])), float(self.elapsed[-1]),
                model.sample_period, settings.s_bar, temperature,
            )  # fmt: skip
        return got

    def condition(self, primitive: Primitive, alpha: float) -> Posterior:
        """The weights of ``primitive`` at speed ``alpha`` conditioned on the observation
        (Eq. 8), from the likelihood's own sums and terms (:func:`promp.evidence.woodbury.
        posterior`): the mean and each dimension's covariance block in O(D M^2 r), the full
        covariance on first use (the dense update, :func:`promp.inference.condition_dense`).

        Raises
        ------
        ValueError
            alpha <= 0, or an observation longer than alpha's duration.
        """
        model = self.model
        duration = observed_duration(model, self.observation, alpha)  # alpha checked
        # from every sample, neither read from nor kept for the speeds recognition scores:
        # the same numbers whichever process integrated the primitive (promp.live.helper)
        sums = self._sums.dense(primitive, np.array([float(alpha)]), np.array([duration]))
        mean, blocks = woodbury.posterior(sums, primitive, self.dims, alpha)

        def full() -> np.ndarray:
            prior = Gaussian(primitive.mean_at(alpha), primitive.cov)
            return condition_dense(model, primitive, self.observation, alpha, prior,
                                   primitive.cov_cholesky)[1]  # fmt: skip

        return Posterior(mean, blocks, full)

    @functools.cached_property
    def posterior(self) -> Posterior:
        """The recognised primitive's weights at the timing's speed given the observation."""
        if self.duration is None:
            return self._posterior_of(self.recognition.index)
        primitive = self.model.primitives[self.recognition.index]
        return self.condition(primitive, self.timing.alpha)

    def _posterior_of(self, index: int) -> Posterior:
        got = self._posteriors.get(index)
        if got is None:
            primitive = self.model.primitives[index]
            got = self._posteriors[index] = self.condition(primitive,
                                                           self._timing_of(index).alpha)
        return got

    def _predictions(self, index: int, posterior: Posterior, n_points: int | None) -> tuple:
        """Primitive ``index``'s prior and ``posterior``'s predictions at its timing's speed
        (kept by ``n_points``: ``posterior`` is the primitive's own, without via-points)."""
        got = self._drawn.get((index, n_points))
        if got is None:
            alpha = self._timing_of(index).alpha
            primitive = self.model.primitives[index]
            got = self._drawn[index, n_points] = (
                predict(self.model, primitive, alpha, n_points=n_points),
                predict(self.model, posterior, alpha, n_points=n_points))  # fmt: skip
        return got

    def infer(
        self,
        via_points: Sequence[ViaPoint] | Mapping[str, Sequence[ViaPoint]] = (),
        n_points: int | None = None,
        truth: Demonstration | None = None,
        path_points: int = PATH_POINTS,
    ) -> Inference:
        """Everything the evidence says about the rest of the movement, as an
        :class:`Inference`: the recognition, the timing, the posterior (conditioned on
        ``via_points`` as well, :func:`promp.via_points.condition_on_via_points`), the prior
        and posterior predictions of every dimension at the timing's speed, the positions'
        regions and futures, and with ``truth`` (the whole movement) the errors.

        Parameters
        ----------
        via_points : sequence of ViaPoint, or mapping of str to sequence of ViaPoint
            Points the prediction must pass through (a time is read at the timing's speed);
            by primitive: the recognised primitive's (none when it has none).
        n_points : int, optional
            Samples of the predictions and regions (default: the predicted number of samples).
        truth : Demonstration, optional
            The whole movement: the errors are measured against it.
        path_points : int
            Samples of each position's future path.
        """
        model, recognition, timing_ = self.model, self.recognition, self.timing
        alpha, posterior = timing_.alpha, self.posterior
        if isinstance(via_points, Mapping):
            via_points = via_points.get(recognition.primitive, ())
        vias = tuple(via_points)
        weights = condition_on_via_points(model, posterior, vias, alpha) if vias else posterior
        if vias or self.duration is not None:
            prior = predict(model, model.primitives[recognition.index], alpha, n_points=n_points)
            prediction = predict(model, weights, alpha, n_points=n_points)
        else:  # (kept: prepare may have drawn them)
            prior, prediction = self._predictions(recognition.index, posterior, n_points)
        natural, errors = None, None
        if truth is not None:
            plain = n_points is None and not vias
            natural = prediction if plain else predict(model, posterior, alpha)
            errors = measure(model, natural, timing_, truth, self.observation.n_observed)
        return Inference(model, self.observation, recognition, timing_, posterior, weights,
                         prior, prediction, vias, natural, errors, path_points)  # fmt: skip

