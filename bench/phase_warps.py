"""Does a time warp recognise earlier? The experiment behind issue 25's finding
(docs/evaluation.md, "Time warps: measured, not adopted"): leave-one-out recognition errors at
40 % observed (hand, speed integrated) on a lab set, for the uniform stretch the method uses and
for phase models that give the partner's timing more freedom, each learned on demonstrations
aligned to their primitive's mean.

* ``uniform``: every demonstration stretched to a common length; the speed integrated over a
  Gaussian prior in log duration (32 nodes), as the method does (with a Gaussian for the
  Student-t).
* ``oracle``: the same model told the test movement's true duration (no integral).
* ``warp J=...``: piecewise-linear warps with knots at phases ``j / J`` fitted per training
  demonstration by iterated alignment to its primitive's mean (Powell on the log segment
  fractions, a small penalty towards the uniform stretch), the ProMP learned on the aligned
  demonstrations, the log segment durations' Gaussian per primitive, and the recognition
  integrating over them on a grid along their two principal axes (16 x 5 nodes, +-3.5 sd).
* ``onset``: the still start cut off at learning (the first sample 5 % of the way to the
  largest displacement), the observation's phase ``max(0, t - onset) / T_move``, integrated
  over (onset, log T_move), a bivariate Gaussian per primitive (11 x 16 nodes).
* ``mixture``: one component per (primitive, person), the primitive's evidence their sum.

The warps are aligned once on every demonstration (the held-out one's primitive mean includes
it: a leak that favours the warps); the ProMPs are fitted without the held-out demonstration.
Settings given (by default M = 5, width 0.7, noise x1: the automatic choice on the whole
heights set). Run: ``.venv/bin/python bench/phase_warps.py [--set heights] [--percent 40]
[--basis M --width W --noise-scale X]`` (under a minute per set on two cores); the last line is
one JSON object.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from promp.data import Demonstration  # noqa: E402
from promp.datasets import read_dataset  # noqa: E402
from promp.evidence.weight_space import (  # noqa: E402
    cholesky_diagonals,
    diagonal_blocks,
    observed_precision,
)
from promp.fitting import fit_with  # noqa: E402
from promp.model import Settings  # noqa: E402
from promp.noise import noise_groups, whiten  # noqa: E402
from promp.observation import Observation  # noqa: E402
from promp.timing import alpha_from_duration, n_observed_for  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
SETTINGS = Settings(n_basis=5, width=0.7, noise_scale=1.0, duration_temperature=1.0,
                    recognition="promp")
GRID = np.linspace(0.0, 1.0, 101)


def log_likelihoods(model, prim, obs, phases, alphas):
    """Eq. 6 at arbitrary observed phases (A, n) (promp.evidence.weight_space's form)."""
    dims = model.layout.dims(obs.modalities)
    m, n_do = model.basis.n_basis, dims.shape[0]
    p, a = n_do * m, phases.shape[0]
    psi = model.basis(phases.reshape(-1)).reshape(a, -1, m)
    mu = prim.mean_at(alphas).reshape(a, model.n_dims, m)[:, dims]
    gram, proj = np.empty((a, n_do, m, m)), np.empty((a, n_do, m))
    rr, logdet_k = np.empty((a, n_do)), np.empty(n_do)
    for tau, cols in noise_groups(prim, dims).items():
        psi_w, logdet = whiten(obs.elapsed, tau, psi)
        y_w, _ = whiten(obs.elapsed, tau, obs.values[:, cols])
        resid = y_w[None] - psi_w @ mu[:, cols].transpose(0, 2, 1)
        gram[:, cols] = (psi_w.transpose(0, 2, 1) @ psi_w)[:, None]
        proj[:, cols] = (psi_w.transpose(0, 2, 1) @ resid).transpose(0, 2, 1)
        rr[:, cols], logdet_k[cols] = (resid**2).sum(1), logdet
    precision, logdet_sigma = observed_precision(prim, dims)
    s2 = prim.noise_var[dims]
    bordered = np.empty((a, p + 1, p + 1))
    bordered[...] = precision
    diagonal_blocks(bordered, n_do, m)[...] += (1.0 / s2)[None, :, None, None] * gram
    b = (proj / s2[None, :, None]).reshape(a, p)
    bordered[:, :p, p], bordered[:, p, :p] = b, b
    bordered[:, p, p] = rr @ (1.0 / s2) + 1.0
    diag = cholesky_diagonals(bordered)
    logdet = 2.0 * np.log(diag[:, :p]).sum(-1) + logdet_sigma
    logdet_r = (obs.n_observed * np.log(s2) + logdet_k).sum()
    constant = obs.values.size * math.log(2 * math.pi)
    return -0.5 * (diag[:, p] ** 2 - 1.0 + logdet + logdet_r + constant)


def warp(fractions, tau, knots):
    """Phase at normalised time ``tau`` of a piecewise-linear warp (segment fractions)."""
    times = np.concatenate([[0.0], np.cumsum(fractions)])
    times[-1] = 1.0
    return np.interp(tau, times, knots)


def resample(values, tau, fractions, knots):
    z = warp(fractions, tau, knots)
    return np.column_stack([np.interp(GRID, z, column) for column in values.T])


def align(demos, knots, iterations=4, penalty=0.02):
    """Each demonstration's segment fractions, aligned to its primitive's mean by turns."""
    base = np.diff(knots)
    data = [((t - t[0]) / (t[-1] - t[0]), v) for t, v in demos]
    fractions = [base.copy() for _ in data]
    for _ in range(iterations):
        mean = np.mean(
            [resample(v, tau, f, knots) for (tau, v), f in zip(data, fractions, strict=True)], 0
        )
        scale = np.mean(np.var(np.concatenate([v for _, v in data]), axis=0))
        new = []
        for (tau, v), f in zip(data, fractions, strict=True):

            def cost(x, tau=tau, v=v, mean=mean, scale=scale):
                g = np.exp(np.r_[x, 0.0]) * base
                g /= g.sum()
                r = resample(v, tau, g, knots) - mean
                return np.mean(r**2) / scale + penalty * np.mean(np.log(g / base) ** 2)

            x0 = np.log(f[:-1] / base[:-1]) - np.log(f[-1] / base[-1])
            res = minimize(cost, x0, method="Powell", options={"xtol": 1e-3, "maxfev": 3000})
            g = np.exp(np.r_[res.x, 0.0]) * base
            new.append(g / g.sum())
        fractions = new
    return fractions


def gaussian_grid(mean, cov, sizes, span=3.5):
    """Nodes along the leading principal axes of a Gaussian, and their log weights."""
    w, v = np.linalg.eigh(cov)
    order = np.argsort(w)[::-1]
    w, v = np.maximum(w[order], 1e-12), v[:, order]
    axes = [np.linspace(-span, span, s) if s > 1 else np.zeros(1) for s in sizes]
    q = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(sizes))
    nodes = mean + q @ (v[:, : len(sizes)] * np.sqrt(w[: len(sizes)])).T
    log_w = -0.5 * (q**2).sum(1)
    return nodes, log_w - np.logaddexp.reduce(log_w)


