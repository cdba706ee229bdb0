"""The "Tubes" dropdown: how the 3D view draws the prior and posterior tubes
(:data:`app.core.view_state.TUBE_STYLES`). One choice, in the view state, that Teach's Prior
folder and Infer's Display folder both show: choosing in one shows it in the other (and in
every browser tab) at the next frame. Not written to the workspace.

What a tube is, in one line beside it (:func:`tube_sentence`): at each moment, the stated share
of the movements is inside it (a region in 3-D, :mod:`promp.region`), and the width of each tube
too wide to be a band, drawn as an outline (:mod:`app.scene.tube_scale`); Teach adds the share
of each primitive's demonstrations' samples measured inside and how much each tube was widened
or narrowed by its calibration on held-out takes (:func:`measured_sentence`,
:mod:`promp.region_calibration`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from app.core.snapshot import Snapshot
from app.core.via_state import StudioViaPoint
from app.core.view_state import TUBE_STYLES, View
from app.live.inference import InferResult
from app.live.regions import TUBE_POINTS, prior_shape
from app.scene.tube_scale import TubeWidth, position_widths, tube_width, workspace_extent
from app.scene.tubes import tube_look
from app.ui.context import PanelGui
from app.ui.text import escape_html
from promp.model import ProMPModel
from promp.region import Coverage
from promp.units import amount
from robots.icub.layout import HAND

HINT = (
    "How the distribution tubes are drawn in 3D: the region where 90 % (or 50 %) of the "
    "movements are at each moment, as a translucent band or only its outline (thin rings and "
    "lines), or off. Each cross-section is the ellipse of the hand's 3-D spread (the model's, "
    "with the sensor's noise), not a band per axis. Demonstration lines stay visible above them."
)


def percent(probability: float) -> str:
    return f"{probability * 100:.0f} %"


def tube_sentence(
    style: str, primitive: str | None = None, vias: int = 0, widths: Sequence[TubeWidth] = ()
) -> str:
    """What the tubes of ``style`` are, in one line: Teach's (``primitive`` None: every
    primitive's prior) or Infer's (the posterior of ``primitive``), ``vias`` via-points
    shaping it; the tubes of ``widths`` too wide for a band said so (:func:`wide_sentence`)."""
    look = tube_look(style)
    if not look.shown:
        return "Tubes off."
    p = percent(look.probability)
    shaped = f"; shaped by {vias} via-point{'s' if vias != 1 else ''}" if vias else ""
    wide = wide_sentence(widths) if look.surface else ""
    if primitive is None:
        return (f"Tubes: at each moment, {p} of a primitive's movements pass inside its tube "
                f"(a 3-D region of the model{shaped}).{wide}")  # fmt: skip
    return (f"Tube: at each moment, {p} of {escape_html(primitive)}'s movements that began "
            f"like this one pass inside it (a 3-D region{shaped}).{wide}")  # fmt: skip


def wide_sentence(widths: Sequence[TubeWidth]) -> str:
    """The tubes of ``widths`` wider than their workspace, drawn as outlines, with their
    widths and the span of their position's mean paths (" Drawn as an outline, wider than
    ..."); "" when none is."""
    wide = [w for w in widths if w.too_wide]
    if not wide:
        return ""
    items = [f"{escape_html(w.name)}'s{' tube' if i == 0 else ''} {amount(w.width, 'm')} wide "
             f"(its paths span {amount(w.extent, 'm')})" for i, w in enumerate(wide)]  # fmt: skip
    outlines = "an outline" if len(wide) == 1 else "outlines"
    return f" Drawn as {outlines}, wider than where the paths go: {', '.join(items)}."


