"""The standard early-classification baselines as evaluation methods: ``--method dtw`` and
``--method prefix-nn``.

Both see what ``ours`` sees (the first ``n_observed`` samples of the observed modalities of the
held-out demonstration; never its duration) and answer with the primitive of the nearest
training demonstration (:func:`promp.baselines.nearest.nearest_primitive`, softmin
probabilities):

* ``dtw``: open-end DTW 1-NN (:class:`promp.baselines.dtw.OpenEndDTW`);
* ``prefix-nn``: prefix 1-NN with a phase search over 50 fractions of each training
  demonstration (:func:`promp.baselines.prefix.prefix_search`).

Positions are relative to the first sample (the observation's and each training
demonstration's own), and divided by their spread over the training demonstrations
(:func:`promp.baselines.relative.column_spread`, computed at fit over every column, so the
scale of a column does not depend on what else is observed): metres, radians and newtons mix.
By default (``scaling="modality"``) the columns of a modality of one unit (the hand in m, the
head in rad) share one scale, keeping its Euclidean geometry; the columns of a modality of
mixed or unknown units (a wrench's N and N m) are scaled one by one. ``"column"`` scales every
column alone, ``"none"`` compares the raw values (:data:`SCALINGS`).

They predict no trajectory, no speed and no duration: alpha, the duration and every trajectory
are NaN, so the position, goal and duration errors of their rows are NaN ("n/a" in the tables).
The speed is not theirs to estimate, so their answer is the same for every alpha row (computed
once per observation, then reused).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from promp.baselines.dtw import OpenEndDTW
from promp.baselines.nearest import nearest_primitive
from promp.baselines.prefix import prefix_search
from promp.baselines.relative import column_spread, relative_to_start
from promp.data import Demonstration, Layout
from promp.evaluate.methods import TrialAnswer

__all__ = [
    "DTWBaseline",
    "NearestNeighbourBaseline",
    "PrefixBaseline",
    "scale_groups",
    "SCALINGS",
]

SCALINGS = ("modality", "column", "none")


class NearestNeighbourBaseline:
    """A 1-NN baseline over movements relative to their start (see the module docstring).

    Parameters
    ----------
    layout : Layout
    scaling : {"modality", "column", "none"}
        How the columns are scaled (see the module docstring).
    """

    name = ""

    def __init__(self, layout: Layout, scaling: str = "modality"):
        if scaling not in SCALINGS:
            raise ValueError(f"scaling must be one of {SCALINGS}, got {scaling!r}")
        self.layout = layout
        self.scaling = scaling
        self.movements: list[np.ndarray] = []  # training, relative and scaled: (m_i, n_dims)
        self.labels: list[int] = []
        self.n_primitives = 0
        self.scale = np.ones(layout.n_dims)
        self._last: tuple | None = None  # (demo, n_observed, observed) -> TrialAnswer

    def fit(self, dataset: Mapping[str, Sequence[Demonstration]], sample_period: float) -> None:
        """Keep the training demonstrations, relative to their start and scaled.

        Raises
        ------
        ValueError
            No demonstrations, or one of fewer than 2 samples.
        """
        raw, labels = [], []
        for k, demos in enumerate(dataset.values()):
            for demo in demos:
                raw.append(
                    relative_to_start(self.layout.extract(demo), f"demonstration {demo.name!r}")
                )
                labels.append(k)
        if not raw:
            raise ValueError("the baseline needs at least one training demonstration")
        if self.scaling == "none":
            self.scale = np.ones(self.layout.n_dims)
        else:
            self.scale = column_spread(raw, scale_groups(self.layout, self.scaling))
        self.movements = [m / self.scale for m in raw]
        self.labels = labels
        self.n_primitives = len(dataset)
        self._forget()

    def infer(
        self, demo: Demonstration, n_observed: int, observe: Sequence[str], alpha_method: str
    ) -> TrialAnswer:
        """The nearest primitive given the first ``n_observed`` samples of ``observe``.

        Raises
        ------
        ValueError
            Not fitted, an unknown modality, or fewer than 2 samples observed.
        """
        if not self.movements:
            raise ValueError("fit the baseline before inferring")
        key = (demo, int(n_observed), tuple(observe))
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        dims = self.layout.dims(observe)
        observed = self.layout.extract(demo)[: int(n_observed), dims]
        query = relative_to_start(observed, f"the observation of {demo.name!r}") / self.scale[dims]
        distances = self._distances(query, demo, dims)
        index, probabilities, _ = nearest_primitive(distances, self.labels, self.n_primitives)
        nothing = np.full((2, self.layout.n_dims), np.nan)
        inferred = TrialAnswer(
            index=index,
            probabilities=probabilities,
            alpha=float("nan"),
            duration=float("nan"),
            prior_mean=nothing,
            prior_std=nothing,
            posterior_mean=nothing,
            posterior_std=nothing,
        )
        self._last = (key, inferred)
        return inferred

    def _forget(self) -> None:
        """Drop what was computed for the previous training set."""
        self._last = None

    def _distances(self, query: np.ndarray, demo: Demonstration, dims: np.ndarray) -> np.ndarray:
        """The distance of ``query`` (n_observed, len(dims)), relative and scaled, to every
        training demonstration: (n_training,)."""
        raise NotImplementedError


def scale_groups(layout: Layout, scaling: str) -> list[int]:
    """A group number per column of ``layout``: the columns of one group share a scale. With
    ``"modality"``, a modality of angles or of one unit is one group, and each column of a
    modality of mixed (``"N|N m"``) or unknown units its own; with ``"column"``, every column
    its own."""
    groups: list[int] = []
    for modality in layout.modalities:
        unit = modality.unit or ""
        shared = scaling == "modality" and (
            modality.kind == "angle" or (unit != "" and "|" not in unit)
        )
        first = len(groups)
        groups.extend(first if shared else first + i for i in range(len(modality.columns)))
    return groups


class DTWBaseline(NearestNeighbourBaseline):
    """Open-end DTW 1-NN, relative to the start (``--method dtw``)."""

    name = "dtw"

    def __init__(self, layout: Layout, scaling: str = "modality"):
        super().__init__(layout, scaling)
        self._demo: Demonstration | None = None  # the demonstration aligned so far
        self._alignments: dict[tuple[int, ...], OpenEndDTW] = {}  # its, by observed columns

    def _forget(self) -> None:
        super()._forget()
        self._demo, self._alignments = None, {}

    def _distances(self, query: np.ndarray, demo: Demonstration, dims: np.ndarray) -> np.ndarray:
        # The evaluation asks for growing observations of one demonstration: each new sample
        # costs one row of the recursion (promp.baselines.dtw.OpenEndDTW), not a new alignment.
        if demo is not self._demo:
            self._demo, self._alignments = demo, {}
        key = tuple(int(d) for d in dims)
        if key not in self._alignments:
            self._alignments[key] = OpenEndDTW([m[:, dims] for m in self.movements])
        dtw = self._alignments[key]
        n = query.shape[0]
        if n > dtw.n_observed:
            dtw.extend(query[dtw.n_observed :])
        return dtw.distances[n - 1]


class PrefixBaseline(NearestNeighbourBaseline):
    """Prefix 1-NN with a phase search, relative to the start (``--method prefix-nn``)."""

    name = "prefix-nn"

    def _distances(self, query: np.ndarray, demo: Demonstration, dims: np.ndarray) -> np.ndarray:
        return prefix_search(query, [m[:, dims] for m in self.movements])[0]
