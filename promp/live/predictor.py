"""The online predictor stage: the movement observed so far, through the method, once per
update.

Each update takes every row of the movement so far (its observed modalities, in the model's
layout order; angles unwrapped, as :meth:`promp.data.Layout.extract` does for a
demonstration) as one :class:`promp.inference.Observation` whose times count from the
movement's first row, and infers on it (:meth:`promp.evidence.Evidence.infer`) with the
movement's evidence extended by the new rows (:meth:`promp.evidence.Evidence.extended`), so
that the likelihood adds only their terms: the result is the one the offline engine
(:func:`promp.evidence.infer`) gives on the same samples to round-off (within 1e-9; the tests
check it), at a cost that does not grow with the rows already observed wherever recognition
scores the same speeds again. What the robot
needs is read from it (:class:`LivePrediction`): the primitives' probabilities, the phase (the
share of the movement observed) and the duration with their intervals, the time left, and the
predicted remainder of one modality at a stated rate (:class:`Remainder`, from the posterior
with :func:`promp.inference.trajectory_at`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from promp.duration import Estimate
from promp.evidence.evidence import Evidence, Inference
from promp.evidence.speed import ALPHA_METHODS
from promp.inference import Observation, trajectory_at
from promp.live.helper import Helper, shares
from promp.model import ProMPModel

if TYPE_CHECKING:
    from promp.live.commitment import Commitment

__all__ = ["LivePrediction", "observed_columns", "OnlinePredictor", "Remainder", "REMAINDER_HZ"]

REMAINDER_HZ = 50.0


@dataclass(frozen=True, eq=False)
class Remainder:
    """The predicted rest of one modality, from the last observed sample to the predicted end.

    Attributes
    ----------
    modality : str
    columns : tuple of str
    after : array, shape (k,)
        Seconds after the last observed sample: ``1/rate, 2/rate, ...`` before the predicted
        end, and the end itself (the last row; 0 when the movement is predicted to be over).
    mean, std : array, shape (k, n_columns)
        In the modality's unit (metres, radians...): the posterior trajectory distribution.
    """

    modality: str
    columns: tuple[str, ...]
    after: np.ndarray
    mean: np.ndarray
    std: np.ndarray


@dataclass(frozen=True, eq=False)
class LivePrediction:
    """One update of the online predictor.

    Attributes
    ----------
    seq : int
        Counts the session's predictions from 1.
    movement : int
        The movement's number (:class:`promp.live.segmenter.Movement`).
    start, last : float
        The movement's first and the latest observed sample, seconds on the session's clock.
    observation : Observation
        What was observed (times from the movement's start).
    inference : Inference
        :meth:`promp.evidence.Evidence.infer` on it.
    remainder : Remainder or None
    compute_s : float
        The time the inference took.
    committed : Commitment or None
        With ``--decide``, the movement's commitment once made, by this prediction or an
        earlier one (:mod:`promp.live.commitment`).
    """

    seq: int
    movement: int
    start: float
    last: float
    observation: Observation
    inference: Inference
    remainder: Remainder | None
    compute_s: float
    committed: Commitment | None = None

    @property
    def n_observed(self) -> int:
        return self.observation.n_observed

    @property
    def elapsed(self) -> float:
        return self.inference.observed_until

    @property
    def probabilities(self) -> np.ndarray:
        return self.inference.probabilities

    @property
    def primitive(self) -> str:
        return self.inference.primitive

    @property
    def phase(self) -> Estimate:
        """The share of the movement observed, with its interval."""
        return self.inference.timing.observed_fraction

    @property
    def duration(self) -> Estimate:
        """The whole movement's duration (s), with its interval."""
        return self.inference.timing.duration

    @property
    def remaining(self) -> Estimate:
        """Seconds left after the last observed sample, with their interval."""
        return self.inference.timing.remaining_after(self.elapsed)


class OnlinePredictor:
    """Predictions from the rows of a movement (see the module docstring).

    Parameters
    ----------
    model : ProMPModel
    columns : mapping of str to slice
        Each observed modality's columns in the rows.
    alpha_method : {"ml", "model"}
    remainder : str, optional
        The modality whose predicted remainder is given (observed or not).
    rate : float
        The remainder's rate, Hz.
    n_points : int, optional
        Passed to :meth:`promp.evidence.Evidence.infer` (the prior and posterior's samples;
        the studio draws its tubes on a fixed number).
    helper : bool
        Share recognition with a helper process (:mod:`promp.live.helper`: an update in
        about three quarters of the time on two cores, the same numbers). It starts with
        :meth:`open` or the first update, and shares the movements that start once it is
        ready; :meth:`close` stops it.
    """

    def __init__(
        self,
        model: ProMPModel,
        columns: Mapping[str, slice],
        alpha_method: str = "ml",
        remainder: str | None = None,
        rate: float = REMAINDER_HZ,
        n_points: int | None = None,
        helper: bool = False,
    ):
        names = model.layout.names
        unknown = [m for m in columns if m not in names]
        if unknown:
            raise ValueError(
                f"the model has no modality {unknown[0]!r}; its modalities are {list(names)}"
            )
        if not columns:
            raise ValueError("observe at least one of the model's modalities")
        if alpha_method not in ALPHA_METHODS:
            raise ValueError(f"alpha_method must be one of {ALPHA_METHODS}, got {alpha_method!r}")
        if remainder is not None:
            model.layout.modality(remainder)  # raises on an unknown name
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"the remainder's rate must be a positive number of Hz, got {rate}")
        self.model = model
        self.modalities = tuple(m for m in names if m in columns)
        self._index = np.concatenate([np.arange(columns[m].start, columns[m].stop)
                                      for m in self.modalities])  # fmt: skip
        angle = model.layout.angle_mask()[model.layout.dims(self.modalities)]
        self._angles = np.flatnonzero(angle)
        self.alpha_method = alpha_method
        self.remainder = remainder
        self.rate = float(rate)
        self.n_points = n_points
        self._seq = 0
        self._movement: int | None = None  # the movement the evidence is of
        self._evidence: Evidence | None = None
        self._helper_wanted = helper and len(model.primitives) > 1
        self._helper: Helper | None = None
        self._shared = False  # the movement under way's recognition is shared with it
        self._last = len(model.primitives) - 1  # the primitive recognised last
        self._said = ""  # the helper's failure, once said

    def open(self) -> None:
        """Start the helper process, if one was asked for (it loads the model meanwhile)."""
        if self._helper_wanted and self._helper is None:
            from promp.io import model_to_json

            self._helper = Helper(model_to_json(self.model), self.alpha_method, self.modalities)

    def close(self) -> None:
        """Stop the helper process (updates after it are computed in this process)."""
        self._helper_wanted = False
        if self._helper is not None:
            self._helper.close()

    def news(self) -> str:
        """Why the helper stopped, once (then ''): the updates are computed here since."""
        helper = self._helper
        if helper is None or helper.alive or self._said or not self._helper_wanted:
            return ""
        self._said = helper.failure
        return self._said

    def observation(self, times: np.ndarray, values: np.ndarray) -> Observation:
        """The movement's rows ``times`` (n,), ``values`` (n, n_channels) as an observation
        of the observed modalities (layout order, angles unwrapped, times from the first)."""
        observed = np.array(values[:, self._index], dtype=float)
        if self._angles.size:
            observed[:, self._angles] = np.unwrap(observed[:, self._angles], axis=0)
        return Observation(times - times[0], observed, self.modalities)

    def predict(self, number: int, times: np.ndarray, values: np.ndarray) -> LivePrediction:
        """One update from the rows of movement ``number`` so far.

        Raises
        ------
        ValueError
            From the engine (an observation it refuses).
        """
        obs = self.observation(times, values)
        began = time.perf_counter()
        if number != self._movement or self._evidence is None:  # a new movement
            self._movement = number
            self._evidence = Evidence(self.model, obs, self.alpha_method)
            self.open()
            self._shared = self._helper is not None and self._helper.ready()
        else:
            self._evidence = self._evidence.extended(obs)
        if self._shared:
            self._shared = self._share(number, obs)
        inference = self._evidence.infer(n_points=self.n_points)
        self._last = inference.recognition.index
        remainder = self._remainder(inference) if self.remainder else None
        self._seq += 1
        return LivePrediction(
            self._seq, number, float(times[0]), float(times[-1]), obs, inference, remainder,
            time.perf_counter() - began,
        )  # fmt: skip

    def _share(self, number: int, obs: Observation) -> bool:
        """The helper integrates its primitives while this process integrates its own and
        prepares the primitive recognised last (:mod:`promp.live.helper`); False when the
        helper failed (what it did not give is computed here, by :meth:`Evidence.infer`)."""
        evidence, helper, ahead = self._evidence, self._helper, self._last
        own, theirs = shares(len(self.model.primitives))
        first = sorted(theirs, key=lambda k: k != ahead)  # the one recognised last, first
        if not helper.submit(number, obs, first):
            return False
        try:
            for k in sorted(own, key=lambda k: k != ahead):
                evidence.integral(k)
            if ahead in theirs:
                got = helper.collect()
                if got is None:
                    return False
                evidence.adopt(got)
            try:
                evidence.prepare(ahead, self.n_points)
            except ValueError:  # what infer will say, if it is the one recognised
                pass
            while helper.waiting:
                got = helper.collect()
                if got is None:
                    return False
                evidence.adopt(got)
        finally:
            helper.forget()
        return True

    def _remainder(self, inference: Inference) -> Remainder:
        elapsed, duration = inference.observed_until, inference.duration
        left = max(duration - elapsed, 0.0)
        after = np.arange(1, int(math.ceil(left * self.rate)) + 1) / self.rate
        after = np.append(after[after < left], left)
        phases = np.clip((elapsed + after) / duration, 0.0, 1.0) if duration > 0 else \
            np.ones_like(after)  # fmt: skip
        mean, std = trajectory_at(self.model, inference.posterior, inference.alpha, phases)
        modality = self.model.layout.modality(self.remainder)
        dims = self.model.layout.dims([self.remainder])
        return Remainder(modality.name, modality.columns, after, mean[:, dims], std[:, dims])


def observed_columns(names: Sequence[str], widths: Sequence[int]) -> dict[str, slice]:
    """Each input's columns in the rows (inputs side by side in ``names``' order)."""
    out, start = {}, 0
    for name, width in zip(names, widths, strict=True):
        out[name] = slice(start, start + int(width))
        start += int(width)
    return out
