"""Figures of the evaluation (matplotlib, PNG), in the style of the paper's Figs. 4-11."""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from promp import metrics, units
from promp.data import Layout, Modality
from promp.datasets import Dataset
from promp.evaluate.decisions import Decisions, doubt_decades
from promp.evaluate.report import confusion_matrices, trial_rows
from promp.evaluate.sweep import SweepResult, Trial

__all__ = [
    "MAX_COLUMNS", "PLOTS_EXTRA", "column_units", "confusion_figure", "curves", "decision_figure",
    "display_unit", "example",
    "figures_unavailable", "grid", "group_series", "methods_of", "reliability_diagram",
    "series_label", "write_figures"
]  # fmt: skip

PLOTS_EXTRA = "pip install 'icub-intention-studio[plots]'"


def figures_unavailable() -> str:
    """Why the figures cannot be drawn here ('' when they can): matplotlib is the ``plots``
    extra of the package (``make run`` installs it), not a dependency of ``promp``."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return f"the figures need matplotlib, which is not installed here ({PLOTS_EXTRA})"
    return ""


def _figure(width: float, height: float):
    """A new figure of ``width`` x ``height`` inches, made without pyplot: pyplot keeps its
    figures in global state, a figure made by matplotlib's ``Figure`` is its caller's alone
    (matplotlib's advice for servers: the studio draws a run kept in the background while an
    export draws its own, at once)."""
    reason = figures_unavailable()
    if reason:
        raise ValueError(reason)
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height))


MAX_COLUMNS = 4  # panels per row of a figure: at 3.2 in and 100 dpi, at most 1,280 px wide


def display_unit(modality: Modality) -> tuple[float, str]:
    """What a modality's values are multiplied by to be shown as the studio shows them, and
    the unit then (:func:`promp.units.display_unit`: metres as cm, angles as degrees, anything
    else as it is)."""
    unit, scale = units.display_unit(modality.unit, modality.kind)
    return scale, unit


def column_units(layout: Layout) -> list[tuple[float, str]]:
    """:func:`display_unit` of every dimension of ``layout``."""
    return [display_unit(m) for m in layout.modalities for _ in m.columns]


def grid(n_panels: int, size: float = 3.2):
    """A figure of ``n_panels`` panels, at most :data:`MAX_COLUMNS` per row, ``size`` inches
    each; the unused ones hidden. Returns (figure, flat list of the used axes)."""
    columns = min(n_panels, MAX_COLUMNS)
    rows = -(-n_panels // columns)
    fig = _figure(size * columns, size * rows)
    axes = fig.subplots(rows, columns, squeeze=False)
    flat = list(axes.reshape(-1))
    for ax in flat[n_panels:]:
        ax.set_visible(False)
    return fig, flat[:n_panels]


def series_label(observed: Sequence[str], alpha_method: str, method: str = "") -> str:
    """The name of one curve, e.g. ``hand+head, alpha ml``, or with its method
    ``dtw: hand+head, alpha ml``."""
    label = f"{'+'.join(observed)}, alpha {alpha_method}"
    return f"{method}: {label}" if method else label


def methods_of(rows: Sequence[Mapping]) -> list[str]:
    """The methods of a sweep's rows (or trials' rows), in the order they first come."""
    return list(dict.fromkeys(str(r.get("method", "")) for r in rows))


def group_series(rows: Sequence[Mapping]) -> dict[str, list[Mapping]]:
    """The sweep's rows as one series per (method, observed modalities, alpha method), by
    :func:`series_label` (the method named only when the rows hold several): the methods in
    the sweep's order, then single modalities first, then larger sets, each set's alpha
    methods in name order; each series' rows by percent."""
    groups: dict[str, list[Mapping]] = defaultdict(list)
    methods = methods_of(rows)
    named = len(methods) > 1
    order = sorted(rows, key=lambda r: (methods.index(str(r.get("method", ""))),
                                        len(r["observed"]), "+".join(r["observed"]),
                                        r["alpha_method"], r["percent"]))  # fmt: skip
    for row in order:
        method = str(row.get("method", "")) if named else ""
        groups[series_label(row["observed"], row["alpha_method"], method)].append(row)
    return dict(groups)