def evidence(model, prim, obs, phases, durations, log_w, dt):
    ok = durations >= obs.elapsed[-1]
    ll = np.full(durations.shape[0], -np.inf)
    alphas = np.array([alpha_from_duration(t, dt, SETTINGS.s_bar) for t in durations])
    if ok.any():
        ll[ok] = log_likelihoods(model, prim, obs, phases[ok], alphas[ok])
    return float(np.logaddexp.reduce(ll + log_w))


def errors(read, percent, kind, J=1):
    layout, names = read.layout, list(read.dataset)
    dt = float(np.median([d.sample_period for v in read.dataset.values() for d in v]))
    knots = np.linspace(0.0, 1.0, J + 1)
    frac = {}
    if kind == "warp":
        frac = {
            c: align([(d.times, layout.extract(d)) for d in read.dataset[c]], knots) for c in names
        }
    onsets = {}
    if kind == "onset":
        for c, demos in read.dataset.items():
            onsets[c] = []
            for d in demos:
                v = layout.extract(d)
                disp = np.linalg.norm(v - v[0], axis=1)
                i = int(np.argmax(disp > 0.05 * disp.max()))
                onsets[c].append(d.times[max(i - 1, 0)] - d.times[0])

    def trained(c, j):
        out = {}
        for k, demos in read.dataset.items():
            kept = []
            for i, d in enumerate(demos):
                if k == c and i == j:
                    continue
                t = d.times - d.times[0]
                if kind == "warp":
                    t = warp(frac[k][i], t / t[-1], knots) * t[-1]
                    kept.append(Demonstration(d.times[0] + t, d.values, d.columns, name=d.name))
                elif kind == "onset":
                    keep = t >= onsets[k][i] - 1e-9
                    kept.append(Demonstration(d.times[keep], d.values[keep], d.columns, d.name))
                else:
                    kept.append(d)
            if kind == "mixture":
                for d in kept:
                    out.setdefault(f"{k}|{d.name.split('/')[0]}", []).append(d)
            else:
                out[k] = kept
        return out

    wrong = 0
    for c in names:
        for j, test in enumerate(read.dataset[c]):
            model = fit_with(trained(c, j), layout, SETTINGS, dt, alpha_models=False)
            obs = Observation.from_demo(model, test, n_observed_for(percent, test.n_samples),
                                        (layout.names[0],))  # fmt: skip
            scores = {}
            for name, prim in zip(model.names, model.primitives, strict=True):
                k = name.split("|")[0]
                others = [i for i in range(len(read.dataset[k])) if not (k == c and i == j)]
                if kind == "oracle":
                    durations = np.array([test.duration])
                    phases = obs.elapsed[None] / durations[:, None]
                    log_w = np.zeros(1)
                elif kind == "warp":
                    x = np.array([np.log(frac[k][i] * read.dataset[k][i].duration) for i in others])
                    cov = np.cov(x.T) * (1 + 1 / len(x)) + 1e-6 * np.eye(J)
                    nodes, log_w = gaussian_grid(x.mean(0), cov, (16, 5))
                    times = np.c_[np.zeros(len(nodes)), np.cumsum(np.exp(nodes), 1)]
                    durations = times[:, -1]
                    phases = np.stack([np.interp(obs.elapsed, t, knots) for t in times])
                elif kind == "onset":
                    x = np.array([[onsets[k][i], np.log(read.dataset[k][i].duration - onsets[k][i])]
                                  for i in others])  # fmt: skip
                    cov = np.cov(x.T) * (1 + 1 / len(x)) + 1e-8 * np.eye(2)
                    nodes, log_w = gaussian_grid(x.mean(0), cov, (11, 16))
                    start, move = nodes[:, 0], np.exp(nodes[:, 1])
                    durations = start + move
                    phases = np.clip((obs.elapsed[None] - start[:, None]) / move[:, None], 0, None)
                    durations = np.where(start >= -0.2, durations, 0.0)
                else:  # uniform, mixture: the log duration
                    if kind == "mixture":
                        x = np.log([d.duration for d in prim_demos(model, name, read, c, j)])
                    else:
                        x = np.log([read.dataset[k][i].duration for i in others])
                    q = np.linspace(-3.5, 3.5, 32)
                    durations = np.exp(x.mean() + x.std(ddof=1) * math.sqrt(1 + 1 / len(x)) * q)
                    log_w = -0.5 * q**2 - np.logaddexp.reduce(-0.5 * q**2)
                    phases = obs.elapsed[None] / durations[:, None]
                e = evidence(model, prim, obs, phases, durations, log_w, dt)
                if kind == "mixture":
                    e += math.log(prim.n_demos)
                scores[k] = np.logaddexp(scores.get(k, -np.inf), e)
            wrong += max(scores, key=scores.get) != c
    return wrong


