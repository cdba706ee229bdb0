"""Distribution tubes: a hand path's mean with a +-k sigma cross-section, as a triangle mesh.

The mesh has a fixed topology for a given number of path samples and ring vertices, so a
tube's vertices can be replaced in place (``mesh.vertices = V``) at scrubbing rate.
"""

from __future__ import annotations

import numpy as np

RING = 12  # vertices per cross-section
MIN_RADIUS = 0.001  # metres: a tube stays visible where the spread vanishes


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
    normal = np.empty((n, 3))
    seed = np.array([0.0, 0.0, 1.0]) if abs(tangent[0, 2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    current = np.cross(tangent[0], seed)
    current /= np.linalg.norm(current)
    for i in range(n):
        current = current - tangent[i] * (current @ tangent[i])
        length = np.linalg.norm(current)
        if length < 1e-9:  # tangent turned onto the normal: pick a fresh perpendicular
            current = np.cross(tangent[i], seed)
            length = np.linalg.norm(current)
        current = current / length
        normal[i] = current
    binormal = np.cross(tangent, normal)
    return normal, binormal


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


def tube_vertices(
    mean: np.ndarray, std: np.ndarray, n_sigma: float = 2.0, ring: int = RING
) -> np.ndarray:
    """Vertices of the tube around ``mean`` (n, 3) with per-axis spread ``std`` (n, 3).

    Each ring lies in the plane normal to the path; its radius in a direction ``u`` of that
    plane is ``n_sigma * sqrt(sum_k (u_k std_k)^2)``, the spread of the path along ``u``.

    Returns
    -------
    array, shape (n * ring, 3), float32
    """
    mean = np.asarray(mean, dtype=float)
    std = np.asarray(std, dtype=float)
    normal, binormal = _frames(mean)
    theta = np.linspace(0.0, 2.0 * np.pi, ring, endpoint=False)
    r_n = n_sigma * np.sqrt(((normal * std) ** 2).sum(axis=1))
    r_b = n_sigma * np.sqrt(((binormal * std) ** 2).sum(axis=1))
    r_n = np.maximum(r_n, MIN_RADIUS)[:, None, None]
    r_b = np.maximum(r_b, MIN_RADIUS)[:, None, None]
    offsets = r_n * np.cos(theta)[None, :, None] * normal[:, None, :]
    offsets = offsets + r_b * np.sin(theta)[None, :, None] * binormal[:, None, :]
    return (mean[:, None, :] + offsets).reshape(-1, 3).astype(np.float32)
