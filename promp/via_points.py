"""Via-points: a primitive conditioned on passing through points (the Gaussian conditioning of
the paper's Eq. 8, applied to chosen points instead of the observed start of a movement).

A via-point ``i`` says that at phase ``z_i`` the movement's columns ``d_i`` (k_i of them) are
``y_i``, give or take a Gaussian error of covariance ``Sigma_i`` (its precision: a tight point
is passed through, a loose one only pulls): ``y_i = A_i w + e_i``, ``e_i ~ N(0, Sigma_i)``,
with ``A_i`` the k_i x P matrix whose row ``j`` holds ``phi(z_i)^T`` in the block of column
``d_ij`` (P = n_dims * M weights). Stacked over the points (``A``: K x P, ``y``: K,
``R = blockdiag(Sigma_i)``), the weights ``w ~ N(mu, Sigma)`` become

    S      = A Sigma A^T + R                        (K x K)
    mu'    = mu + Sigma A^T S^-1 (y - A mu)
    Sigma' = Sigma - Sigma A^T S^-1 A Sigma

which is Eq. 8 with ``A`` in place of the observation's basis and ``R`` in place of the sensor
noise. All points are conditioned on at once; since each conditioning is exact, this equals
conditioning on them one by one, in any order, and conditioning on an observation before or
after them equals conditioning on both at once. The trajectory itself passes through a point
(``R`` is the point's own covariance, not the sensor noise a sample would add).

Via-points belong to the user of a model, not to the model: the model is never changed and its
file never holds them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve

from promp.inference import Gaussian, Posterior
from promp.model import Primitive, ProMPModel
from promp.timing import check_alpha, duration_from_alpha

__all__ = ["ViaPoint", "condition_on_via_points", "via_point_design"]


@dataclass(frozen=True, eq=False)
class ViaPoint:
    """A point a movement passes through.

    Parameters
    ----------
    columns : tuple of str
        Columns of the model's layout (e.g. ``("x", "y", "z")``, or ``("z",)`` for a height
        alone), k of them, no repeat.
    values : array, shape (k,)
        Where those columns are, in their units (angles in the model's unwrapped convention).
    cov : array, shape (k, k)
        The point's covariance (symmetric, positive definite): small for a point the movement
        must pass through, large for one it is only pulled towards.
    phase : float, optional
        In [0, 1]: the share of the movement. Exactly one of ``phase`` and ``time``.
    time : float, optional
        Seconds from the start of the movement (>= 0), made a phase with the duration of the
        speed alpha the conditioning is given.

    Raises
    ------
    ValueError
        Shapes that disagree, non-finite values, a covariance that is not symmetric positive
        definite, a phase outside [0, 1], a negative time, both or neither of phase and time.
    """

    columns: tuple[str, ...]
    values: np.ndarray
    cov: np.ndarray
    phase: float | None = None
    time: float | None = None

    def __post_init__(self) -> None:
        columns = tuple(str(c) for c in self.columns)
        if not columns or len(set(columns)) != len(columns):
            raise ValueError(f"a via-point needs distinct columns, got {list(columns)}")
        k = len(columns)
        values = np.array(self.values, dtype=float).reshape(-1)
        cov = np.array(self.cov, dtype=float)
        if values.shape != (k,) or not np.all(np.isfinite(values)):
            raise ValueError(
                f"a via-point on {list(columns)} needs {k} finite values, got {self.values!r}"
            )
        if cov.shape != (k, k) or not np.all(np.isfinite(cov)):
            raise ValueError(f"a via-point's covariance must be a finite {k}x{k} matrix")
        if not np.allclose(cov, cov.T, rtol=1e-9, atol=0.0):
            raise ValueError("a via-point's covariance must be symmetric")
        if np.linalg.eigvalsh(cov).min() <= 0.0:
            raise ValueError(
                "a via-point's covariance must be positive definite (a precision per point: "
                "give a small variance for a point to pass through, not zero)"
            )
        if (self.phase is None) == (self.time is None):
            raise ValueError("a via-point needs either a phase (0 to 1) or a time (seconds)")
        if self.phase is not None:
            phase = float(self.phase)
            if not np.isfinite(phase) or not 0.0 <= phase <= 1.0:
                raise ValueError(f"a via-point's phase must be in [0, 1], got {self.phase}")
            object.__setattr__(self, "phase", phase)
        else:
            time = float(self.time)
            if not np.isfinite(time) or time < 0.0:
                raise ValueError(f"a via-point's time must be >= 0 seconds, got {self.time}")
            object.__setattr__(self, "time", time)
        values.setflags(write=False)
        cov.setflags(write=False)
        object.__setattr__(self, "columns", columns)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "cov", cov)

    @classmethod
    def isotropic(
        cls,
        columns: Sequence[str],
        values: Sequence[float] | np.ndarray,
        std: float,
        phase: float | None = None,
        time: float | None = None,
    ) -> ViaPoint:
        """A via-point whose error has the same standard deviation ``std`` (> 0) in every
        column: ``cov = std^2 I``."""
        std = float(std)
        if not np.isfinite(std) or std <= 0.0:
            raise ValueError(f"a via-point's standard deviation must be positive, got {std}")
        return cls(tuple(columns), np.asarray(values, dtype=float), std**2 * np.eye(len(columns)),
                   phase=phase, time=time)  # fmt: skip

    def phase_at(self, model: ProMPModel, alpha: float | None) -> float:
        """The point's phase; a time is divided by the duration of speed ``alpha``.

        Raises
        ------
        ValueError
            A time without alpha, or later than the movement's duration at alpha.
        """
        if self.phase is not None:
            return self.phase
        if alpha is None:
            raise ValueError("a via-point given by its time needs the speed alpha")
        duration = float(duration_from_alpha(alpha, model.sample_period, model.settings.s_bar))
        if self.time > duration * (1.0 + 1e-9):
            raise ValueError(
                f"a via-point at {self.time:.3f} s is after the end of the movement "
                f"({duration:.3f} s at alpha = {alpha:.4g})"
            )
        return min(self.time / duration, 1.0)


def via_point_design(
    model: ProMPModel, via_points: Sequence[ViaPoint], alpha: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, y, R)`` of ``via_points`` (see the module docstring): shapes (K, P), (K,), (K, K).

    Raises
    ------
    ValueError
        A column the model's layout does not have (named, with the layout's columns), or a
        point's phase (see :meth:`ViaPoint.phase_at`).
    """
    layout_columns = model.layout.columns
    m = model.basis.n_basis
    rows, targets, covs = [], [], []
    for point in via_points:
        unknown = [c for c in point.columns if c not in layout_columns]
        if unknown:
            raise ValueError(
                f"the model has no column(s) {unknown}; its columns are {list(layout_columns)}"
            )
        phi = model.basis(np.array([point.phase_at(model, alpha)]))[0]  # (M,)
        for column in point.columns:
            d = layout_columns.index(column)
            row = np.zeros(model.n_dims * m)
            row[d * m : (d + 1) * m] = phi
            rows.append(row)
        targets.append(point.values)
        covs.append(point.cov)
    k = len(rows)
    noise = np.zeros((k, k))
    start = 0
    for cov in covs:
        size = cov.shape[0]
        noise[start : start + size, start : start + size] = cov
        start += size
    a = np.array(rows).reshape(k, model.n_dims * m)
    y = np.concatenate(targets) if targets else np.zeros(0)
    return a, y, noise


def condition_on_via_points(
    model: ProMPModel,
    prior: Primitive | Gaussian | Posterior,
    via_points: Sequence[ViaPoint],
    alpha: float | None = None,
) -> Gaussian:
    """The weights conditioned on passing through ``via_points`` (see the module docstring).

    Parameters
    ----------
    model : ProMPModel
        Its basis and layout (never changed).
    prior : Primitive, Gaussian or Posterior
        The weights before: a primitive's prior at speed ``alpha`` (``mean_at(alpha)``,
        ``Sigma_w``), any Gaussian over the weights, or a posterior given an observation
        (:func:`promp.evidence.condition`): the points then combine with what was observed.
    via_points : sequence of ViaPoint
        Conditioned on at once; none gives the prior back, unchanged.
    alpha : float, optional
        The speed: needed for a primitive's prior and for a point given by its time.

    Returns
    -------
    Gaussian
        A new object: mean (P,), covariance (P, P); the prior's arrays are not modified.

    Raises
    ------
    ValueError
        A primitive without alpha, alpha <= 0, a point the model cannot place (an unknown
        column, a time after the end), a prior that is not finite, or variances too small to
        compute with.
    """
    if alpha is not None:
        check_alpha(alpha)
    if isinstance(prior, Primitive):
        if alpha is None:
            raise ValueError("a primitive's prior needs the speed alpha")
        mean, cov = prior.mean_at(alpha), prior.cov
    elif isinstance(prior, (Gaussian, Posterior)):
        mean, cov = prior.mean, prior.cov
    else:
        raise ValueError(
            f"the prior must be a Primitive, a Gaussian or a Posterior, got {type(prior).__name__}"
        )
    mean = np.array(mean, dtype=float)
    cov = np.array(cov, dtype=float)
    n_weights = model.n_dims * model.basis.n_basis
    if mean.shape != (n_weights,) or cov.shape != (n_weights, n_weights):
        raise ValueError(
            f"the prior has {mean.shape[0]} weights; the model has {n_weights} "
            f"({model.n_dims} dimensions x {model.basis.n_basis} basis functions)"
        )
    if not via_points:
        return Gaussian(mean, cov)
    if not (np.isfinite(mean).all() and np.isfinite(cov).all()):
        raise ValueError("the prior's mean and covariance must be finite numbers (NaN or inf "
                         "in them would make every conditioned weight NaN)")
    a, y, noise = via_point_design(model, via_points, alpha)
    a_cov = a @ cov  # (K, P)
    s = a_cov @ a.T + noise
    try:
        chol = np.linalg.cholesky(0.5 * (s + s.T))
    except np.linalg.LinAlgError:
        raise ValueError(
            "the via-points' variances are too small for the model's scale (A Sigma A^T + R "
            "is not numerically positive definite): give them larger ones"
        ) from None
    gain_t = cho_solve((chol, True), a_cov, check_finite=False)  # S^-1 A Sigma, (K, P)
    new_mean = mean + gain_t.T @ (y - a @ mean)
    new_cov = cov - a_cov.T @ gain_t
    return Gaussian(new_mean, 0.5 * (new_cov + new_cov.T))
