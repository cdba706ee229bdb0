"""Demonstrations and modality layouts.

A :class:`Demonstration` is a timed multi-dimensional recording with named columns. A
:class:`Layout` groups columns into :class:`Modality` blocks (e.g. ``hand`` = x, y, z in metres,
``head`` = roll, pitch, yaw in radians); the engine works on the layout's columns, in its order.
"""

from __future__ import annotations

import weakref
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from itertools import combinations
from typing import Literal

import numpy as np

from promp._recent import per_object

__all__ = [
    "Demonstration", "Kind", "Layout", "MAX_MAGNITUDE", "Modality", "check_values",
    "sample_period_of"
]  # fmt: skip

Kind = Literal["linear", "angle"]

# No sensor in any sensible unit reads beyond this; such values (a unit or parsing mistake)
# would overflow the squares and products of the fit.
MAX_MAGNITUDE = 1e12


def check_values(times: np.ndarray, values: np.ndarray, label: str) -> None:
    """ValueError unless ``times`` and ``values`` are finite and ``values`` within
    +-:data:`MAX_MAGNITUDE`; ``label`` names the data in the message."""
    if not np.all(np.isfinite(times)) or not np.all(np.isfinite(values)):
        raise ValueError(f"{label}: contains NaN or infinite values")
    if values.size and float(np.max(np.abs(values))) > MAX_MAGNITUDE:
        raise ValueError(
            f"{label}: a value of magnitude {float(np.max(np.abs(values))):.3g} is beyond "
            f"{MAX_MAGNITUDE:.0e} (check the units or the file)"
        )


