"""What the learner publishes (:class:`LearnerState`, one immutable value per outcome) and the
settings a fit of some of the demonstrations uses (:func:`resolved_settings`).

Readers take the latest state lock-free (:attr:`app.core.learner.Learner.state`); the studio's
snapshot holds one (:class:`app.core.snapshot.Snapshot`). The automatic settings the model
chose are resolved once per refit, as it is published (:attr:`LearnerState.settings`): a
held-out model is fitted with them, never chosen again, and no frame resolves them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from app.core.fits import Fitted
from promp.data import Demonstration, Layout
from promp.model import ProMPModel, Settings
from promp.typicality import Typicality

HeldOutKey = tuple  # (learn_version, primitive, demo, repr(settings), the group rule or None)
# A take's score, by the id of the demonstration scored (held: its id stays its own): the
# demonstration and its typicality (None: too few others to score it).
Scores = Mapping[int, tuple[Demonstration, Typicality | None]]


@dataclass(frozen=True, eq=False)
class LearnerState:
    """What the learner has published (see the module docstring and
    :class:`app.core.learner.Learner`).

    Attributes
    ----------
    model : ProMPModel or None
        The latest model (None when nothing can be learned: ``error`` says why).
    error : str or None
    fit_ms : float
        The time its fit took (a reused model: the time of the fit it reuses).
    reused : bool
        It came from a recent fit of the same training.
    learn_version : int
        The store's ``learn_version`` the model was learned from (-1: none yet).
    n_demos : int
        The demonstrations it was learned from.
    request : int
        The refit request it answers (:meth:`app.core.learner.Learner.wait` waits for its own).
    held_out : mapping of HeldOutKey to Fitted
        Models learned without one demonstration, by :func:`app.core.learner.held_out_key`.
    scores : mapping of int to (Demonstration, Typicality or None)
        The takes' typicality, by the id of the demonstration scored (a take of the same
        name recorded again is another demonstration, scored anew).
    settings : Settings or None
        What a fit of some of the demonstrations of ``learn_version`` uses (a held-out model):
        the workspace's learning settings with every automatic one at the value ``model``
        chose (:func:`resolved_settings`), resolved once per refit (None before the first).
    """

    model: ProMPModel | None = None
    error: str | None = None
    fit_ms: float = 0.0
    reused: bool = False
    learn_version: int = -1
    n_demos: int = 0
    request: int = 0
    held_out: Mapping[HeldOutKey, Fitted] = field(default_factory=dict)
    scores: Scores = field(default_factory=dict)
    settings: Settings | None = None


def resolved_settings(settings: Settings, layout: Layout, model: ProMPModel | None) -> Settings:
    """``settings`` (a workspace's, over ``layout``) with every automatic one, the duration's
    temperature and the recognition variant included, at the value ``model`` chose (the
    automatic ones at their fallback values without a model of this layout): what a fit of
    some demonstrations uses, e.g. for typicality or a held-out model, without choosing again
    (a choice costs a second a fit; a given fit, tens of milliseconds)."""
    if model is None or model.layout != layout:
        return settings.with_fallback()
    chosen = {name: getattr(model.settings, name) for name in settings.chosen_by_fit}
    return replace(settings, **{name: v for name, v in chosen.items() if v is not None})