def _series(
    rows: list[dict], value: Callable[[Mapping], float]
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """One curve per series of :func:`group_series`: (percents, values)."""
    return {
        label: (np.array([r["percent"] for r in group]), np.array([value(r) for r in group]))
        for label, group in group_series(rows).items()
    }


def curves(rows: list[dict], path: Path, method: str, position: Modality | None = None) -> None:
    """Recognition errors, position error (in ``position``'s display unit, cm by default) and
    NRMSE(posterior) - NRMSE(prior) against %."""
    scale, unit = display_unit(position) if position is not None else (100.0, "cm")
    fig = _figure(15, 4.2)
    axes = fig.subplots(1, 3)
    trials = rows[0]["trials"] if rows else 0
    for label, (x, y) in _series(rows, lambda r: r["recognition_errors"]).items():
        axes[0].plot(x, y, "o-", label=label)
    axes[0].set_ylabel(f"recognition errors (of {trials})")
    for label, (x, y) in _series(rows, lambda r: r["position_error_m"]).items():
        axes[1].plot(x, scale * y, "o-", label=label)
    axes[1].set_ylabel(f"position error of the remainder ({unit})")
    delta = _series(rows, lambda r: r["nrmse_posterior"] - r["nrmse_prior"])
    for label, (x, y) in delta.items():
        axes[2].plot(x, y, "o-", label=label)
    axes[2].axhline(0.0, color="k", lw=0.8)
    axes[2].set_ylabel("NRMSE posterior - prior")
    for ax, title in zip(
        axes,
        ("recognition (Figs. 6a, 11)", "trajectory (Figs. 6b, 8a, 10)", "update (6c, 8b)"),
        strict=True,
    ):
        ax.set_xlabel("% of the movement observed")
        ax.set_title(title)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"leave-one-out, method {method}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def reliability_diagram(trials: list[Trial], n_primitives: int, path: Path, method: str) -> None:
    """Predicted probability against observed frequency, per alpha method (all observed
    percentages together; a failed trial counts as a uniform guess), of the trials of
    ``method``."""
    fig = _figure(5.2, 5)
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
    for alpha_method in sorted({t.alpha_method for t in trials}):
        chosen = [t for t in trials if t.alpha_method == alpha_method]
        probabilities = np.array([
            t.inferred.probabilities if t.inferred is not None
            else np.full(n_primitives, 1.0 / n_primitives)
            for t in chosen
        ])  # fmt: skip
        truth = np.array([t.primitive for t in chosen])
        forecast, frequency, count = metrics.reliability(probabilities, truth)
        used = count > 0
        ece = metrics.calibration_error(forecast, frequency, count)
        ax.plot(
            forecast[used], frequency[used], "o-",
            label=f"alpha {alpha_method} (calibration error {ece:.3f})",
        )  # fmt: skip
        for x, y, n in zip(forecast[used], frequency[used], count[used], strict=True):
            ax.annotate(str(n), (x, y), fontsize=6, xytext=(3, -8), textcoords="offset points")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_xlabel("predicted probability of a primitive")
    ax.set_ylabel("observed frequency (numbers: forecasts per bin)")
    ax.set_title(f"reliability of the recognition, method {method}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def example(trial: Trial, dataset: Dataset, layout: Layout, path: Path) -> None:
    """One inference like Figs. 4, 7, 9: observed samples, prior and posterior bands, truth."""
    names = list(dataset)  # demo names repeat across primitives: look in the right one
    demo = next(d for d in dataset[names[trial.primitive]] if d.name == trial.demo)
    truth = layout.extract(demo)
    t_true = demo.times - demo.times[0]
    n_obs = max(1, int(np.ceil(trial.percent / 100 * demo.n_samples - 1e-9)))
    inf = trial.inferred
    t_pred = np.linspace(0.0, inf.duration, inf.posterior_mean.shape[0])
    observed = set(layout.dims(trial.observed).tolist())
    fig, axes = grid(layout.n_dims)
    for d, (ax, (scale, unit)) in enumerate(zip(axes, column_units(layout), strict=True)):
        for mean, std, colour, alpha, label in (
            (inf.prior_mean, inf.prior_std, "tab:blue", 0.2, "prior +-2 sd"),
            (inf.posterior_mean, inf.posterior_std, "tab:red", 0.25, "posterior +-2 sd"),
        ):
            ax.fill_between(t_pred, scale * (mean[:, d] - 2 * std[:, d]),
                            scale * (mean[:, d] + 2 * std[:, d]), color=colour, alpha=alpha,
                            label=label)  # fmt: skip
        ax.plot(t_pred, scale * inf.posterior_mean[:, d], color="tab:red", lw=1.5)
        ax.plot(t_true, scale * truth[:, d], "k--", lw=1, label="truth")
        if d in observed:
            ax.plot(t_true[:n_obs], scale * truth[:n_obs, d], "k.", ms=3, label="observed")
        if math.isfinite(inf.duration_low) and math.isfinite(inf.duration_high):
            ax.axvspan(inf.duration_low, inf.duration_high, color="tab:red", alpha=0.08,
                       label="predicted end, 90 %")  # fmt: skip
        ax.set_title(f"{layout.columns[d]} ({unit})" if unit else layout.columns[d], fontsize=9)
        ax.set_xlabel("s")
    axes[0].legend(fontsize=7)
    fig.suptitle(
        f"{names[trial.primitive]} {trial.demo}:\n{trial.percent:.0f} % of "
        f"{'+'.join(trial.observed)} observed, alpha {trial.alpha_method}, recognised "
        f"{names[inf.index]} (p = {inf.probabilities[inf.index]:.2f})"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def confusion_figure(matrices: Sequence[Mapping], path: Path, method: str) -> None:
    """The confusion matrices of one (observed modalities, alpha method), one panel per
    percentage: rows the true primitive, columns the recognised one (the last column: the
    trials the method failed on), counts written in the cells."""
    labels = list(matrices[0]["primitives"])
    size = max(3.2, 0.45 * len(labels) + 1.6)
    fig, axes = grid(len(matrices), size)
    for ax, matrix in zip(axes, matrices, strict=True):
        counts = np.array(matrix["counts"])
        ax.imshow(counts, cmap="Blues", vmin=0, vmax=max(int(counts.sum(1).max()), 1))
        for (i, j), n in np.ndenumerate(counts):
            if n:
                colour = "white" if n > 0.6 * counts.sum(1).max() else "black"
                ax.text(j, i, str(n), ha="center", va="center", fontsize=7, color=colour)
        columns = [*labels, "failed"][: counts.shape[1]]
        ax.set_xticks(range(len(columns)), [_short(c) for c in columns], rotation=60, fontsize=7,
                      ha="right")  # fmt: skip
        ax.set_yticks(range(len(labels)), [_short(c) for c in labels], fontsize=7)
        ax.set_title(f"{matrix['percent']:g} % observed", fontsize=9)
        ax.set_xlabel("recognised", fontsize=8)
        ax.set_ylabel("true", fontsize=8)
    first = matrices[0]
    fig.suptitle(f"confusion, method {method}, {series_label(first['observed'], first['alpha'])}",
                 fontsize=10)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def _short(name: str, limit: int = 18) -> str:
    """A tick label: the name, shortened in the middle past ``limit`` characters."""
    return name if len(name) <= limit else f"{name[: limit // 2 - 1]}…{name[-(limit // 2):]}"


def write_figures(
    folder: Path,
    result: SweepResult,
    dataset: Dataset,
    layout: Layout,
    method: str,
    decisions: Decisions | None = None,
) -> list[Path]:
    """Write the curves (every method of the sweep in one figure, named after ``method``, the
    run's), and per method the reliability diagram, the confusion matrices (one figure per
    observed modality set and alpha method) and, for a method that predicts a trajectory, one
    example per observed modality set; with ``decisions`` (``--decide``), when each method
    would act (:func:`decision_figure`); return the paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / f"curves_{method}.png"]
    curves(result.rows, paths[0], method, layout.modality(metrics.position_modality(layout)))
    names = methods_of(result.rows) if result.rows else [method]
    for name in names:
        own = [t for t in result.trials if t.method == name or len(names) == 1]
        path = folder / f"reliability_{name or method}.png"
        reliability_diagram(own, len(dataset), path, name or method)
        paths.append(path)
    by_series: dict[tuple[str, str], list[Mapping]] = defaultdict(list)
    for matrix in confusion_matrices(trial_rows(result, list(dataset)), list(dataset)):
        key = (matrix["method"] or method, series_label(matrix["observed"], matrix["alpha"]))
        by_series[key].append(matrix)
    for (name, label), matrices in by_series.items():
        path = folder / f"confusion_{name}_{label.replace(', alpha ', '_')}.png"
        confusion_figure(matrices, path, name)
        paths.append(path)
    ran = [t for t in result.trials if t.inferred is not None and _predicts(t.inferred)]
    for name in names:
        own = [t for t in ran if t.method == name or len(names) == 1]
        for observed in sorted({t.observed for t in own}):
            candidates = [t for t in own if t.observed == observed and t.alpha_method == "ml"]
            candidates = candidates or [t for t in own if t.observed == observed]
            # A correctly recognised trial near 40 % observed, as in the paper's figures.
            candidates.sort(key=lambda t: (not t.correct, abs(t.percent - 40)))
            path = folder / f"example_{name or method}_{'+'.join(observed)}.png"
            example(candidates[0], dataset, layout, path)
            paths.append(path)
    if decisions is not None and decisions.rows:
        path = folder / f"decisions_{method}.png"
        decision_figure(decisions.rows, decisions.curve, len(dataset), path, method)
        paths.append(path)
    return paths


def _predicts(inferred) -> bool:
    """Whether a method predicted a trajectory (the baselines only recognise: NaN)."""
    return bool(np.isfinite(inferred.posterior_mean).any())


def decision_figure(
    rows: Sequence[Mapping], curve: Sequence[Mapping], n_primitives: int, path: Path, title: str
) -> None:
    """When each method would act (``--decide``), drawn to ``path``: left, the earliness /
    accuracy trade-off of the commit rule over its thresholds (in-sample: every trial at every
    threshold), one curve per method, observed set and alpha method, with the headline decision
    (each trial's threshold chosen without it) marked on it; right, the harmonic mean of
    accuracy and 1 - earliness against the threshold in decades of doubt, the median threshold
    chosen without each trial dotted. ``rows``, the headline, and ``curve``, in-sample, are
    :func:`promp.evaluate.decisions.decide`'s."""
    fig = _figure(12, 4.6)
    left, right = fig.subplots(1, 2)
    import matplotlib  # there: _figure said why not when it is missing

    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    named = len({str(r["method"]) for r in rows}) > 1
    for i, row in enumerate(rows):
        key = (row["method"], tuple(row["observed"]), row["alpha_method"])
        points = [c for c in curve
                  if (c["method"], tuple(c["observed"]), c["alpha_method"]) == key]  # fmt: skip
        colour = colours[i % len(colours)]
        label = series_label(row["observed"], row["alpha_method"],
                             str(row["method"]) if named else "")  # fmt: skip
        earliness = np.array([c["earliness"] for c in points])
        accuracy = np.array([c["accuracy"] for c in points])
        x = doubt_decades([c["threshold"] for c in points], n_primitives)
        hm = np.array([c["harmonic_mean"] for c in points])
        left.plot(100 * earliness, 100 * accuracy, ".-", color=colour, lw=1, ms=3,
                  label=f"{label} (in-sample)")  # fmt: skip
        right.plot(x, hm, "-", color=colour, lw=1.2, label=label)
        if math.isfinite(row["harmonic_mean"]):
            held_out = f"{label}: held-out, harmonic mean {row['harmonic_mean']:.2f}"
            left.plot(100 * row["earliness"], 100 * row["accuracy"], "*", color=colour, ms=13,
                      mec="k", mew=0.6, label=held_out)  # fmt: skip
            chosen = float(doubt_decades(row["threshold"], n_primitives))
            right.axvline(min(chosen, float(x.max())), color=colour, ls=":", lw=1)
    left.set_xlabel("earliness: % of the movement observed when it commits (never: 100)")
    left.set_ylabel("accuracy: % of trials committed to the true primitive")
    left.set_title("earliness / accuracy over thresholds (in-sample);\n*: each trial's "
                   "threshold chosen without it", fontsize=10)  # fmt: skip
    left.set_xlim(0, 100)
    left.set_ylim(0, 100)
    right.set_xlabel("threshold, decades of doubt: -log10((1 - p) / (1 - 1/K))")
    right.set_ylabel("harmonic mean of accuracy and 1 - earliness")
    right.set_title("harmonic mean against the threshold (in-sample);\ndotted: the median "
                    "threshold chosen without each trial", fontsize=10)  # fmt: skip
    right.set_ylim(0, 1)
    for ax in (left, right):
        ax.grid(alpha=0.3)
    left.legend(fontsize=7, loc="lower right")
    window = rows[0].get("window_s", math.nan) if rows else math.nan
    fig.suptitle(f"when the robot acts, {title}: commit once p >= threshold for {window:g} s")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
