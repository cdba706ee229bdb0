"""How much of the demonstrations the studio's tubes hold: the share of every primitive's hand
samples inside its drawn 90 % region, each sample at its own phase t / T, on a dataset (by
default the three shared sets and the default workspace), beside what other choices of the
region would hold. The demonstrations the checks flag are left out, as the evaluation leaves
them out (``--include-flagged`` keeps them).

The region drawn (:mod:`promp.region`): at each phase the ellipsoid
``(y - m)^T S^-1 (y - m) <= c^2 chi2_3(0.9)`` of a new demonstration's hand sample, ``S`` the
model's covariance of the weights over every speed (``Sigma_w + v_a s s^T``) through the basis,
plus the samples' noise (the fit residuals' variance), ``c`` the primitive's calibrated factor
(:mod:`promp.region_calibration`, chosen by the fit from its demonstrations left out in turn).
Columns:

* ``drawn``: that region, the model fitted on every demonstration (what Teach reports);
* ``held out``: each demonstration against the model fitted without it (the same settings):
  what the region says of a new demonstration. Nested: that model's factor was chosen without
  the demonstration too;
* ``scale``: the factor ``c`` of the model fitted on every demonstration;
* ``Gaussian``, ``Gaussian held out``: the same without the factor (``c = 1``, the region
  drawn before it);
* ``one speed``: ``Sigma_w`` alone (the covariance at the typical speed, no spread of speeds);
* ``scaled noise``: with the model's noise, which carries the recognition's ``noise_scale``;
* ``own``, ``own held out``: each primitive's own sample covariance of its weights (no prior
  pooled across primitives), over its speeds, inflated by ``1 + 1/n`` like the model's;
* ``±2σ axes``: the old tube's idea, every axis within 2 standard deviations of the movement
  (no noise, typical speed).

Run: ``.venv/bin/python bench/tube_coverage.py`` (a few minutes), or on one dataset as
``python -m promp.evaluate`` reads it: ``.venv/bin/python bench/tube_coverage.py FOLDER --format
records`` (its ``--modality``, rig and check options too). The last line is one JSON object: the
``drawn``, ``held out`` and ``Gaussian held out`` shares and the factor per set and primitive.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from promp.data import sample_period_of  # noqa: E402
from promp.evaluate.cli import add_check_arguments, add_dataset_arguments, load  # noqa: E402
from promp.fitting import fit_with  # noqa: E402
from promp.inference import Gaussian  # noqa: E402
from promp.learn import fit  # noqa: E402
from promp.quality import winsorized  # noqa: E402
from promp.region import (  # noqa: E402
    new_movement,
    region_radius,
    region_scale,
    sample_distribution,
    sample_noise_var,
)
from promp.timing import demo_phases  # noqa: E402
from promp.weights import fit_all_weights  # noqa: E402
from robots.icub.layout import STUDIO_LAYOUT  # noqa: E402
from robots.icub.scenario import generate_scenario  # noqa: E402

SHARED = ROOT.parent / "shared" / "data"
SETS = ("lab-records-heights", "lab-records-flt", "lab-records-flt-shapes", "default workspace")
PROBABILITY = 0.9
Q = region_radius(PROBABILITY, 3) ** 2


def parser() -> argparse.ArgumentParser:
    out = argparse.ArgumentParser(
        prog="bench/tube_coverage.py", description=__doc__.split("\n\n")[0]
    )
    add_dataset_arguments(out)
    add_check_arguments(out)
    return out


def read(argv: list[str]):
    """The demonstrations (flagged ones left out unless --include-flagged) and their layout."""
    if argv == ["default workspace"]:
        return {k: list(v) for k, v in generate_scenario(seed=0, n_demos=20).items()}, STUDIO_LAYOUT
    args = parser().parse_args(argv)
    args.observe = None
    loaded = load(args)
    for (prim, demo), findings in sorted(loaded.excluded.items()):
        print(f"  left out {prim}/{demo}: {findings[0].message}", flush=True)
    return {k: list(v) for k, v in loaded.dataset.items()}, loaded.layout


def own_movement(model, demos, prim) -> Gaussian:
    """The primitive's own sample covariance (residuals of the regression on log alpha, as the
    model's), over its speeds, inflated by 1 + 1/n; the model's mean."""
    weights = np.array(fit_all_weights(model.settings.basis, demos, model.layout,
                                       model.settings.ridge).weights)  # fmt: skip
    logs = winsorized(np.log(prim.alphas))
    x = np.column_stack([np.ones_like(logs), logs - logs.mean()])
    beta, *_ = np.linalg.lstsq(x, weights, rcond=None)
    resid = weights - x @ beta
    n = weights.shape[0]
    cov = resid.T @ resid / max(n - 2, 1) * (1.0 + 1.0 / n)
    cov = cov + np.var(logs, ddof=1) * np.outer(beta[1], beta[1])
    return Gaussian(np.array(prim.mean), cov)


def inside(model, dist, demos, noise, axes: bool = False, scale: float = 1.0) -> tuple[int, int]:
    dims = model.layout.dims(["hand"])
    count = total = 0
    for demo in demos:
        region = sample_distribution(model, dist, dims, demo_phases(demo.times), noise, scale)
        points = model.layout.extract(demo)[:, dims]
        if axes:  # every axis within 2 sd
            sd = np.sqrt(np.diagonal(region.cov, axis1=1, axis2=2))
            hit = np.all(np.abs(points - region.mean) <= 2.0 * sd, axis=1)
        else:
            hit = region.squared_distances(points) <= Q
        count += int(hit.sum())
        total += int(hit.shape[0])
    return count, total


def measure(name: str, argv: list[str]) -> dict:
    print(f"\n{name}", flush=True)
    dataset, layout = read(argv)
    start = time.perf_counter()
    model = fit(dataset, layout)
    dt = sample_period_of([d for demos in dataset.values() for d in demos])
    rows = {}
    for prim in model.primitives:
        demos = dataset[prim.name]
        noise = sample_noise_var(model, prim)
        one_speed = Gaussian(np.array(prim.mean), prim.cov)
        scale = region_scale(prim, "hand")
        shares = {
            "drawn": inside(model, new_movement(prim), demos, noise, scale=scale),
            "Gaussian": inside(model, new_movement(prim), demos, noise),
            "one speed": inside(model, one_speed, demos, noise),
            "scaled noise": inside(model, new_movement(prim), demos, prim.noise_var),
            "own": inside(model, own_movement(model, demos, prim), demos, noise),
            "±2σ axes": inside(model, one_speed, demos, None, axes=True),
        }
        held, gauss_held, own_held = [0, 0], [0, 0], [0, 0]
        for j, demo in enumerate(demos):
            others = demos[:j] + demos[j + 1 :]
            refit = fit_with({**dataset, prim.name: others}, layout, model.settings, dt,
                             alpha_models=False)  # fmt: skip
            p = refit.primitive(prim.name)
            n_noise = sample_noise_var(refit, p)
            for acc, dist, c_j in (
                (held, new_movement(p), region_scale(p, "hand")),
                (gauss_held, new_movement(p), 1.0),
                (own_held, own_movement(refit, others, p), 1.0),
            ):
                c, t = inside(refit, dist, [demo], n_noise, scale=c_j)
                acc[0] += c
                acc[1] += t
        shares["held out"] = tuple(held)
        shares["Gaussian held out"] = tuple(gauss_held)
        shares["own held out"] = tuple(own_held)
        rows[prim.name] = {k: c / t for k, (c, t) in shares.items()}
        rows[prim.name]["demos"] = len(demos)
        rows[prim.name]["scale"] = scale
    print(f"  ({time.perf_counter() - start:.0f} s; basis {model.settings.n_basis}, "
          f"noise scale {model.settings.noise_scale:g})", flush=True)  # fmt: skip
    columns = ("drawn", "held out", "Gaussian", "Gaussian held out", "one speed", "scaled noise",
               "own", "own held out", "±2σ axes")  # fmt: skip
    print(f"  {'primitive':<12}{'demos':>6}{'scale':>7}" + "".join(f"{c:>19}" for c in columns))
    for prim_name, row in rows.items():
        print(f"  {prim_name:<12}{row['demos']:>6}{row['scale']:>7.2f}"
              + "".join(f"{100 * row[c]:>18.1f}%" for c in columns))  # fmt: skip
    return rows


def main(argv: list[str]) -> None:
    load_average = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"share of the hand samples inside the {PROBABILITY:.0%} region, at their own phase "
          f"(load average {load_average})")  # fmt: skip
    if argv:
        runs = {str(argv[0]): argv}
    else:
        runs = {name: [str(SHARED / name), "--format", "records"] for name in SETS[:-1]
                if (SHARED / name).is_dir()}  # fmt: skip
        runs[SETS[-1]] = [SETS[-1]]
    results = {name: measure(name, args) for name, args in runs.items()}
    summary = {
        name: {p: {"drawn": round(r["drawn"], 3), "held_out": round(r["held out"], 3),
                   "gaussian_held_out": round(r["Gaussian held out"], 3),
                   "scale": round(r["scale"], 3)}
               for p, r in rows.items()}
        for name, rows in results.items()
    }  # fmt: skip
    print(json.dumps({"probability": PROBABILITY, "shares": summary}))


if __name__ == "__main__":
    main(sys.argv[1:])
