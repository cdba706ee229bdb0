"""The model file: versioned JSON (demonstrations are NPZ, :mod:`promp.demo_npz`, or CSV,
:mod:`promp.datasets`). No pickle anywhere.

Model JSON, schema version 5 (versions 1 to 4 still load: see :func:`model_from_dict`)::

    {
      "format": "icub-intention-studio/promp-model",
      "version": 5,
      "layout": [{"name": "hand", "columns": ["x", "y", "z"], "unit": "m", "kind": "linear"},
                 ...],
      "settings": {"n_basis": 7, "width": 1.0, "ridge": 1e-06, "s_bar": 100.0,
                   "shrinkage": null, "noise_std": {}, "noise_scale": 1.0,
                   "alpha_coupling": true, "noise_correlation": true, "select": "loo",
                   "recognition": "promp"},
      "sample_period": 0.02,                       # seconds
      "report": {"settings": {"rule": "...", "chosen": {"n_basis": 7, ...}, ...},
                 "covariance": {"rule": "...", "strength": 42.2, ...}},
                                                   # what the fit chose from the data, and why
      "primitives": [{
          "name": "curved",
          "mean": [...],                           # (n_dims * n_basis,), dimension-major
          "cov_diag": [...],                       # (n_dims * n_basis,)
          "cov_factor": [[...], ...],              # (n_dims * n_basis, rank)
          "noise_var": [...],                      # (n_dims,)
          "noise_tau": [...],                      # (n_dims,) noise correlation time, s
          "alphas": [...],                         # (n_demos,)
          "shrinkage": [...],                      # (n_dims,) share of the target F
          "log_alpha_mean": -0.1,                  # mean log(alpha) of the training demos
          "alpha_slope": [...],                    # (n_dims * n_basis,): d mean / d log(alpha)
          "alpha_models": {"hand": {"n_observed": [...], "lo": [[...]], "hi": [[...]],
                                    "weights": [[...]], "residual_var": [...]}, ...},
          "stillness": {"hand": {"lead": [...], "pause": [...], "trail": [...]}, ...}
                    # per modality in m or rad, each (n_demos,): how each demonstration is
                    # still, s: before its motion, the longest pause inside, after
          "region_scale": {"hand": 1.3, ...},
                    # per modality: the factor on the radius of its predictive region that
                    # holds its stated share of its own demonstrations, each left out in turn
          "residuals": [[...], ...]                # (n_demos, n_dims * n_basis) or null
      }, ...]
    }

Sigma_w = diag(cov_diag) + cov_factor cov_factor^T. Floats are written with Python's shortest
round-trip representation, so saving and loading is exact.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from promp.alpha_model import N_RBF, AlphaModel
from promp.data import Layout, Modality
from promp.files import atomic_write_text
from promp.model import STILL_PARTS, Primitive, ProMPModel, Settings

__all__ = [
    "MODEL_FORMAT", "MODEL_VERSION", "READABLE_VERSIONS", "load_model", "model_from_dict",
    "model_from_json", "model_to_dict", "model_to_json", "save_model"
]  # fmt: skip

MODEL_FORMAT = "icub-intention-studio/promp-model"
MODEL_VERSION = 5
READABLE_VERSIONS = (1, 2, 3, 4, 5)


def _has_bool(value: Any) -> bool:
    if isinstance(value, bool):
        return True
    return isinstance(value, list) and any(_has_bool(v) for v in value)


def _array(value: Any, what: str, shape: tuple[int | None, ...]) -> np.ndarray:
    """A finite float array of the given shape (None = any length) or a ValueError."""
    if _has_bool(value):  # JSON true/false is not a number, though numpy would take it as one
        raise ValueError(f"{what}: not an array of numbers (holds true/false)")
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{what}: not an array of numbers ({exc})") from exc
    if arr.ndim != len(shape) or any(
        want is not None and got != want for got, want in zip(arr.shape, shape, strict=True)
    ):
        expected = "(" + ", ".join("n" if s is None else str(s) for s in shape)
        expected += ",)" if len(shape) == 1 else ")"
        raise ValueError(f"{what}: expected shape {expected}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what}: contains NaN or infinite values")
    return arr


def _field(obj: Mapping, key: str, what: str) -> Any:
    if not isinstance(obj, Mapping) or key not in obj:
        raise ValueError(f"{what}: missing field {key!r}")
    return obj[key]


def _number(obj: Mapping, key: str, what: str) -> float:
    """The finite number ``obj[key]`` or a ValueError (true/false and strings are refused)."""
    value = _field(obj, key, what)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{what} {key}: expected a number, got {value!r}")
    if not np.isfinite(value):
        raise ValueError(f"{what} {key}: must be finite, got {value!r}")
    return float(value)


def _block_diagonal(
    cov_diag: np.ndarray, factor: np.ndarray, n_dims: int
) -> tuple[np.ndarray, np.ndarray]:
    """``Sigma_w = diag(cov_diag) + factor factor^T`` with a diagonal constant within each
    dimension's block (what :class:`promp.model.Primitive` stores): the same matrix, the
    diagonal's excess over its block's least entry moved into the factor as columns. The first
    version-1 writer's diagonal was not constant; later ones are, and are returned as given."""
    blocks = cov_diag.reshape(n_dims, -1)
    least = np.repeat(blocks.min(axis=1), blocks.shape[1])
    excess = cov_diag - least
    moved = np.nonzero(excess > 0)[0]
    if not moved.size:
        return cov_diag, factor
    columns = np.zeros((cov_diag.shape[0], moved.shape[0]))
    columns[moved, np.arange(moved.shape[0])] = np.sqrt(excess[moved])
    return least, np.hstack([factor, columns])


