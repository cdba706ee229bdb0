"""How a guided hand moves in the simulated experiment: the path's shape and its timing.

- Path (:func:`smooth_path`): a C2 piecewise quintic through via points
  (``scipy.interpolate.BPoly.from_derivatives``): the grasp, the lift point, for a detour an
  apex, and the drop point; tangent up at the grasp and the lift point, horizontal towards the
  drop point at an apex, from the previous via point towards the drop point at the end, zero
  curvature at every via point. Each piece depends only on its two end via points, so paths
  that share their first via points share their first pieces exactly.
- Timing (:func:`arc_progress`): minimum jerk (:func:`minimum_jerk`) along the arc length. A
  movement starts with the law of the plain carry, ``s(tau) = L_direct mj(tau)``, and covers
  the extra length of a detour with a second minimum-jerk submovement superimposed from
  ``shared_fraction`` on, ``s(tau) = L_direct mj(tau) + (L - L_direct) mj((tau - f) / (1 - f))``
  (superposition of minimum-jerk units, Flash and Henis 1991), so that movements of different
  lengths coincide in time until ``f``. Zero velocity and acceleration at both ends.

Lengths in metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BPoly

# Samples of the dense path used to measure its arc length.
_DENSE_SAMPLES = 4000
_UP = np.array([0.0, 0.0, 1.0])
# Speed of the path's parameter at the lift point, relative to elsewhere: a tighter turn into the
# carry (the direct movement rises ~4 cm above the lift point rather than ~6 cm).
_LIFT_TANGENT = 0.5


def minimum_jerk(tau: np.ndarray) -> np.ndarray:
    """Minimum-jerk progress ``10 tau^3 - 15 tau^4 + 6 tau^5`` for ``tau`` in [0, 1], same shape."""
    tau = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    return tau**3 * (10.0 + tau * (-15.0 + 6.0 * tau))


def _unit(vector: np.ndarray) -> np.ndarray:
    norm = float(np.linalg.norm(vector))
    if norm < 1e-9:
        raise ValueError("two consecutive via points coincide: no direction between them")
    return vector / norm


@dataclass(frozen=True, eq=False)
class SmoothPath:
    """A smooth path through via points, sampled densely and measured along its length.

    Attributes
    ----------
    dense : array, shape (n_dense, 3)
        Points along the path.
    arc : array, shape (n_dense,)
        Arc length at each dense point, from 0 to :attr:`length`.
    knot_arc : array, shape (n_via,)
        Arc length at each via point.
    """

    dense: np.ndarray
    arc: np.ndarray
    knot_arc: np.ndarray

    @property
    def length(self) -> float:
        return float(self.arc[-1])

    def at(self, s: np.ndarray) -> np.ndarray:
        """Positions at arc lengths ``s``, shape (n,) -> (n, 3)."""
        return np.column_stack([np.interp(s, self.arc, self.dense[:, k]) for k in range(3)])


def smooth_path(points: np.ndarray) -> SmoothPath:
    """The C2 piecewise-quintic path through ``points`` (grasp, lift, [apex], drop).

    Tangents: up at the grasp and the lift point, horizontal towards the drop point at an apex,
    from the previous via point towards the drop point at the end; zero curvature at every via
    point. Each piece depends only on its two end via points (and their tangents), so paths
    that share their first via points share their first pieces exactly.

    Parameters
    ----------
    points : array, shape (n_via, 3), n_via >= 3

    Returns
    -------
    SmoothPath
    """
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 3:
        raise ValueError(f"points must have shape (n_via >= 3, 3), got {points.shape}")
    drop = points[-1]
    across = drop - points[1]
    across[2] = 0.0
    apexes = [_unit(across)] * (points.shape[0] - 3)
    tangents = [_UP, _LIFT_TANGENT * _UP, *apexes, _unit(drop - points[-2])]
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    if chords.min() < 1e-9:
        raise ValueError("two consecutive via points coincide: no direction between them")
    u = np.concatenate([[0.0], np.cumsum(chords)])
    # Parameter ~ arc length: unit tangents give about unit speed along each piece.
    poly = BPoly.from_derivatives(
        u, [[p, t, np.zeros(3)] for p, t in zip(points, tangents, strict=True)]
    )
    dense_u = np.linspace(0.0, u[-1], _DENSE_SAMPLES)
    dense = poly(dense_u)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    return SmoothPath(dense=dense, arc=arc, knot_arc=np.interp(u, dense_u, arc))


def arc_progress(
    tau: np.ndarray, length: float, direct_length: float, shared_fraction: float
) -> np.ndarray:
    """Arc length travelled at phase ``tau`` (see the module docstring), same shape as ``tau``.

    ``direct_length * mj(tau) + (length - direct_length) * mj((tau - f) / (1 - f))``: the timing
    of the direct movement, plus a minimum-jerk submovement from ``f = shared_fraction`` on that
    covers the extra length of a detour. Zero velocity and acceleration at both ends.

    Raises
    ------
    ValueError
        If the path is so much shorter than the direct one that the hand would move backwards.
    """
    f = shared_fraction
    s = direct_length * minimum_jerk(tau) + (length - direct_length) * minimum_jerk(
        (np.asarray(tau, dtype=float) - f) / (1.0 - f)
    )
    if np.any(np.diff(s) < -1e-12):
        raise ValueError(
            f"a path of {length:.3f} m cannot start with the timing of the {direct_length:.3f} m "
            "direct movement without moving backwards"
        )
    return s