def _frozen(array: np.ndarray) -> np.ndarray:
    out = np.array(array, dtype=float, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class Demonstration:
    """One recorded movement.

    Parameters
    ----------
    times : array, shape (n_samples,)
        Sample times in seconds, strictly increasing.
    values : array, shape (n_samples, n_columns)
        The recorded values, one column per name in ``columns``.
    columns : tuple of str, length n_columns
        Column names.
    name : str
        Identifier (e.g. the file stem); informative only.

    The arrays are copied and made read-only: nothing outside can mutate a demonstration.
    """

    times: np.ndarray
    values: np.ndarray
    columns: tuple[str, ...]
    name: str = ""

    def __post_init__(self) -> None:
        times = np.asarray(self.times, dtype=float)
        values = np.asarray(self.values, dtype=float)
        label = f"demonstration {self.name!r}" if self.name else "demonstration"
        if values.ndim == 1:
            values = values[:, None]
        if times.ndim != 1 or values.ndim != 2:
            raise ValueError(
                f"{label}: times must be 1-D and values 2-D (n_samples, n_columns), "
                f"got shapes {times.shape} and {values.shape}"
            )
        if times.shape[0] != values.shape[0]:
            raise ValueError(
                f"{label}: {times.shape[0]} times but {values.shape[0]} rows of values"
            )
        if times.shape[0] < 2:
            raise ValueError(f"{label}: needs at least 2 samples, got {times.shape[0]}")
        columns = tuple(str(c) for c in self.columns)
        if len(columns) != values.shape[1]:
            raise ValueError(
                f"{label}: {len(columns)} column names for {values.shape[1]} value columns"
            )
        if len(set(columns)) != len(columns):
            raise ValueError(f"{label}: duplicate column names in {columns}")
        check_values(times, values, label)
        if np.any(np.diff(times) <= 0):
            raise ValueError(f"{label}: times must be strictly increasing")
        object.__setattr__(self, "times", _frozen(times))
        object.__setattr__(self, "values", _frozen(values))
        object.__setattr__(self, "columns", columns)

    @property
    def n_samples(self) -> int:
        return int(self.times.shape[0])

    @property
    def duration(self) -> float:
        """Time from the first to the last sample, in seconds."""
        return float(self.times[-1] - self.times[0])

    @property
    def sample_period(self) -> float:
        """Median time between samples, in seconds."""
        return float(np.median(np.diff(self.times)))

    def select(self, names: Sequence[str]) -> np.ndarray:
        """Columns ``names`` in that order, array of shape (n_samples, len(names))."""
        missing = [n for n in names if n not in self.columns]
        if missing:
            raise ValueError(
                f"demonstration {self.name!r} has no column(s) {missing}; "
                f"it has {list(self.columns)}"
            )
        index = [self.columns.index(n) for n in names]
        return self.values[:, index]


@dataclass(frozen=True)
class Modality:
    """A block of columns observed together, e.g. the hand position or the head orientation.

    Parameters
    ----------
    name : str
        What the observation names (``Observation.modalities``), e.g. ``"hand"``.
    columns : tuple of str
        The demonstrations' columns it is made of, in order, e.g. ``("x", "y", "z")``.
    unit : str
        Their unit (``"m"``, ``"rad"``...): noise and errors are in it.
    kind : {"linear", "angle"}
        ``"angle"`` columns are unwrapped before fitting and their errors taken on the circle.
    """

    name: str
    columns: tuple[str, ...]
    unit: str = "m"
    kind: Kind = "linear"

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("a modality needs a name")
        if not self.columns:
            raise ValueError(f"modality {self.name!r} has no columns")
        if self.kind not in ("linear", "angle"):
            raise ValueError(
                f"modality {self.name!r}: kind must be 'linear' or 'angle', got {self.kind!r}"
            )
        object.__setattr__(self, "columns", tuple(self.columns))

    @property
    def is_position(self) -> bool:
        """Whether it is a point in space: three linear columns in metres (a robot's hand, a
        partner's hand, a marker), or three linear columns of no stated unit whose names end in
        x, y and z, in that order (``hx, hy, hz``, ``marker_x, ...``: a CSV's columns other
        than x, y, z get no unit, and are taken for metres). A modality in another unit (a
        force in N, an orientation in rad) or of another size is not."""
        if self.kind != "linear" or len(self.columns) != 3:
            return False
        if self.unit == "m":
            return True
        named = all(c.lower().endswith(a) for c, a in zip(self.columns, "xyz", strict=True))
        return self.unit == "" and named


@dataclass(frozen=True)
class Layout:
    """The ordered modalities a model is learned over; dimension d of the model is column d.

    Parameters
    ----------
    modalities : tuple of Modality
        Distinct names and columns; ``n_dims`` is the total number of their columns.
    """

    modalities: tuple[Modality, ...]

    def __post_init__(self) -> None:
        mods = tuple(self.modalities)
        if not mods:
            raise ValueError("a layout needs at least one modality")
        names = [m.name for m in mods]
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate modality names in {names}")
        columns = [c for m in mods for c in m.columns]
        if len(set(columns)) != len(columns):
            raise ValueError(f"a column belongs to two modalities in {columns}")
        object.__setattr__(self, "modalities", mods)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.modalities)

    @property
    def columns(self) -> tuple[str, ...]:
        return tuple(c for m in self.modalities for c in m.columns)

    @property
    def n_dims(self) -> int:
        return len(self.columns)

    @property
    def positions(self) -> tuple[Modality, ...]:
        """The modalities that are points in space (:attr:`Modality.is_position`), in order."""
        return tuple(m for m in self.modalities if m.is_position)

    def modality(self, name: str) -> Modality:
        for m in self.modalities:
            if m.name == name:
                return m
        raise ValueError(f"unknown modality {name!r}; the layout has {list(self.names)}")

    def observed(self, names: Iterable[str]) -> tuple[str, ...]:
        """The modalities ``names`` as an observation may hold them: any non-empty set of the
        layout's, in layout order (a name given twice counts once). What ``--observe`` of the
        command lines accepts, and what :meth:`observable` lists.

        Raises
        ------
        ValueError
            An unknown name, or none.
        """
        wanted = list(names)
        for name in wanted:
            self.modality(name)  # raises on unknown names
        if not wanted:
            raise ValueError("no modality selected")
        return tuple(name for name in self.names if name in wanted)

    def observable(self) -> tuple[tuple[str, ...], ...]:
        """Every set of modalities an observation may hold (:meth:`observed`): all of them
        first, then each alone, then every combination of two, three, ... (in layout order);
        ``2 ** n - 1`` sets of ``n`` modalities."""
        names, sizes = self.names, range(1, len(self.names))
        return (names, *(self.observed(c) for k in sizes for c in combinations(names, k)))

    def dims(self, names: Iterable[str]) -> np.ndarray:
        """Model dimensions (column indices) of the modalities ``names``, in layout order."""
        wanted = self.observed(names)
        out: list[int] = []
        start = 0
        for m in self.modalities:
            if m.name in wanted:
                out.extend(range(start, start + len(m.columns)))
            start += len(m.columns)
        return np.array(out, dtype=int)

    def angle_mask(self) -> np.ndarray:
        """Boolean mask, shape (n_dims,), True for angular dimensions."""
        return np.array([m.kind == "angle" for m in self.modalities for _ in m.columns])

    def extract(self, demo: Demonstration) -> np.ndarray:
        """The layout's columns of ``demo``, shape (n_samples, n_dims); angles unwrapped.
        Read-only, and computed once per demonstration and layout (both immutable): a fit
        and the choice of its settings read the same demonstrations many times."""
        return per_object(_EXTRACTED, demo, self, lambda: self._extract(demo))

    def _extract(self, demo: Demonstration) -> np.ndarray:
        values = np.array(demo.select(self.columns), dtype=float)
        mask = self.angle_mask()
        if mask.any():
            values[:, mask] = np.unwrap(values[:, mask], axis=0)
        values.setflags(write=False)
        return values


_EXTRACTED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def sample_period_of(demos: Sequence[Demonstration]) -> float:
    """The recording period of a set of demonstrations: the median of their median steps."""
    return float(np.median([d.sample_period for d in demos]))
