"""Radial basis functions over the phase (paper Eq. 1).

A trajectory of one dimension is ``xi(z) = phi(z)^T w``, with ``phi`` the normalised Gaussian
basis over the phase ``z`` in [0, 1]. Several dimensions use the same basis each, so the
multi-dimensional basis is block-diagonal: weights are stored dimension-major,
``w = [w_dim0 (M), w_dim1 (M), ...]``.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

__all__ = ["PhaseBasisCache", "RBFBasis", "SeedBasis"]


@dataclass(frozen=True)
class RBFBasis:
    """``n_basis`` normalised Gaussians with centres evenly spaced on [0, 1].

    Parameters
    ----------
    n_basis : int
        M, the number of basis functions per dimension (>= 2).
    width : float
        Standard deviation of each Gaussian as a multiple of the spacing between centres
        (``1 / (M - 1)``): the widths are tied to the spacing, so the same ``width`` gives the
        same overlap for any M.
    """

    n_basis: int = 20
    width: float = 1.0

    def __post_init__(self) -> None:
        if int(self.n_basis) != self.n_basis or self.n_basis < 2:
            raise ValueError(f"n_basis must be an integer >= 2, got {self.n_basis}")
        if not np.isfinite(self.width) or self.width <= 0:
            raise ValueError(f"width must be a positive number, got {self.width}")
        centres = np.linspace(0.0, 1.0, self.n_basis)
        centres.setflags(write=False)
        object.__setattr__(self, "_centres", centres)

    @property
    def centres(self) -> np.ndarray:
        return self._centres

    @property
    def sigma(self) -> float:
        return self.width / (self.n_basis - 1)

    def __call__(self, z: np.ndarray) -> np.ndarray:
        """Basis values at phases ``z``, array of shape (len(z), n_basis); rows sum to 1."""
        z = np.asarray(z, dtype=float).reshape(-1, 1)
        return self._normalised(z, self._centres[None, :], axis=1)

    def columns(self, z: np.ndarray) -> np.ndarray:
        """Basis values at phases ``z`` of shape (..., n), the basis functions along a new
        axis -2: shape (..., n_basis, n), each column summing to 1. The numbers of
        :meth:`__call__`, laid out so that the samples are the contiguous axis (the
        likelihood's sums over samples, :mod:`promp.evidence.sums`)."""
        z = np.asarray(z, dtype=float)[..., None, :]
        return self._normalised(z, self._centres[:, None], axis=-2)

    def _normalised(self, z: np.ndarray, centres: np.ndarray, axis: int) -> np.ndarray:
        """The normalised Gaussians of phases ``z`` around ``centres`` (shapes that broadcast,
        the centres along ``axis``)."""
        values = (z - centres) / self.sigma
        np.square(values, out=values)
        outside = (z < 0.0) | (z > 1.0)
        if outside.any():
            # Subtract the row maximum of the exponent before exp: phases far outside [0, 1]
            # would otherwise underflow every Gaussian and leave 0/0. The maximum is at the
            # nearest centre, so it is the exponent of the clipped phase. (Inside [0, 1] the
            # nearest centre is at most half a spacing away: nothing underflows.)
            nearest = (z - np.clip(z, 0.0, 1.0)) / self.sigma
            values -= nearest**2
        np.multiply(values, -0.5, out=values)
        np.exp(values, out=values)
        values /= values.sum(axis=axis, keepdims=True)
        return values


class PhaseBasisCache:
    """The basis at the phases ``elapsed / duration``, cached per duration.

    Scrubbing an observation re-scores the same candidate durations on a growing prefix of the
    same samples, so each duration keeps the longest ``elapsed`` seen and its basis rows; a
    request for a prefix of it is a slice. Bounded. Shared by the threads that infer with one
    model: the entries are read and replaced under a lock, and an entry's arrays are never
    written once stored (a thread that copies from one while another replaces it still copies
    the rows it found).
    """

    def __init__(self, basis: RBFBasis, max_entries: int = 512):
        self.basis = basis
        self.max_entries = max_entries
        self._entries: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self._lock = threading.Lock()

    def __call__(self, elapsed: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """Basis rows, shape (len(durations), len(elapsed), n_basis)."""
        n = elapsed.shape[0]
        out = np.empty((durations.shape[0], n, self.basis.n_basis))
        missing = []
        with self._lock:
            found = [self._entries.get(d) for d in durations.tolist()]
        for i, entry in enumerate(found):
            if (
                entry is not None
                and entry[0].shape[0] >= n
                and np.array_equal(entry[0][:n], elapsed)
            ):
                out[i] = entry[1][:n]
            else:
                missing.append(i)
        if missing:  # one basis evaluation for every missing duration
            rows = self.basis((elapsed[None, :] / durations[missing, None]).reshape(-1))
            rows = rows.reshape(len(missing), n, -1)  # the cache's own: never handed out
            out[missing] = rows
            seen = elapsed.copy()
            seen.setflags(write=False)
            rows.setflags(write=False)
            with self._lock:
                if len(self._entries) + len(missing) > self.max_entries:
                    self._entries.clear()
                for j, i in enumerate(missing):
                    self._entries[float(durations[i])] = (seen, rows[j])
        return out


@dataclass(frozen=True)
class SeedBasis:
    """The original toolbox's basis, kept only for the ``--method seed`` baseline.

    ``M`` Gaussians with centres ``(i - 1) / M`` (i = 1..M, so none at z = 1) and
    ``exp(-(z - c)^2 / (1 / M^2))``, normalised.
    """

    n_basis: int = 5

    @property
    def centres(self) -> np.ndarray:
        return np.arange(self.n_basis) / self.n_basis

    def __call__(self, z: np.ndarray) -> np.ndarray:
        z = np.asarray(z, dtype=float).reshape(-1, 1)
        exponent = -((z - self.centres[None, :]) ** 2) * self.n_basis**2
        exponent -= exponent.max(axis=1, keepdims=True)
        values = np.exp(exponent)
        return values / values.sum(axis=1, keepdims=True)