def prim_demos(model, name, read, c, j):
    k, person = name.split("|")
    return [d for i, d in enumerate(read.dataset[k])
            if d.name.split("/")[0] == person and not (k == c and i == j)]  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", default="heights")
    parser.add_argument("--percent", type=float, default=40.0)
    parser.add_argument("--basis", type=int, default=5)
    parser.add_argument("--width", type=float, default=0.7)
    parser.add_argument("--noise-scale", type=float, default=1.0)
    args = parser.parse_args()
    global SETTINGS
    SETTINGS = Settings(n_basis=args.basis, width=args.width, noise_scale=args.noise_scale,
                        duration_temperature=1.0, recognition="promp")  # fmt: skip
    read = read_dataset(SHARED / f"lab-records-{args.set}", "records")
    n = sum(len(v) for v in read.dataset.values())
    runs = [("uniform", "uniform", 1), ("oracle (true duration)", "oracle", 1)]
    runs += [(f"warp J={j}", "warp", j) for j in (2, 4)] + [("onset", "onset", 1)]
    if all("/" in d.name for v in read.dataset.values() for d in v):
        runs.append(("mixture per person", "mixture", 1))
    out = {}
    for label, kind, j in runs:
        start = time.perf_counter()
        out[label] = errors(read, args.percent, kind, j)
        print(f"{label:24s} {out[label]:4d}/{n} errors  ({time.perf_counter() - start:.0f} s)",
              flush=True)  # fmt: skip
    print(json.dumps({"set": args.set, "percent": args.percent, "trials": n, "errors": out}))


if __name__ == "__main__":
    main()