def _stillness(raw: Any, layout: Layout, n_demos: int, what: str
               ) -> dict[str, dict[str, np.ndarray]]:  # fmt: skip
    """A primitive's ``stillness``: per modality of ``layout`` in m or rad, each part of
    :data:`promp.model.STILL_PARTS` as ``n_demos`` non-negative seconds."""
    if not isinstance(raw, Mapping):
        raise ValueError(f"{what} stillness: expected an object")
    units = {m.name: m.unit for m in layout.modalities}
    out = {}
    for name, parts in raw.items():
        if units.get(name) not in ("m", "rad"):
            raise ValueError(f"{what} stillness: {name!r} is not a modality in m or rad of the "
                             f"layout")  # fmt: skip
        out[str(name)] = {}
        for part in STILL_PARTS:
            label = f"{what} stillness {name!r} {part}"
            arr = _array(_field(parts, part, f"{what} stillness {name!r}"), label, (n_demos,))
            if np.any(arr < 0):
                raise ValueError(f"{label}: must be >= 0 s")
            out[str(name)][part] = arr
    return out


def _region_scale(raw: Any, layout: Layout, what: str) -> dict[str, float]:
    """A primitive's ``region_scale``: a positive finite number per modality of ``layout``
    it lists."""
    if not isinstance(raw, Mapping):
        raise ValueError(f"{what} region_scale: expected an object")
    out = {}
    for name, value in raw.items():
        if name not in layout.names:
            raise ValueError(f"{what} region_scale: {name!r} is not a modality of the layout")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{what} region_scale {name!r}: expected a number")
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"{what} region_scale {name!r}: must be positive, got {value}")
        out[str(name)] = float(value)
    return out