def prior_widths(
    model: ProMPModel, names: Sequence[str], style: str, via_points: Sequence[StudioViaPoint]
) -> tuple[TubeWidth, ...]:
    """The width of each prior tube of ``names`` (the hand's, shaped by ``via_points``) in
    ``style`` (none for a model without a hand)."""
    if HAND.name not in model.layout.names:
        return ()
    probability, extent = tube_look(style).probability, workspace_extent(model, HAND.name)
    return tuple(
        tube_width(name, prior_shape(model, name, via_points).region(model, HAND.name,
                                                                     TUBE_POINTS),
                   probability, extent)
        for name in names if name in model.names
    )  # fmt: skip


def inference_widths(result: InferResult | None, style: str) -> tuple[TubeWidth, ...]:
    """The width of each position's posterior tube of ``result`` in ``style``."""
    if result is None or result.future is None:
        return ()
    probability = tube_look(style).probability
    return tuple(position_widths(result.model, result.positions, probability).values())


def measured_sentence(shares: Mapping[str, Coverage]) -> str:
    """The share of each primitive's demonstrations' samples measured inside its tube, and
    the calibration of each tube's radius (:func:`calibration_sentence`)."""
    if not shares:
        return ""
    p = percent(next(iter(shares.values())).probability)
    parts = ", ".join(f"{escape_html(name)} {c.share * 100:.0f} %" for name, c in shares.items())
    return (f"Inside the {p} tubes, measured: {parts} of their demonstrations' samples."
            f"{calibration_sentence(shares)}")  # fmt: skip


def calibration_sentence(shares: Mapping[str, Coverage]) -> str:
    """Why and how much each tube of ``shares`` is wider or narrower than its Gaussian's
    (" Each tube's width is calibrated ..."); "" when none is (too few demonstrations)."""
    scaled = {name: c.scale for name, c in shares.items() if c.scale != 1.0}
    if not scaled:
        return ""
    parts = ", ".join(
        f"{escape_html(name)} {'widened' if c > 1.0 else 'narrowed'} ×{c:.2f}"
        for name, c in scaled.items()
    )
    p = percent(next(iter(shares.values())).probability)
    return (f" Each tube's width is calibrated to hold {p} of its primitive's takes, each "
            "left out in turn (one Gaussian does not hold how takes vary in their timing "
            f"within the movement): {parts}.")  # fmt: skip


class TubeStyleControl:
    """The dropdown (built in the current container) and the view state it sets."""

    def __init__(self, gui: PanelGui, view: View):
        self.view = view
        self.dropdown = gui.add_dropdown(
            "Tubes", TUBE_STYLES, initial_value=view.state.tube_style, hint=HINT
        )
        self._shown = view.state.tube_style  # the state's style the dropdown shows
        self.dropdown.on_update(self._chosen)

    def _chosen(self, _event) -> None:
        if self.dropdown.value in TUBE_STYLES:
            self.view.set_tube_style(self.dropdown.value)

    def step(self, snapshot: Snapshot) -> None:
        """Show ``snapshot``'s style, when it changed in the state (a choice made after the
        snapshot was taken is not undone)."""
        style = snapshot.view.tube_style
        if style != self._shown:
            self._shown = style
            if self.dropdown.value != style:
                self.dropdown.value = style


class TubeNote:
    """An HTML line that says what Infer's tube is (:func:`tube_sentence`), written when it
    changes."""

    def __init__(self, handle):
        self.handle = handle
        self._shown: tuple = (None,) * 4  # what the line says: style, primitive, vias, result

    def show(
        self, style: str, primitive: str | None, vias: int, result: InferResult | None = None
    ) -> None:
        """Say what the tube of ``primitive`` is (and how wide, from ``result``, the
        inference drawn), when one of them changed (``result`` by identity)."""
        if (style, primitive, vias) == self._shown[:3] and result is self._shown[3]:
            return
        self._shown = (style, primitive, vias, result)
        widths = inference_widths(result, style)
        text = tube_sentence(style, primitive, vias, widths) if primitive is not None else ""
        self.handle.content = (
            f'<div style="font-size:0.72em;color:#555;padding-right:14px">{text}</div>'
            if text else ""
        )  # fmt: skip
