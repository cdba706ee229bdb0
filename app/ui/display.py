"""How the studio shows a layout's dimensions and modality choices, defined once.

Every chart, table and readout of the studio takes its titles, units and scales from this
table: lengths in centimetres, angles in degrees, any other unit as recorded
(:func:`quantities` for charts, :func:`shown` for text). The engine keeps metres and radians;
only the display converts, with :mod:`promp.units`, which the command lines use too (the
checks' findings say "2.07 mm" in both).
"""

from __future__ import annotations

from dataclasses import dataclass

from promp import units
from promp.data import Layout, Modality
from promp.evaluate.registry import METHOD_TITLES

LENGTH_UNIT, LENGTH_SCALE = units.display_unit("m")  # a length in metres, as shown


def display_unit(modality: Modality) -> tuple[str, float]:
    """(shown unit, factor from the engine's unit) of ``modality``'s values."""
    return units.display_unit(modality.unit, modality.kind)


def shown(value: float, modality: Modality, digits: int = 1, signed: bool = False) -> str:
    """``value`` (in ``modality``'s unit) as the studio writes it, e.g. ``1.2 cm`` or
    ``+12°``; ``—`` when it is not finite (:func:`promp.units.shown`)."""
    return units.shown(value, modality.unit, modality.kind, digits, signed)


@dataclass(frozen=True)
class Quantity:
    """One dimension of a layout as the studio shows it.

    Attributes
    ----------
    column : int
        The dimension's index in the layout.
    modality, name : str
        Its modality and column name.
    unit : str
        Shown unit ("" when the data has none).
    scale : float
        Multiplies the engine's value into the shown unit.
    """

    column: int
    modality: str
    name: str
    unit: str
    scale: float

    @property
    def title(self) -> str:
        """E.g. ``hand x (cm)``."""
        return f"{self.modality} {self.name}" + (f" ({self.unit})" if self.unit else "")

    @property
    def axis_label(self) -> str:
        """The y axis of its charts, e.g. ``x (cm)``."""
        return self.name + (f" ({self.unit})" if self.unit else "")


def quantities(layout: Layout) -> tuple[Quantity, ...]:
    """Every dimension of ``layout``, in order."""
    out = []
    for modality in layout.modalities:
        unit, scale = display_unit(modality)
        for column in modality.columns:
            out.append(Quantity(len(out), modality.name, column, unit, scale))
    return tuple(out)


# The alpha methods as every tab writes them (the engine's names are the keys).
ALPHA_LABELS = {"ml": "ML", "model": "model"}
INFER_ALPHAS = {label: method for method, label in ALPHA_LABELS.items()}  # Infer's dropdown
ALPHA_HINT = (
    "How the speed (alpha, the time modulation: 100 / samples of the whole movement) is "
    "estimated. ML: the most likely of the training speeds; model: regressed on the early motion."
)


def method_label(method: str) -> str:
    """A method of the evaluation as the studio names it, e.g. ``DTW 1-NN`` for ``dtw``
    (:data:`promp.evaluate.registry.METHOD_TITLES`)."""
    return METHOD_TITLES.get(method, method)


def observed_label(names) -> str:
    """Observed modalities as every tab writes them, e.g. ``hand + head``."""
    return " + ".join(names)


def series_title(observed, alpha_method: str) -> str:
    """One evaluation curve as the studio names it, e.g. ``hand + head, ML``."""
    return f"{observed_label(observed)}, {ALPHA_LABELS.get(alpha_method, alpha_method)}"


def observed_choices(layout: Layout) -> dict[str, tuple[str, ...]]:
    """The observed-modality choices the studio offers, by label: every set the command
    lines' ``--observe`` accepts (:meth:`promp.data.Layout.observable`), all modalities
    together first ("hand + head"), then each alone, then the other combinations
    ("human + emg")."""
    return {observed_label(names): names for names in layout.observable()}