def model_to_dict(model: ProMPModel) -> dict[str, Any]:
    """The JSON-ready description of ``model`` (schema in the module docstring)."""
    s = model.settings
    return {
        "format": MODEL_FORMAT,
        "version": MODEL_VERSION,
        "layout": [
            {"name": m.name, "columns": list(m.columns), "unit": m.unit, "kind": m.kind}
            for m in model.layout.modalities
        ],
        "settings": {
            "n_basis": s.n_basis,
            "width": s.width,
            "ridge": s.ridge,
            "s_bar": s.s_bar,
            "shrinkage": s.shrinkage,
            "noise_std": dict(s.noise_std),
            "noise_scale": s.noise_scale,
            "alpha_coupling": s.alpha_coupling,
            "noise_correlation": s.noise_correlation,
            "duration_temperature": s.duration_temperature,
            "select": s.select,
            "recognition": s.recognition,
        },
        "sample_period": model.sample_period,
        "report": dict(model.report),
        "primitives": [
            {
                "name": p.name,
                "mean": p.mean.tolist(),
                "cov_diag": p.cov_diag.tolist(),
                "cov_factor": p.cov_factor.tolist(),
                "noise_var": p.noise_var.tolist(),
                "noise_tau": p.noise_tau.tolist(),
                "alphas": p.alphas.tolist(),
                "shrinkage": p.shrinkage.tolist(),
                "log_alpha_mean": p.log_alpha_mean,
                "alpha_slope": p.alpha_slope.tolist(),
                "alpha_models": {
                    name: {key: value.tolist() for key, value in am.to_arrays().items()}
                    for name, am in p.alpha_models.items()
                },
                "stillness": {name: {part: np.asarray(v, dtype=float).tolist()
                                     for part, v in parts.items()}
                              for name, parts in p.stillness.items()},
                "region_scale": {name: float(v) for name, v in p.region_scale.items()},
                "residuals": None if p.residuals is None else p.residuals.tolist(),
            }
            for p in model.primitives
        ],
    }


def model_to_json(model: ProMPModel) -> str:
    return json.dumps(model_to_dict(model), allow_nan=False)


def model_from_dict(data: Any) -> ProMPModel:
    """Rebuild a model from :func:`model_to_dict` output, validating everything.

    Every version this code reads (:data:`READABLE_VERSIONS`) loads as its writer meant it
    (``tests/test_promp_model_format.py`` loads a file of each writer and compares the prior it
    predicts with the one that writer's code predicted):

    * version 5 adds the settings' ``recognition`` and each primitive's ``residuals``
      (absent: ``"promp"`` and none, so the model recognises with the ProMP, as its writer
      did);
    * version 4 adds each primitive's ``region_scale`` (absent: every region keeps the radius
      of its Gaussian, as its writer drew it);
    * version 3 adds each primitive's ``stillness`` (absent: none learned, the primitive is
      taken never to pause, its still ends unknown: the live segmenter cuts its movements as
      before);
    * version 2 adds ``report``; its later writers add the settings ``select`` and
      ``duration_temperature`` (absent: ``"loo"``, and 1, the plain posterior);
    * version 1 has no ``report``; its first writers had white observation noise (no
      ``noise_tau``: 0), one shrinkage for every dimension (a number, not a list), Eq. 7
      models with a row for every ``n_o`` from 1 (no ``n_observed``) and, the very first, a
      prior diagonal not constant within a dimension's block (:func:`_block_diagonal`).

    Raises
    ------
    ValueError
        Wrong format tag, unknown version, missing fields, wrong shapes, non-finite numbers.
    """
    if not isinstance(data, Mapping):
        raise ValueError("a model file must hold a JSON object")
    if data.get("format") != MODEL_FORMAT:
        raise ValueError(
            f"not a model file: 'format' is {data.get('format')!r}, expected {MODEL_FORMAT!r}"
        )
    version = data.get("version")
    if version not in READABLE_VERSIONS:
        raise ValueError(
            f"unsupported model version {version!r}; this version reads versions "
            f"{', '.join(map(str, READABLE_VERSIONS))}"
        )
    report = data.get("report", {})
    if not isinstance(report, Mapping):
        raise ValueError("model 'report' must be a JSON object")
    layout, settings = _layout_and_settings(data)
    sample_period = _number(data, "sample_period", "model")
    if sample_period <= 0:
        raise ValueError(f"sample_period must be positive, got {sample_period}")
    primitives = []
    raw_prims = _field(data, "primitives", "model")
    if not isinstance(raw_prims, list) or not raw_prims:
        raise ValueError("a model needs a non-empty list of primitives")
    names = set()
    for i, p in enumerate(raw_prims):
        name = str(_field(p, "name", f"primitive {i}"))
        if name in names:
            raise ValueError(f"duplicate primitive name {name!r}")
        names.add(name)
        primitives.append(_primitive_from_dict(p, name, layout, settings.n_basis, version))
    return ProMPModel(
        layout=layout,
        settings=settings,
        sample_period=sample_period,
        primitives=tuple(primitives),
        report=dict(report),
    )


