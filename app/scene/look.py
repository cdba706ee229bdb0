"""What the 3D view shows, decided in one place: a pure function of the panel in use and of
the Infer panel's display options.

- **Teach** (and **Data**, which has nothing of its own in 3D): the workspace, i.e. the
  demonstrations (those the user hid excepted) and the prior tubes; Teach adds the ghost of
  the selected primitive's start (where its demonstrations begin, where a take should too).
- **Infer**, while it shows an inference in 3D: the observation, the posterior tube and the
  predicted path, with the workspace as its "Session priors" option says: *shown* as in Teach,
  *faded* (tubes dimmed, demonstrations hidden) or *hidden*.

The panel in use is the one whose controls a browser used last. viser's tab groups keep the
selected tab in the browser (no message tells the server, and its dock lets a user pull tabs out
side by side), so the server cannot know which tab is on screen; the scene, like every GUI state
of the studio, is shared by all browser tabs.
"""

from __future__ import annotations

from dataclasses import dataclass

TEACH, INFER, DATA = "teach", "infer", "data"
PANELS = (TEACH, INFER, DATA)
SHOWN, FADED, HIDDEN = "shown", "faded", "hidden"
PRIOR_MODES = (SHOWN, FADED, HIDDEN)


@dataclass(frozen=True)
class Look:
    """What is drawn.

    Attributes
    ----------
    demos : bool
        The demonstration lines (each still hidden when the user hid it).
    priors : {"shown", "faded", "hidden"}
        The prior tubes: at their own opacity, dimmed, or not drawn.
    inference : bool
        The Infer layer: observation, posterior tube, predicted path and end point.
    start : bool
        The ghost of the selected primitive's start pose (Teach).
    """

    demos: bool
    priors: str
    inference: bool
    start: bool = False


WORKSPACE_LOOK = Look(demos=True, priors=SHOWN, inference=False)
TEACH_LOOK = Look(demos=True, priors=SHOWN, inference=False, start=True)


def look(panel: str, inference_shown: bool, priors: str = SHOWN) -> Look:
    """What the scene draws while ``panel`` is in use.

    Parameters
    ----------
    panel : {"teach", "infer", "data"}
    inference_shown : bool
        The Infer panel has an inference to show in 3D (a result, "Show in 3D" on, a hand
        modality).
    priors : {"shown", "faded", "hidden"}
        The Infer panel's "Session priors" option.

    Raises
    ------
    ValueError
        An unknown panel or priors option.
    """
    if panel not in PANELS:
        raise ValueError(f"unknown panel {panel!r}; expected one of {', '.join(PANELS)}")
    if priors not in PRIOR_MODES:
        raise ValueError(f"unknown priors option {priors!r}; expected {', '.join(PRIOR_MODES)}")
    if panel == TEACH:
        return TEACH_LOOK
    if panel != INFER or not inference_shown:
        return WORKSPACE_LOOK
    return Look(demos=priors == SHOWN, priors=priors, inference=True)
