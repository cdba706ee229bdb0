"""The Infer tab's controls: built once (:func:`build_observation`, :func:`build_display`),
following what the workspace offers (:meth:`InferControls.follow`), set to a request of another
tab (:meth:`InferControls.show`); the panel reads them once per frame into an immutable
:class:`app.panels.infer.view_model.InferState`."""

from __future__ import annotations

from dataclasses import dataclass

import viser

from app.core.groups import group_choices
from app.core.store_state import StoreState
from app.core.view_state import View
from app.live.inference import LIVE, LSL, TEST
from app.scene.look import FADED, PRIOR_MODES
from app.ui.context import InferRequest, PanelGui
from app.ui.display import ALPHA_HINT, INFER_ALPHAS, observed_choices
from app.ui.text import chosen_hint
from app.ui.tube_style import TubeStyleControl

NONE = "(none)"
PRIMITIVE_HINT = "The primitive of the test demonstration."
DEMO_HINT = "InferResult with a model learned without it."
HOLD_ALONE = "the demonstration"  # the Hold out choice of the test demonstration alone
HOLD_PREFIX = "its "  # the other choices: "its folder", "its folder level 2"
HOLD_HINT = (
    "What the model is learned without: the test demonstration, or its whole group (a "
    "subject's or a session's folder of the dataset the workspace was imported from), as the "
    "Data tab's evaluation grouped by folder does"
)
SOURCES = (TEST, LIVE, LSL)


@dataclass(frozen=True, eq=False)
class InferControls:
    """The handles of the Infer tab's controls."""

    source: viser.GuiDropdownHandle
    primitive: viser.GuiDropdownHandle
    demo: viser.GuiDropdownHandle
    observed: viser.GuiDropdownHandle
    alpha: viser.GuiDropdownHandle
    live_button: viser.GuiButtonHandle
    live_clear: viser.GuiButtonHandle
    percent: viser.GuiSliderHandle
    probabilities: viser.GuiHtmlHandle
    status: viser.GuiHtmlHandle
    replay_buttons: viser.GuiButtonGroupHandle
    replay_bar: viser.GuiProgressBarHandle
    show_3d: viser.GuiCheckboxHandle
    session_mode: viser.GuiDropdownHandle
    tubes: TubeStyleControl
    hold_out: viser.GuiDropdownHandle

    def follow(self, store: StoreState) -> bool:
        """Offer what ``store`` holds: its primitives, the chosen one's demonstrations (each
        named whole in its dropdown's tooltip), the observed modalities of its layout; the live
        or the test controls. True when the layout's choices changed (the charts are built
        again)."""
        names = store.names or (NONE,)
        if tuple(self.primitive.options) != names:
            self.primitive.options = names
        demos = tuple(d.name for d in store.demos.get(self.primitive.value, ())) or (NONE,)
        if tuple(self.demo.options) != demos:
            self.demo.options = demos
        for handle, hint in ((self.primitive, PRIMITIVE_HINT), (self.demo, DEMO_HINT)):
            named = chosen_hint(hint, handle.value)  # the field may cut a long name
            if handle.hint != named:
                handle.hint = named
        holds = tuple(group_choices(store, HOLD_ALONE, HOLD_PREFIX))
        if tuple(self.hold_out.options) != holds:  # the folders the sources have
            self.hold_out.options = holds
        observed = tuple(observed_choices(store.layout))
        changed = tuple(self.observed.options) != observed
        if changed:
            self.observed.options = observed
        test, live, lsl = (self.source.value == s for s in SOURCES)
        for handle, wanted in ((self.primitive, test), (self.demo, test),
                               (self.hold_out, test and len(holds) > 1),
                               (self.live_button, live), (self.live_clear, live),
                               (self.observed, not lsl), (self.percent, not lsl)):  # fmt: skip
            if handle.visible != wanted:
                handle.visible = wanted
        return changed

    def show(self, request: InferRequest, store: StoreState) -> int:
        """Set the controls to ``request``: its demonstration as the test one, its modalities
        and alpha method, the slider at its percentage rounded to whole percents (returned).

        Raises
        ------
        ValueError
            If ``store`` has no such demonstration, or the modalities or the alpha method are
            not among the tab's choices.
        """
        names = tuple(d.name for d in store.demos.get(request.primitive, ()))
        if request.demo not in names:
            raise ValueError(
                f"the workspace has no demonstration {request.demo!r} of {request.primitive!r} "
                "(deleted since the evaluation?)"
            )
        observed = next((label for label, modalities in observed_choices(store.layout).items()
                         if set(modalities) == set(request.observed)), None)  # fmt: skip
        alpha = next((k for k, v in INFER_ALPHAS.items() if v == request.alpha_method), None)
        if observed is None or alpha is None:
            raise ValueError(
                f"the Infer tab cannot observe {'+'.join(request.observed)} with alpha "
                f"{request.alpha_method!r}"
            )
        percent = int(min(self.percent.max, max(self.percent.min, round(request.percent))))
        self.source.value = TEST
        self.hold_out.value = HOLD_ALONE  # the leave-one-out trial: the demonstration alone
        self.primitive.value = request.primitive
        self.demo.options = names
        self.demo.value = request.demo
        self.observed.value = observed
        self.alpha.value = alpha
        self.percent.value = percent
        return percent


def build_observation(gui: PanelGui, observed: tuple[str, ...]) -> dict:
    """The Observation folder and the slider (in the current container)."""
    with gui.add_folder("Observation"):
        handles = dict(
            source=gui.add_dropdown(
                "Source", SOURCES, initial_value=TEST,
                hint="A demonstration held out from the model; the studio's hand as you drag it "
                "and the partner's head from Teach's head source, as they happen; or a lab's "
                "sensors streamed over LSL (motion capture, EMG, the robot's state)",
            ),
            primitive=gui.add_dropdown("Primitive", (NONE,), hint=PRIMITIVE_HINT),
            demo=gui.add_dropdown("Test demo", (NONE,), hint=DEMO_HINT),
            hold_out=gui.add_dropdown("Hold out", (HOLD_ALONE,), hint=HOLD_HINT, visible=False),
            observed=gui.add_dropdown("Observed", observed),
            alpha=gui.add_dropdown(
                "Alpha", tuple(INFER_ALPHAS), initial_value="ML", hint=ALPHA_HINT,
            ),
            live_button=gui.add_button("Start observing", visible=False),
            live_clear=gui.add_button("Clear observation", visible=False),
        )  # fmt: skip
    handles["percent"] = gui.add_slider(
        "Observed %", min=1, max=100, step=1, initial_value=40,
        hint="How much of the movement is seen (live: of the buffer)",
    )  # fmt: skip
    return handles


def build_display(gui: PanelGui, view: View) -> dict:
    """The Display folder (collapsed), its tube style shared with Teach (``view``'s)."""
    with gui.add_folder("Display", expand_by_default=False):
        return dict(
            show_3d=gui.add_checkbox("Show in 3D", True),
            session_mode=gui.add_dropdown(
                "Session priors", PRIOR_MODES, initial_value=FADED,
                hint="While an inference is shown, the session's prior tubes and demonstration "
                "lines are shown; faded: tubes dimmed, lines hidden; hidden: both hidden",
            ),
            tubes=TubeStyleControl(gui, view),
        )  # fmt: skip
