"""Distribution tubes: the region where a share of the movements are at each moment, swept
along their mean path, as a triangle mesh, and how each tube style draws one
(:func:`tube_look`, :func:`outline_segments`).

At each phase the region is the ellipsoid ``{y : (y - m)^T S^-1 (y - m) <= r^2}`` of a sample's
Gaussian (mean ``m``, covariance ``S``: :mod:`promp.region`), ``r`` the radius that holds the
stated probability. Swept along the path, its cross-section in the plane normal to the path is
the ellipsoid's shadow on that plane: the ellipse of the projected covariance ``B^T S B``
(``B``: the plane's two unit vectors) at the same radius. Each ring is that ellipse.

The mesh has a fixed topology for a given number of path samples and ring vertices, so a
tube's vertices can be replaced in place (``mesh.vertices = V``) at scrubbing rate; so has its
outline (line segments).

The surface is drawn from inside only (:data:`TUBE_SIDE`, its back faces): a line within the
tube (its demonstrations, the observation, the predicted path) is then in front of every face
drawn, so the depth test keeps the line whole and untinted above the translucent tube (viser
1.1.1 has no render order for scene nodes, and its lines are opaque). A tube drawn from both
sides covered each line inside with its front wall: on a real set, blobs that hid the
demonstrations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from app.core.view_state import NO_TUBES, OUTLINE, REGION_50, REGION_90, TUBE_STYLES
from promp.region import SampleDistribution, region_radius

RING = 12  # vertices per cross-section
MIN_RADIUS = 0.001  # metres: a tube stays visible where the spread vanishes
TUBE_SIDE = "back"  # the surface's faces drawn (see the module docstring)


def resample(values: np.ndarray, n: int) -> np.ndarray:
    """Rows of ``values`` (m, d) linearly resampled to ``n`` rows over the same span."""
    m = values.shape[0]
    if m == n:
        return np.asarray(values, dtype=float)
    source = np.linspace(0.0, 1.0, m)
    target = np.linspace(0.0, 1.0, n)
    return np.column_stack(
        [np.interp(target, source, values[:, j]) for j in range(values.shape[1])]
    )


def _frames(path: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normal and binormal unit vectors along ``path`` (n, 3), by parallel transport, so the
    rings do not twist; robust to stationary stretches (zero tangent)."""
    n = path.shape[0]
    tangent = np.gradient(path, axis=0)
    norms = np.linalg.norm(tangent, axis=1)
    # Where the path does not move, reuse the nearest moving tangent.
    moving = norms > 1e-9
    if not moving.any():
        tangent = np.tile([1.0, 0.0, 0.0], (n, 1))
    else:
        index = np.arange(n)
        nearest = np.interp(index, index[moving], index[moving]).round().astype(int)
        tangent = tangent[nearest] / norms[nearest][:, None]
    seed = (0.0, 0.0, 1.0) if abs(tangent[0, 2]) < 0.9 else (1.0, 0.0, 0.0)
    # The transport is sequential: on Python floats (numpy's per-call cost on 3-vectors made
    # this loop most of a live frame's drawing, holding the interpreter's lock).
    rows = tangent.tolist()
    x, y, z = _cross(rows[0], seed)
    length = math.sqrt(x * x + y * y + z * z)
    x, y, z = x / length, y / length, z / length
    normal = []
    for t in rows:
        along = x * t[0] + y * t[1] + z * t[2]
        x, y, z = x - t[0] * along, y - t[1] * along, z - t[2] * along
        length = math.sqrt(x * x + y * y + z * z)
        if length < 1e-9:  # tangent turned onto the normal: pick a fresh perpendicular
            x, y, z = _cross(t, seed)
            length = math.sqrt(x * x + y * y + z * z)
        x, y, z = x / length, y / length, z / length
        normal.append((x, y, z))
    normal = np.array(normal)
    binormal = np.cross(tangent, normal)
    return normal, binormal


def _cross(a, b) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def tube_faces(n_points: int, ring: int = RING) -> np.ndarray:
    """Triangles of a tube of ``n_points`` rings, shape ((n_points - 1) * ring * 2, 3)."""
    i = np.arange(n_points - 1)[:, None] * ring
    j = np.arange(ring)[None, :]
    a = i + j
    b = i + (j + 1) % ring
    c = a + ring
    d = b + ring
    faces = np.stack([np.stack([a, c, b], -1), np.stack([b, c, d], -1)], axis=2)
    return faces.reshape(-1, 3).astype(np.uint32)


