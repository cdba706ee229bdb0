"""A 3-D region of a primitive, drawn by a viewer: its ellipsoids at some phases.

At a phase, the region that holds ``P`` of a new sample is the ellipsoid
``{y : (y - m)^T S^-1 (y - m) <= r^2}``, ``r = sqrt(chi2_3^-1(P))``
(:func:`promp.region.region_radius`). With ``S = V diag(l) V^T`` (eigenvectors ``V``), its
semi-axes are ``r sqrt(l)`` along the columns of ``V``: what Rerun's ``Ellipsoids3D`` and
Foxglove's ``SpherePrimitive`` (a size per axis and a pose) draw, without a mesh of ours.
"""

from __future__ import annotations

import numpy as np

from promp.region import region_radius
from promp.viewers.scene_log import Color, Ellipsoids, Stamp

__all__ = ["ELLIPSOIDS", "region_ellipsoids"]

ELLIPSOIDS = 16  # phases a region is drawn at, evenly spread from its start to its end


def region_ellipsoids(
    path: str,
    mean: np.ndarray,
    cov: np.ndarray,
    probability: float,
    color: Color,
    at: Stamp | None = None,
    n: int = ELLIPSOIDS,
) -> Ellipsoids:
    """The region of ``probability`` at ``n`` phases of (``mean``, ``cov``), evenly spread.

    Parameters
    ----------
    mean : array, shape (m, 3)
        The region's centre at each phase, metres.
    cov : array, shape (m, 3, 3)
        A sample's covariance at each phase, square metres (symmetric, positive
        semi-definite).
    probability : float
        The share of the samples inside, in (0, 1).

    Raises
    ------
    ValueError
        Shapes that do not match, a covariance that is not symmetric positive semi-definite,
        a probability outside (0, 1).
    """
    mean = np.asarray(mean, dtype=float)
    cov = np.asarray(cov, dtype=float)
    if mean.ndim != 2 or mean.shape[1] != 3 or cov.shape != (mean.shape[0], 3, 3):
        raise ValueError(f"{path}: means (m, 3) and covariances (m, 3, 3) expected, got "
                         f"{mean.shape} and {cov.shape}")  # fmt: skip
    if not np.allclose(cov, cov.transpose(0, 2, 1), atol=1e-12 + 1e-9 * np.abs(cov).max()):
        raise ValueError(f"{path}: a covariance is not symmetric")
    radius = region_radius(probability, 3)
    chosen = np.unique(np.round(np.linspace(0, mean.shape[0] - 1, min(n, mean.shape[0]))))
    chosen = chosen.astype(int)
    values, vectors = np.linalg.eigh(cov[chosen])
    if np.any(values < -1e-12 * max(1.0, float(np.abs(values).max()))):
        raise ValueError(f"{path}: a covariance is not positive semi-definite")
    flip = np.linalg.det(vectors) < 0  # a proper rotation: the last axis turned round
    vectors[flip, :, 2] *= -1.0
    half_axes = radius * np.sqrt(np.clip(values, 0.0, None))
    return Ellipsoids(path, mean[chosen], half_axes, vectors, color, at=at)
