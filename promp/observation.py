"""The observation: the early part of a movement, in some of a model's modalities."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from promp.data import Demonstration, check_values
from promp.model import ProMPModel
from promp.timing import n_observed_for

__all__ = ["Observation", "check_observation", "observed_dims"]


@dataclass(frozen=True, eq=False)
class Observation:
    """The early part of a movement, in some of the model's modalities.

    Parameters
    ----------
    times : array, shape (n_observed,)
        Seconds; ``times[0]`` is the start of the movement.
    values : array, shape (n_observed, n_observed_dims)
        The columns of ``modalities``, in the layout's order (angles unwrapped).
    modalities : tuple of str
    """

    times: np.ndarray
    values: np.ndarray
    modalities: tuple[str, ...]

    def __post_init__(self) -> None:
        times = np.asarray(self.times, dtype=float)
        values = np.asarray(self.values, dtype=float)
        if times.ndim != 1 or times.shape[0] == 0:
            raise ValueError("the observation is empty: observe at least one sample")
        if values.ndim != 2 or values.shape[0] != times.shape[0]:
            raise ValueError(
                f"observation values must have shape ({times.shape[0]}, n_dims), got {values.shape}"
            )
        check_values(times, values, "the observation")
        if np.any(np.diff(times) <= 0):
            raise ValueError("observation times must be strictly increasing")
        if not self.modalities:
            raise ValueError("the observation names no modality")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "modalities", tuple(self.modalities))

    @property
    def n_observed(self) -> int:
        return int(self.times.shape[0])

    @property
    def elapsed(self) -> np.ndarray:
        """Seconds since the start of the movement, shape (n_observed,)."""
        return self.times - self.times[0]

    @classmethod
    def from_demo(
        cls, model: ProMPModel, demo: Demonstration, n_observed: int, modalities: Sequence[str]
    ) -> Observation:
        """The first ``n_observed`` samples of ``demo`` in ``modalities``."""
        if n_observed < 1:
            raise ValueError(f"n_observed must be >= 1, got {n_observed}")
        if n_observed > demo.n_samples:
            raise ValueError(
                f"cannot observe {n_observed} samples of a {demo.n_samples}-sample demonstration"
            )
        dims = observed_dims(model, modalities)
        values = model.layout.extract(demo)[:n_observed, dims]
        return cls(demo.times[:n_observed], values, tuple(modalities))

    @classmethod
    def first(
        cls, model: ProMPModel, demo: Demonstration, percent: float, modalities: Sequence[str]
    ) -> Observation:
        """The first ``percent`` % of ``demo`` in ``modalities``: its first
        :func:`promp.timing.n_observed_for` samples (the evaluation's rule, and the studio's).

        Raises
        ------
        ValueError
            If ``percent`` is not in (0, 100], or a modality is unknown.
        """
        return cls.from_demo(model, demo, n_observed_for(percent, demo.n_samples), modalities)

    @classmethod
    def first_live(
        cls,
        times: np.ndarray,
        values: np.ndarray,
        percent: float,
        modalities: Sequence[str],
    ) -> Observation:
        """The first ``percent`` % of a movement sampled as it happens, in ``modalities``.

        The share is taken of every sample (:func:`promp.timing.n_observed_for`, as
        :meth:`first`); a sample with a value missing (NaN: a sensor that saw nothing then,
        a face not found) is then left out, and the times start at the first one kept.

        Parameters
        ----------
        times : array, shape (n,)
            Seconds, increasing.
        values : array, shape (n, n_observed_dims)
            The columns of ``modalities`` in the layout's order; NaN where missed.
        percent : float
            In (0, 100].
        modalities : sequence of str

        Raises
        ------
        ValueError
            No sample, ``percent`` not in (0, 100], or a value missing in every sample of
            the share.
        """
        times, values = np.asarray(times, dtype=float), np.asarray(values, dtype=float)
        n_observed = n_observed_for(percent, times.shape[0])
        keep = np.all(np.isfinite(values[:n_observed]), axis=1)
        if not keep.any():
            raise ValueError(f"every one of the first {n_observed} samples has a value missing")
        kept = times[:n_observed][keep]
        return cls(kept - kept[0], values[:n_observed][keep], tuple(modalities))


def observed_dims(model: ProMPModel, modalities: Sequence[str]) -> np.ndarray:
    """Model dimensions of ``modalities`` (raises ValueError on unknown names)."""
    return model.layout.dims(modalities)


def check_observation(model: ProMPModel, obs: Observation) -> np.ndarray:
    """The model dimensions ``obs`` holds, shape (n_observed_dims,); ValueError if its columns
    do not match its modalities."""
    dims = observed_dims(model, obs.modalities)
    if obs.values.shape[1] != dims.shape[0]:
        raise ValueError(
            f"the observation has {obs.values.shape[1]} columns but modalities "
            f"{list(obs.modalities)} have {dims.shape[0]}"
        )
    return dims