def ring_spreads(
    mean: np.ndarray, cov: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each ring's plane (n, 3, 2: the path's normal and binormal), and the eigenvalues (n, 2,
    ascending) and eigenvectors (n, 2, 2) of the covariance ``cov`` (n, 3, 3) projected on it,
    the eigenvalues floored so that no ring is thinner than :data:`MIN_RADIUS` at ``radius``
    (read-only arrays: a frame asks for one region's several times, from the 3D view's tube
    and the readout's widths, and gets the same answer without computing it again)."""
    mean = np.ascontiguousarray(mean, dtype=float)
    cov = np.ascontiguousarray(cov, dtype=float)
    return _spreads(mean.tobytes(), mean.shape, cov.tobytes(), cov.shape, float(radius))


@lru_cache(maxsize=16)
def _spreads(mean: bytes, mean_shape: tuple, cov: bytes, cov_shape: tuple, radius: float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    normal, binormal = _frames(np.frombuffer(mean).reshape(mean_shape))
    plane = np.stack([normal, binormal], axis=2)  # (n, 3, 2)
    projected = plane.transpose(0, 2, 1) @ np.frombuffer(cov).reshape(cov_shape) @ plane
    values, vectors = np.linalg.eigh(projected)  # (n, 2), (n, 2, 2)
    floor = (MIN_RADIUS / max(radius, 1e-12)) ** 2
    spreads = (plane, np.maximum(values, floor), vectors)
    for array in spreads:
        array.flags.writeable = False
    return spreads


def ring_widths(region: SampleDistribution, probability: float) -> np.ndarray:
    """The width (n,) of each ring of :func:`region_vertices` (the ellipse's longest
    diameter, metres): what the tube measures across at each phase."""
    radius = region_radius(probability, 3)
    _, values, _ = ring_spreads(region.mean, region.cov, radius)
    return 2.0 * radius * np.sqrt(values[:, -1])


def tube_vertices(
    mean: np.ndarray, cov: np.ndarray, radius: float, ring: int = RING
) -> np.ndarray:
    """Vertices of the tube around ``mean`` (n, 3) of the regions of covariance ``cov``
    (n, 3, 3) at Mahalanobis ``radius`` (see the module docstring).

    Each ring lies in the plane normal to the path (normal ``u``, binormal ``v``); its points
    are ``m + radius * [u v] L (cos t, sin t)`` with ``L L^T = [u v]^T S [u v]``: the shadow of
    the ellipsoid on that plane, never thinner than :data:`MIN_RADIUS`.

    Returns
    -------
    array, shape (n * ring, 3), float32
    """
    mean = np.asarray(mean, dtype=float)
    plane, values, vectors = ring_spreads(mean, cov, radius)
    # no axis thinner than MIN_RADIUS: eigenvalues floored, the matrix rebuilt (a Cholesky
    # factor of it, not the eigenvectors, whose signs could flip from ring to ring and twist
    # the mesh)
    floored = (vectors * values[:, None, :]) @ vectors.transpose(0, 2, 1)
    chol = np.linalg.cholesky(floored)  # (n, 2, 2)
    theta = np.linspace(0.0, 2.0 * np.pi, ring, endpoint=False)
    circle = np.stack([np.cos(theta), np.sin(theta)])  # (2, ring)
    offsets = radius * (plane @ chol @ circle)  # (n, 3, ring)
    return (mean[:, :, None] + offsets).transpose(0, 2, 1).reshape(-1, 3).astype(np.float32)


def region_vertices(region: SampleDistribution, probability: float, ring: int = RING) -> np.ndarray:
    """:func:`tube_vertices` of a 3-D region (:class:`promp.region.SampleDistribution`) at the
    radius that holds ``probability`` of it."""
    return tube_vertices(region.mean, region.cov, region_radius(probability, 3), ring)


# ---------------------------------------------------------------------- the tube styles

OUTLINE_RINGS = 11  # rings drawn along a tube in outline
OUTLINE_RAILS = 4  # lines drawn along a tube in outline, a quarter turn apart


@dataclass(frozen=True)
class TubeLook:
    """How one :data:`app.core.view_state.TUBE_STYLES` style draws a tube.

    Attributes
    ----------
    probability : float
        The share of the movements inside the tube at each moment.
    surface : bool
        The translucent surface (a band).
    outline : bool
        Thin lines instead: :data:`OUTLINE_RINGS` rings and :data:`OUTLINE_RAILS` lines along.
    """

    probability: float
    surface: bool
    outline: bool

    @property
    def shown(self) -> bool:
        return self.surface or self.outline


TUBE_LOOKS = {
    REGION_90: TubeLook(0.9, surface=True, outline=False),
    REGION_50: TubeLook(0.5, surface=True, outline=False),
    OUTLINE: TubeLook(0.9, surface=False, outline=True),
    NO_TUBES: TubeLook(0.9, surface=False, outline=False),
}


def tube_look(style: str) -> TubeLook:
    """The look of ``style`` (one of :data:`app.core.view_state.TUBE_STYLES`).

    Raises
    ------
    ValueError
        An unknown style.
    """
    if style not in TUBE_LOOKS:
        raise ValueError(f"unknown tube style {style!r}; expected one of {TUBE_STYLES}")
    return TUBE_LOOKS[style]


def outline_segments(vertices: np.ndarray, ring: int = RING) -> np.ndarray:
    """The outline of a tube of :func:`tube_vertices`: :data:`OUTLINE_RINGS` of its rings,
    evenly spaced from end to end, and :data:`OUTLINE_RAILS` lines along it.

    Returns
    -------
    array, shape (OUTLINE_RINGS * ring + OUTLINE_RAILS * (n - 1), 2, 3), float32
        Line segments (start, end).
    """
    rings = np.asarray(vertices, dtype=np.float32).reshape(-1, ring, 3)
    n = rings.shape[0]
    chosen = rings[np.linspace(0, n - 1, OUTLINE_RINGS).round().astype(int)]  # (R, ring, 3)
    around = np.stack([chosen, np.roll(chosen, -1, axis=1)], axis=2).reshape(-1, 2, 3)
    rails = rings[:, np.arange(OUTLINE_RAILS) * ring // OUTLINE_RAILS]  # (n, rails, 3)
    along = np.stack([rails[:-1], rails[1:]], axis=2).reshape(-1, 2, 3)
    return np.concatenate([around, along])
