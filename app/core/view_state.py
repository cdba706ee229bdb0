"""What the user chose to look at, shared by every browser tab: the demonstrations hidden in
the 3D view, the primitive being taught, a model imported to infer with, how the
distribution tubes are drawn (:data:`TUBE_STYLES`, one choice that Teach and Infer both show),
whether the simulated scene is drawn (:func:`scene_shown`) and the via-points that shape the
primitives (:mod:`app.core.via_state`).

Not written to the workspace, like every view setting. :class:`View` holds the latest
:class:`ViewState` (readers take :attr:`View.state`, lock-free); its setters publish a new one.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, replace

from app.core.store_state import Key, StoreState
from app.core.via_state import StudioViaPoint, checked
from promp.model import ProMPModel

# How the 3D view draws the prior and posterior tubes (what each draws: app.scene.tubes): the
# region that holds 90 % (or 50 %) of the movements at each moment, as a translucent band or
# its outline.
REGION_90, REGION_50, OUTLINE, NO_TUBES = "90 % region", "50 % region", "90 % outline", "off"
TUBE_STYLES = (REGION_90, REGION_50, OUTLINE, NO_TUBES)


@dataclass(frozen=True, eq=False)
class ImportedModel:
    """A model read from a file (the Data tab's import), inferred with instead of the learned
    one until what is learned from next changes (the store's ``learn_version``)."""

    model: ProMPModel
    source: str
    learn_version: int

    def valid_for(self, store: StoreState) -> bool:
        return self.learn_version == store.learn_version


@dataclass(frozen=True)
class SceneChoice:
    """The simulated scene shown (or hidden) by the user, for the workspace ``key`` names
    (:func:`scene_key`); another workspace has its own default again."""

    key: tuple
    shown: bool


def scene_key(store: StoreState) -> tuple:
    """What a choice of the scene holds for: the workspace's folder and whether its data was
    recorded in the scene (a dataset imported into the default workspace's folder is a new
    choice)."""
    return (store.workspace.root, store.frame.in_scene)


@dataclass(frozen=True)
class ViewState:
    """The view's choices (see the module docstring).

    Attributes
    ----------
    hidden : frozenset of (primitive, demo)
        Demonstrations the user hid in the 3D view (a name no longer in the workspace is
        ignored).
    primitive : str or None
        The primitive chosen in Teach (recordings go into it).
    imported : ImportedModel or None
    tube_style : str
        One of :data:`TUBE_STYLES`: how the prior and posterior tubes are drawn.
    via_points : tuple of StudioViaPoint
        The via-points of every primitive, in the order they were added
        (:mod:`app.core.via_state`).
    scene : SceneChoice or None
        The user's choice of the simulated scene (None: the workspace's default,
        :func:`scene_shown`).
    """

    hidden: frozenset[Key] = frozenset()
    primitive: str | None = None
    imported: ImportedModel | None = None
    tube_style: str = REGION_90
    via_points: tuple[StudioViaPoint, ...] = ()
    scene: SceneChoice | None = None


def scene_shown(view: ViewState, store: StoreState) -> bool:
    """Whether the 3D view draws the simulated scene (table, object, bins, partner) with
    ``store``'s workspace: as the user chose for it, else when its data was recorded in that
    scene (:attr:`app.io.hand_frame.HandFrame.in_scene`: the studio's own workspaces, not an
    imported dataset)."""
    choice = view.scene
    if choice is not None and choice.key == scene_key(store):
        return choice.shown
    return store.frame.in_scene


class View:
    """The view state and its changes (see the module docstring)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._state = ViewState()
        self._next_id = 1  # the next via-point's id

    @property
    def state(self) -> ViewState:
        return self._state

    def _set(self, **changes) -> None:
        with self._lock:
            self._state = replace(self._state, **changes)

    def set_hidden(self, primitive: str, demo: str, hidden: bool) -> None:
        """Hide (or show again) one demonstration's line in the 3D view."""
        with self._lock:
            keys = self._state.hidden
            keys = keys | {(primitive, demo)} if hidden else keys - {(primitive, demo)}
            self._state = replace(self._state, hidden=keys)

    def renamed(self, old: str, new: str) -> None:
        """Primitive ``old`` is now ``new``: what was hidden of it stays hidden, its
        via-points stay its."""
        with self._lock:
            state = self._state
            hidden = frozenset((new if p == old else p, d) for p, d in state.hidden)
            primitive = new if state.primitive == old else state.primitive
            vias = tuple(replace(v, primitive=new) if v.primitive == old else v
                         for v in state.via_points)  # fmt: skip
            self._state = replace(state, hidden=hidden, primitive=primitive, via_points=vias)

    def choose(self, primitive: str | None) -> None:
        """The primitive being taught."""
        self._set(primitive=primitive)

    def show_scene(self, shown: bool, store: StoreState) -> None:
        """Draw the simulated scene (``shown``) with ``store``'s workspace."""
        self._set(scene=SceneChoice(scene_key(store), bool(shown)))

    def set_tube_style(self, style: str) -> None:
        """Draw the distribution tubes as ``style`` says.

        Raises
        ------
        ValueError
            ``style`` is not one of :data:`TUBE_STYLES`.
        """
        if style not in TUBE_STYLES:
            raise ValueError(f"unknown tube style {style!r}; expected one of {TUBE_STYLES}")
        self._set(tube_style=TUBE_STYLES[TUBE_STYLES.index(style)])  # the constant itself

    def add_via_point(
        self, primitive: str, phase: float, position, std: float
    ) -> StudioViaPoint:
        """A new via-point of ``primitive`` (checked: :func:`app.core.via_state.checked`);
        returns it, with its id."""
        with self._lock:
            point = checked(primitive, phase, position, std, id=self._next_id)
            self._next_id += 1  # never reused: a handle dragged late moves no other point
            self._state = replace(self._state, via_points=(*self._state.via_points, point))
        return point

    def change_via_point(self, id: int, **changes) -> StudioViaPoint:
        """Via-point ``id`` with new ``phase``, ``position`` or ``std`` (checked).

        Raises
        ------
        ValueError
            No via-point ``id`` (removed meanwhile), or a value :func:`checked` refuses.
        """
        with self._lock:
            points = self._state.via_points
            old = next((v for v in points if v.id == id), None)
            if old is None:
                raise ValueError(f"there is no via-point {id} any more")
            values = {"phase": old.phase, "position": old.position, "std": old.std, **changes}
            new = checked(old.primitive, id=id, **values)
            self._state = replace(self._state,
                                  via_points=tuple(new if v.id == id else v for v in points))
        return new

    def remove_via_points(self, ids) -> None:
        """Remove the via-points ``ids`` (those already gone are ignored)."""
        gone = set(ids)
        with self._lock:
            kept = tuple(v for v in self._state.via_points if v.id not in gone)
            self._state = replace(self._state, via_points=kept)

    def use_imported(self, model: ProMPModel | None, source: str, store: StoreState) -> None:
        """Infer with ``model`` (read from ``source``) until what ``store`` learns from
        changes; None goes back to the learned model.

        Raises
        ------
        ValueError
            The model's modalities are not the workspace's.
        """
        if model is not None and model.layout != store.layout:
            raise ValueError(
                f"the model's modalities {list(model.layout.columns)} are not the "
                f"workspace's {list(store.layout.columns)}"
            )
        imported = None if model is None else ImportedModel(model, source, store.learn_version)
        self._set(imported=imported)
