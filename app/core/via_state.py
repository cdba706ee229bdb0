"""The studio's via-points: points the user asks a primitive's hand to pass through, at a phase,
each with its precision (:mod:`promp.via_points` conditions on them).

They belong to the view, like the tube style: not written to the workspace, shared by every
browser tab, and never part of a model (an exported model is the learned one). Each names its
primitive: Teach shapes the primitive it shows, Infer the one it recognises; a via-point of a
primitive the workspace no longer has is ignored. A via-point has an ``id`` that stays while it
is dragged or retyped, so a row of the list and its handle in 3D stay the same one.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from promp.data import Layout
from promp.via_points import ViaPoint
from robots.icub.layout import HAND

MIN_STD_M, MAX_STD_M = 0.001, 1.0  # a precision of 1 mm to 1 m
MAX_COORDINATE_M = 10.0  # a via-point further than this from the robot is a typing mistake


@dataclass(frozen=True)
class StudioViaPoint:
    """A via-point of the ``hand`` of ``primitive``.

    Attributes
    ----------
    id : int
    primitive : str
    phase : float
        In [0, 1]: the share of the movement.
    position : tuple of 3 floats
        Metres, in the iCub's root frame (the workspace's hand frame).
    std : float
        Metres: the standard deviation of the point in every axis (its precision).
    """

    id: int
    primitive: str
    phase: float
    position: tuple[float, float, float]
    std: float

    def for_model(self, layout: Layout) -> ViaPoint:
        """The point for :func:`promp.via_points.condition_on_via_points` on ``layout``'s hand."""
        columns = layout.modality(HAND.name).columns
        return ViaPoint.isotropic(columns, self.position, self.std, phase=self.phase)


def checked(
    primitive: str, phase: float, position: Sequence[float], std: float, id: int = 0
) -> StudioViaPoint:
    """A via-point of these values, checked.

    Raises
    ------
    ValueError
        A phase outside [0, 1], a position with a coordinate not finite or beyond
        :data:`MAX_COORDINATE_M`, a precision outside [1 mm, 1 m]; in the units the user
        types (%, cm).
    """
    point = tuple(float(v) for v in np.asarray(position, dtype=float).reshape(-1))
    if len(point) != 3 or not all(math.isfinite(v) for v in point):
        raise ValueError(
            f"a via-point's position is three finite numbers (x, y, z), got {position}"
        )
    if max(abs(v) for v in point) > MAX_COORDINATE_M:
        raise ValueError(
            f"a via-point is at most {MAX_COORDINATE_M * 100:.0f} cm from the robot along each "
            f"axis; got x, y, z = {', '.join(f'{v * 100:.4g}' for v in point)} cm"
        )
    if not (math.isfinite(phase) and 0.0 <= phase <= 1.0):
        raise ValueError(
            f"a via-point's phase is 0 to 100 % of the movement, got {phase * 100:g} %"
        )
    if not (math.isfinite(std) and MIN_STD_M <= std <= MAX_STD_M):
        raise ValueError(
            f"a via-point's precision is ±{MIN_STD_M * 100:g} to ±{MAX_STD_M * 100:g} cm, "
            f"got ±{std * 100:g} cm"
        )
    return StudioViaPoint(int(id), str(primitive), float(phase), point, float(std))  # type: ignore[arg-type]


def of_primitive(points: Sequence[StudioViaPoint], primitive: str | None) -> tuple:
    """The via-points of ``primitive``, in the order they were added."""
    return tuple(p for p in points if p.primitive == primitive)


@dataclass(frozen=True, eq=False)
class LayoutViaPoints:
    """The via-points on one layout, by primitive, in the order they were added: as the
    studio draws them (``studio``) and as the method takes them (``method``: on the layout's
    hand, :meth:`StudioViaPoint.for_model`); none of either when the layout has no hand.
    What :meth:`promp.evidence.Evidence.infer` takes is ``method``: it uses the recognised
    primitive's."""

    studio: Mapping[str, tuple[StudioViaPoint, ...]]
    method: Mapping[str, tuple[ViaPoint, ...]]


NO_VIA_POINTS = LayoutViaPoints(MappingProxyType({}), MappingProxyType({}))


def by_primitive(points: Sequence[StudioViaPoint], layout: Layout) -> LayoutViaPoints:
    """``points`` on ``layout`` (see :class:`LayoutViaPoints`)."""
    if HAND.name not in layout.names or not points:
        return NO_VIA_POINTS
    studio: dict[str, tuple] = {}
    for point in points:
        studio[point.primitive] = (*studio.get(point.primitive, ()), point)
    method = {name: tuple(p.for_model(layout) for p in mine) for name, mine in studio.items()}
    return LayoutViaPoints(MappingProxyType(studio), MappingProxyType(method))
