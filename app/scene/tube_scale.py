"""When a tube is too wide to be read as a band: wider than its position's workspace.

A tube is the region where a share of the movements are at each moment
(:mod:`app.scene.tubes`). Where the movements differ a lot (a loose handover, another lab's
people) it can measure a metre across: as a translucent band it is a blob that covers every
path and every other tube, and says only that the hand can be anywhere. Such a tube is drawn
as its outline (thin rings and lines) whatever the tube style, and the line that says what a
tube is states its width (:mod:`app.ui.tube_style`).

Too wide means wider than the workspace of its position: the box that every primitive's mean
path of that position (the robot's hand, a partner's hand) fits in, its longest side
(:func:`workspace_extent`: what the model learned of where that position goes, per position,
at any scale). On the three shared lab sets and the default workspace the widest tube is at
most 0.42 of that extent; on the handover set of the tests, 2 to 5 times it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from app.live.regions import TUBE_POINTS, PositionView
from app.scene.tubes import TubeLook, ring_widths
from promp.model import ProMPModel
from promp.region import SampleDistribution

WIDER_THAN = 1.0  # a tube wider than this share of its position's workspace: an outline


@dataclass(frozen=True)
class TubeWidth:
    """How wide the tube of ``name`` is (``width``, its widest ring, metres) beside the
    workspace of its position (``extent``, metres)."""

    name: str
    width: float
    extent: float

    @property
    def too_wide(self) -> bool:
        """Wider than its workspace: drawn as an outline."""
        return self.width > WIDER_THAN * self.extent


def workspace_extent(model: ProMPModel, modality: str, n_points: int = TUBE_POINTS) -> float:
    """The longest side (metres) of the box that every primitive's prior mean path of
    ``modality`` (three columns) fits in."""
    dims = model.layout.dims([modality])
    phases = model.basis(np.linspace(0.0, 1.0, n_points))  # (n_points, n_basis)
    paths = [np.asarray(p.mean).reshape(model.n_dims, -1)[dims] @ phases.T
             for p in model.primitives]  # fmt: skip
    points = np.concatenate(paths, axis=1)  # (3, n)
    return float(np.max(np.ptp(points, axis=1)))


def tube_width(
    name: str, region: SampleDistribution, probability: float, extent: float
) -> TubeWidth:
    """The width of ``region``'s tube at ``probability`` beside ``extent``."""
    return TubeWidth(name, float(np.max(ring_widths(region, probability))), float(extent))


def drawn_look(look: TubeLook, width: TubeWidth) -> TubeLook:
    """``look`` for a tube of ``width``: its outline instead of a band when too wide."""
    if look.surface and width.too_wide:
        return TubeLook(look.probability, surface=False, outline=True)
    return look


def position_widths(
    model: ProMPModel, positions: Sequence[PositionView], probability: float
) -> dict[str, TubeWidth]:
    """The width of each position's region (an inference's, :class:`PositionView`) at
    ``probability``, beside its position's workspace in ``model``."""
    return {
        view.modality: tube_width(view.modality, view.region, probability,
                                  workspace_extent(model, view.modality))
        for view in positions
    }  # fmt: skip
