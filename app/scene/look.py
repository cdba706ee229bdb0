"""What the 3D view may show: the panels and the "Session priors" options by name, and what
each panel asks it to show in a frame (:class:`Shown`). What it does show is decided in one
place, :func:`app.scene.scene_view.look`, a pure function of the panel in use and of the Infer
panel's display options:

- **Teach** (and **Data**, which has nothing of its own in 3D): the workspace, i.e. the
  demonstrations (those the user hid excepted) and the prior tubes; Teach adds the ghost of
  the selected primitive's start (where its demonstrations begin, where a take should too).
- **Infer**, while it shows an inference in 3D: the observation, the posterior tube and the
  predicted path, with the workspace as its "Session priors" option says: *shown* as in Teach,
  *faded* (tubes dimmed, demonstrations hidden) or *hidden*.

The panel in use is the tab a browser showed last (the page's script reports a tab chosen:
:mod:`app.ui.page_script`), or the one whose controls a browser used last (viser's dock lets a
user pull tabs out side by side). The scene, like every GUI state of the studio, is shared by
all browser tabs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.live.inference import InferResult

TEACH, INFER, DATA = "teach", "infer", "data"
PANELS = (TEACH, INFER, DATA)
SHOWN, FADED, HIDDEN = "shown", "faded", "hidden"
PRIOR_MODES = (SHOWN, FADED, HIDDEN)


@dataclass(frozen=True, eq=False)
class InferenceShown:
    """The Infer panel's inference (``result``, drawn in ``color``; None: nothing to draw) and
    its display options: ``in_3d`` ("Show in 3D") and ``priors`` ("Session priors")."""

    result: InferResult | None
    color: tuple[int, int, int]
    in_3d: bool = True
    priors: str = SHOWN


@dataclass(frozen=True, eq=False)
class StartShown:
    """Teach's ghost of the chosen primitive's start (``position`` None: it has none)."""

    position: np.ndarray | None
    color: tuple[int, int, int]


@dataclass(frozen=True)
class ViaShown:
    """The via-points a panel shows while it is in use: those of ``primitive`` (None: none),
    in ``color``."""

    panel: str
    primitive: str | None
    color: tuple[int, int, int]


@dataclass(frozen=True, eq=False)
class Shown:
    """What a panel asks the 3D view to show in one frame (None: nothing of that kind);
    ``vias``: each panel's via-points (the panel in use's are drawn)."""

    inference: InferenceShown | None = None
    start: StartShown | None = None
    vias: tuple[ViaShown, ...] = ()

    def merged(self, other: Shown | None) -> Shown:
        """This, with what ``other`` asks for where it asks for something."""
        if other is None:
            return self
        return Shown(other.inference or self.inference, other.start or self.start,
                     self.vias + other.vias)  # fmt: skip

    def vias_of(self, panel: str) -> ViaShown | None:
        """The via-points ``panel`` shows, if it shows any."""
        return next((v for v in self.vias if v.panel == panel), None)
