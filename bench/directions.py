"""Issue 37's directions (i) and (iii), measured beside the method: does scoring each primitive
another way recognise earlier? The experiment behind docs/evaluation.md, "Directions (i) and
(iii) measured".

Every variant runs through the evaluation's own leave-one-out sweep
(:func:`promp.evaluate.sweep.run_sweep`: the same folds, observations and metrics as ``python -m
promp.evaluate``), each fold fitted once with the automatic settings (as ``--method ours``) and
shared by the variants; the flagged takes left out (as the evaluation leaves them out); the
position modality observed (the hand on the lab sets), the speed integrated (``--alpha ml``).
A variant changes one thing: the evidence ``p(y | k)`` of each primitive (and with the mixture
the speed posterior); the class probabilities (with the "none of these" hypothesis), the
conditioning and the prediction are the engine's.

* ``promp``: the engine as it is (``--method ours``; a check that the harness is the CLI's).
* ``mixture:H``: each primitive the mixture of its training demonstrations, each a component
  shrunk towards the primitive (kernel shrinkage, West 1993; Liu & West 2001): weights
  ``N(mu(alpha) + sqrt(1 - H^2) e_j, H^2 Sigma_w)`` (``e_j`` the demonstration's residual from
  the regression on log alpha), log speed a Student-t centred ``sqrt(1 - H^2)`` of the way from
  the prior's centre to the demonstration's own, ``H`` times as wide; each component integrated
  over its speed on the primitive's quadrature (refined around the best node), the evidence the
  components' average. ``H = 1`` is the ProMP exactly; as ``H`` falls each demonstration
  becomes a template at its own speed with the ProMP's noise.
* ``ebip:Q``: ensemble Bayesian interaction primitives (Campbell & Ben Amor, RSS 2019): per
  primitive an ensemble over (phase, log phase velocity, weights), drawn from its training
  demonstrations (their own weights and speeds, jittered by ``0.5^2 Sigma_w`` and half the
  spread of their log durations), filtered through the observation by an ensemble Kalman filter
  with perturbed observations (an update every 0.05 s and at the last sample; the log velocity
  a random walk of ``Q`` per square root of a second; the noise the primitive's variances,
  without its correlation); the evidence the accumulated innovation log-likelihood. Its speed
  posterior (hence the prediction's duration) stays the ProMP's. 120 members, seeded: the run
  is reproducible.
* ``start:B``: issue 37's direction (ii), the first sample's evidence tempered: each node's
  log-likelihood less ``(1 - B) log p(y_0 | k, alpha)`` (the first sample's marginal under the
  primitive, its observed dimensions jointly). ``B = 1`` is the ProMP, ``B = 0`` the rest of
  the observation conditioned on its start.

Run: ``.venv/bin/python bench/directions.py --set heights [--percent 20 40 60 80]
[--variant promp mixture:0.5 ebip:1] [--jobs 1]`` (about a minute per variant on a shared set,
two cores). The last line is one JSON object: per variant and percentage, errors, log-loss and
position error of the remainder (cm).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from promp.datasets import read_dataset  # noqa: E402
from promp.evaluate.methods import ProMPEngine  # noqa: E402
from promp.evaluate.sweep import position_modality, run_sweep  # noqa: E402
from promp.evidence import Evidence  # noqa: E402
from promp.evidence.speed import logsumexp, quadrature, quadrature_weights  # noqa: E402
from promp.fitting import fit_parts  # noqa: E402
from promp.model import Settings  # noqa: E402
from promp.observation import check_observation  # noqa: E402
from promp.quality import split_flagged  # noqa: E402
from promp.timing import duration_from_alpha  # noqa: E402

SHARED = ROOT.parent / "shared" / "data"
ENSEMBLE, STEP, JITTER = 120, 0.05, 0.5
_FIT: dict = {}  # the last fold's fit, shared by the variants of that fold


def _fitted(engine: ProMPEngine, dataset, dt: float, chosen=None):
    """The fold's model and each primitive's demonstrations' weights (fitted once per fold, at
    the settings ``chosen`` for its block: the same for every variant)."""
    key = (tuple((name, tuple(d.name for d in demos)) for name, demos in dataset.items()),
           repr(chosen))  # fmt: skip
    if _FIT.get("key") != key:
        ProMPEngine.fit(engine, dataset, dt, chosen)
        model = engine.model
        _, parts = fit_parts(dataset, engine.layout, model.settings, dt, alpha_models=False)
        _FIT.clear()
        _FIT.update(key=key, model=model, parts=parts)
    return _FIT["model"], _FIT["parts"]


class Variant(ProMPEngine):
    """The engine with the evidence of every primitive computed by ``integrate``."""

    def __init__(self, layout, name: str):
        # the ProMP's settings chosen (the recognition given: every variant shares the fit)
        super().__init__(layout, Settings(recognition="promp"))
        self.name = name
        kind, _, value = name.partition(":")
        self.kind, self.value = kind, float(value) if value else None

    def fit(self, dataset, sample_period: float, chosen=None) -> None:
        self.model, parts = _fitted(self, dataset, sample_period, chosen)
        if self.kind == "mixture":  # the engine's own (promp.evidence.mixture)
            settings = replace(self.model.settings, recognition=self.name)
            self.model = replace(self.model, settings=settings)
        self.parts = {p.name: part for p, part in zip(self.model.primitives, parts, strict=True)}
        self._components: dict = {}
        self._ensembles: dict = {}

    def infer(self, demo, n_observed, observe, alpha_method):
        with self._scoring():
            return super().infer(demo, n_observed, observe, alpha_method)

    @contextlib.contextmanager
    def _scoring(self):
        if self.kind in ("promp", "mixture"):
            yield
            return
        original = Evidence._integrate

        def integrate(evidence, prim, prior):
            nodes, ll, lp, log_evidence = original(evidence, prim, prior)
            if self.kind == "start":  # direction (ii): the first sample's evidence tempered
                ll = ll - (1.0 - self.value) * _start_log_likelihood(evidence, prim, nodes)
                _, _, log_mass = quadrature(prior, evidence._bound)
                return nodes, ll, lp, logsumexp(ll + quadrature_weights(nodes, lp, log_mass))
            return nodes, ll, lp, self._ebip(evidence.model, prim, evidence.observation)

        Evidence._integrate = integrate
        try:
            yield
        finally:
            Evidence._integrate = original

    # -- direction (i): phase as a filtered state ------------------------------------------
    def _ensemble(self, model, prim, dims):
        key = (prim.name, tuple(dims))
        if key not in self._ensembles:
            rng = np.random.default_rng(0)
            m = model.basis.n_basis
            weights = self.parts[prim.name].weights
            n = weights.shape[0]
            pick = np.arange(ENSEMBLE) % n
            jitter = (rng.standard_normal((ENSEMBLE, prim.cov_factor.shape[1])) @ prim.cov_factor.T
                      + np.sqrt(prim.cov_diag) * rng.standard_normal((ENSEMBLE, weights.shape[1])))
            members = (weights[pick] + JITTER * jitter).reshape(ENSEMBLE, model.n_dims, m)
            durations = duration_from_alpha(prim.alphas, model.sample_period, model.settings.s_bar)
            spread = float(np.std(np.log(durations), ddof=1)) if n > 1 else 0.1
            log_speed = -np.log(durations[pick]) + JITTER * spread * rng.standard_normal(ENSEMBLE)
            self._ensembles[key] = np.concatenate(
                [np.zeros((ENSEMBLE, 1)), log_speed[:, None],
                 members[:, dims].reshape(ENSEMBLE, -1)],
                axis=1,
            )  # fmt: skip
        return self._ensembles[key].copy()

    def _ebip(self, model, prim, obs):
        dims = check_observation(model, obs)
        m, n_do = model.basis.n_basis, dims.shape[0]
        state = self._ensemble(model, prim, dims)
        rng = np.random.default_rng(1)
        noise = prim.noise_var[dims]
        t = obs.elapsed
        updates = [0]
        for i in range(1, t.shape[0]):
            if t[i] - t[updates[-1]] >= STEP - 1e-9:
                updates.append(i)
        if updates[-1] != t.shape[0] - 1:
            updates.append(t.shape[0] - 1)
        total, before, n = 0.0, 0.0, state.shape[0]
        for i in updates:
            gap, before = t[i] - before, t[i]
            if gap > 0:
                state[:, 1] += self.value * math.sqrt(gap) * rng.standard_normal(n)
                state[:, 0] += np.exp(state[:, 1]) * gap
            basis = model.basis(np.clip(state[:, 0], 0.0, 1.0))
            predicted = np.einsum("nm,ndm->nd", basis, state[:, 2:].reshape(n, n_do, m))
            d_y = predicted - predicted.mean(0)
            d_x = state - state.mean(0)
            cov = d_y.T @ d_y / (n - 1) + np.diag(noise)
            chol = np.linalg.cholesky(cov)
            z = np.linalg.solve(chol, obs.values[i] - predicted.mean(0))
            total += -0.5 * z @ z - np.log(np.diag(chol)).sum() - 0.5 * n_do * math.log(2 * math.pi)
            gain = np.linalg.solve(cov, (d_x.T @ d_y / (n - 1)).T).T
            perturbed = obs.values[i][None] + rng.standard_normal((n, n_do)) * np.sqrt(noise)
            state += (perturbed - predicted) @ gain.T
        return total


def _start_log_likelihood(evidence, prim, nodes: np.ndarray) -> np.ndarray:
    """``log p(y_0 | k, alpha)`` at the speeds ``exp(nodes)``: the first sample's marginal
    under the primitive (its observed dimensions jointly, the noise of one sample)."""
    model, obs = evidence.model, evidence.observation
    dims, m = evidence.dims, model.basis.n_basis
    psi0 = model.basis(np.zeros(1))[0]  # (M,)
    cols = (dims[:, None] * m + np.arange(m)).reshape(-1)
    lift = np.zeros((dims.shape[0], cols.shape[0]))
    for i in range(dims.shape[0]):
        lift[i, i * m:(i + 1) * m] = psi0
    mean = prim.mean_at(np.exp(nodes))[:, cols] @ lift.T  # (A, Do)
    cov = lift @ prim.cov[np.ix_(cols, cols)] @ lift.T + np.diag(prim.noise_var[dims])
    chol = np.linalg.cholesky(cov)
    z = np.linalg.solve(chol, (obs.values[0][None] - mean).T)  # (Do, A)
    return (-0.5 * (z * z).sum(0) - np.log(np.diag(chol)).sum()
            - 0.5 * dims.shape[0] * math.log(2 * math.pi))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--set", default="heights", help="a shared set's name or a folder")
    parser.add_argument("--format", default="records")
    parser.add_argument("--percent", type=float, nargs="+", default=[20, 40, 60, 80])
    parser.add_argument("--variant", nargs="+", default=["promp", "mixture:0.5", "ebip:1"])
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args(argv)
    for name in args.variant:
        kind, _, value = name.partition(":")
        try:
            number = float(value) if value else None
        except ValueError:
            number = math.nan
        if not ((kind == "promp" and number is None)
                or (kind == "mixture" and number is not None and 0.0 < number <= 1.0)
                or (kind == "ebip" and number is not None and 0.0 <= number < math.inf)
                or (kind == "start" and number is not None and 0.0 <= number <= 1.0)):
            parser.error(f"unknown variant {name!r}: promp, mixture:H (0 < H <= 1) or ebip:Q "
                         "(Q >= 0)")  # fmt: skip
    folder = Path(args.set) if Path(args.set).is_dir() else SHARED / f"lab-records-{args.set}"
    read = read_dataset(folder, args.format)
    dataset, _ = split_flagged(read.dataset, read.findings)  # left out, as the evaluation does
    factories = {name: (lambda name=name: Variant(read.layout, name)) for name in args.variant}
    start = time.perf_counter()
    observed = [position_modality(read.layout)]
    result = run_sweep(factories, dataset, read.layout, args.percent, ["ml"], [observed],
                       jobs=args.jobs)  # fmt: skip
    wall = time.perf_counter() - start
    table: dict = {}
    print(f"{folder.name}, {observed[0]} observed: errors / log-loss / position error (cm) at "
          f"{args.percent} %")
    for row in result.rows:
        cell = {"errors": int(row["recognition_errors"]),
                "log_loss": round(float(row["log_loss"]), 9),
                "position_cm": round(100 * float(row["position_error_m"]), 6)}  # fmt: skip
        table.setdefault(row["method"], {})[str(int(row["percent"]))] = cell
    for name, cells in table.items():
        print(f"  {name:14s} " + "  ".join(
            f"{c['errors']:3d} {c['log_loss']:.3f} {c['position_cm']:.2f}" for c in cells.values()))
    print(json.dumps({"set": folder.name, "wall_s": round(wall, 1), "table": table}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