def _layout_and_settings(data: Mapping) -> tuple[Layout, Settings]:
    """The layout and the settings of a model file's dict (see :func:`model_from_dict`)."""
    try:
        layout = Layout(
            tuple(
                Modality(
                    name=str(_field(m, "name", "layout")),
                    columns=tuple(str(c) for c in _field(m, "columns", "layout")),
                    unit=str(_field(m, "unit", "layout")),
                    kind=_field(m, "kind", "layout"),
                )
                for m in _field(data, "layout", "model")
            )
        )
        raw = _field(data, "settings", "model")
        settings = Settings(
            n_basis=int(_field(raw, "n_basis", "settings")),
            width=float(_field(raw, "width", "settings")),
            ridge=None if raw.get("ridge") is None else float(raw["ridge"]),
            s_bar=float(_field(raw, "s_bar", "settings")),
            shrinkage=None if raw.get("shrinkage") is None else float(raw["shrinkage"]),
            noise_std={str(k): float(v) for k, v in dict(raw.get("noise_std", {})).items()},
            noise_scale=float(raw.get("noise_scale", 1.0)),
            alpha_coupling=bool(raw.get("alpha_coupling", True)),
            noise_correlation=bool(raw.get("noise_correlation", True)),
            # files before the calibration had none: the plain posterior
            duration_temperature=float(raw.get("duration_temperature", 1.0) or 1.0),
            select=str(raw.get("select", "loo")),
            # before version 5 (or fitted with every setting given): None, the ProMP
            recognition=None if raw.get("recognition") is None else str(raw["recognition"]),
        )
    except (TypeError, AttributeError) as exc:
        raise ValueError(f"malformed layout or settings ({exc})") from exc
    return layout, settings


def _primitive_from_dict(
    p: Mapping, name: str, layout: Layout, n_basis: int, version: int
) -> Primitive:
    """Primitive ``name`` of a model file's dict, validated (see :func:`model_from_dict`)."""
    n_dims = layout.n_dims
    n_weights = n_dims * n_basis
    what = f"primitive {name!r}"
    factor = _array(_field(p, "cov_factor", what), f"{what} cov_factor", (n_weights, None))
    cov_diag = _array(_field(p, "cov_diag", what), f"{what} cov_diag", (n_weights,))
    if np.any(cov_diag <= 0):
        raise ValueError(f"{what} cov_diag: variances must be positive")
    if version == 1:
        cov_diag, factor = _block_diagonal(cov_diag, factor, n_dims)
    noise_var = _array(_field(p, "noise_var", what), f"{what} noise_var", (n_dims,))
    if np.any(noise_var <= 0):
        raise ValueError(f"{what} noise_var: variances must be positive")
    if version == 1 and "noise_tau" not in p:  # white noise: the first writer's model
        noise_tau = np.zeros(n_dims)
    else:
        noise_tau = _array(_field(p, "noise_tau", what), f"{what} noise_tau", (n_dims,))
    if np.any(noise_tau < 0):
        raise ValueError(f"{what} noise_tau: correlation times must be >= 0")
    alphas = _array(_field(p, "alphas", what), f"{what} alphas", (None,))
    if alphas.size == 0 or np.any(alphas <= 0):
        raise ValueError(f"{what} alphas: need at least one, all positive")
    alpha_models = _alpha_models_from_dict(_field(p, "alpha_models", what), layout, what,
                                           version)  # fmt: skip
    shrinkage = _field(p, "shrinkage", what)
    if version == 1 and not isinstance(shrinkage, (list, bool)):  # one for every dimension
        shrinkage = [shrinkage] * n_dims
    shrinkage = _array(shrinkage, f"{what} shrinkage", (n_dims,))
    if np.any((shrinkage <= 0) | (shrinkage > 1)):
        raise ValueError(f"{what} shrinkage: intensities must be in (0, 1]")
    stillness = _stillness(_field(p, "stillness", what) if version >= 3 else {}, layout,
                           alphas.size, what)  # fmt: skip
    region_scale = _region_scale(_field(p, "region_scale", what) if version >= 4 else {},
                                 layout, what)  # fmt: skip
    residuals = p.get("residuals") if version >= 5 else None
    if residuals is not None:
        residuals = _array(residuals, f"{what} residuals", (alphas.size, n_weights))
    log_alpha_mean = _number(p, "log_alpha_mean", what)
    alpha_slope = _array(_field(p, "alpha_slope", what), f"{what} alpha_slope", (n_weights,))
    return Primitive(
        name=name,
        mean=_array(_field(p, "mean", what), f"{what} mean", (n_weights,)),
        cov_diag=cov_diag,
        cov_factor=factor,
        noise_var=noise_var,
        noise_tau=noise_tau,
        alphas=alphas,
        alpha_models=alpha_models,
        shrinkage=shrinkage,
        log_alpha_mean=log_alpha_mean,
        alpha_slope=alpha_slope,
        stillness=stillness,
        region_scale=region_scale,
        residuals=residuals,
    )


