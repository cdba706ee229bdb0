"""Distribution tubes: a hand path's mean with a +-k sigma cross-section, as a triangle mesh,
and how each tube style draws one (:func:`tube_look`, :func:`outline_segments`).

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

from dataclasses import dataclass

import numpy as np

from app.core.view_state import BANDS_1SD, BANDS_2SD, NO_TUBES, OUTLINE, TUBE_STYLES

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


# ---------------------------------------------------------------------- the tube styles

OUTLINE_RINGS = 11  # rings drawn along a tube in outline
OUTLINE_RAILS = 4  # lines drawn along a tube in outline, a quarter turn apart


@dataclass(frozen=True)
class TubeLook:
    """How one :data:`app.core.view_state.TUBE_STYLES` style draws a tube.

    Attributes
    ----------
    n_sigma : float
        The tube's radius in standard deviations of the path.
    surface : bool
        The translucent surface (a band).
    outline : bool
        Thin lines instead: :data:`OUTLINE_RINGS` rings and :data:`OUTLINE_RAILS` lines along.
    """

    n_sigma: float
    surface: bool
    outline: bool

    @property
    def shown(self) -> bool:
        return self.surface or self.outline


TUBE_LOOKS = {
    BANDS_2SD: TubeLook(2.0, surface=True, outline=False),
    BANDS_1SD: TubeLook(1.0, surface=True, outline=False),
    OUTLINE: TubeLook(2.0, surface=False, outline=True),
    NO_TUBES: TubeLook(2.0, surface=False, outline=False),
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