def _alpha_models_from_dict(
    raw_models: Any, layout: Layout, what: str, version: int
) -> dict[str, AlphaModel]:
    """The Eq. 7 model of every modality of primitive ``what`` (see :func:`model_from_dict`)."""
    alpha_models = {}
    if not isinstance(raw_models, Mapping):
        raise ValueError(f"{what} alpha_models: expected an object")
    for modality in layout.modalities:
        am = _field(raw_models, modality.name, f"{what} alpha_models")
        width = len(modality.columns)
        label = f"{what} alpha model {modality.name!r}"
        lo = _array(_field(am, "lo", label), f"{label} lo", (None, width))
        if version == 1 and "n_observed" not in am:  # one row per n_o from 1
            grid = np.arange(1.0, lo.shape[0] + 1.0)
        else:
            grid = _array(
                _field(am, "n_observed", label), f"{label} n_observed", (lo.shape[0],)
            )
        if grid.size == 0 or grid[0] != 1 or np.any(np.diff(grid) <= 0):
            raise ValueError(f"{label} n_observed: must increase from 1")
        alpha_models[modality.name] = AlphaModel(
            n_observed=grid.astype(int),
            lo=lo,
            hi=_array(_field(am, "hi", label), f"{label} hi", (lo.shape[0], width)),
            weights=_array(
                _field(am, "weights", label), f"{label} weights", (lo.shape[0], width * N_RBF)
            ),
            residual_var=_array(
                _field(am, "residual_var", label), f"{label} residual_var", (lo.shape[0],)
            ),
        )
    return alpha_models


def model_from_json(text: str | bytes) -> ProMPModel:
    try:
        data = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"not valid JSON ({exc})") from exc
    return model_from_dict(data)


def save_model(path: Path, model: ProMPModel) -> None:
    """Write ``model`` to ``path`` as JSON (the format of the module docstring, version
    :data:`MODEL_VERSION`), atomically: a reader never sees half a file.

    Parameters
    ----------
    path : path
    model : ProMPModel
    """
    atomic_write_text(Path(path), model_to_json(model))


def load_model(path: Path) -> ProMPModel:
    """The model in the JSON file ``path``, of any version this code reads
    (:func:`model_from_dict`).

    Parameters
    ----------
    path : path

    Returns
    -------
    ProMPModel

    Raises
    ------
    ValueError
        An unreadable file, not JSON, not a model file, an unknown version, a missing field,
        a wrong shape or a non-finite number, with the file named.
    """
    path = Path(path)
    try:
        text = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read ({exc})") from exc
    try:
        return model_from_json(text)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc

