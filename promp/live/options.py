"""How a live session observes and predicts, checked before anything opens.

:class:`LiveOptions` are a session's settings (how movements start, the remainder published,
the time base); :func:`check_inputs` checks the inputs against the model;
:func:`live_columns` names the rows' columns (what a recorder writes), so that the sinks can
be made before the session that feeds them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from promp.decision import CommitRule
from promp.live.segmenter import MAX_MOVEMENT_S, STARTS
from promp.live.source import LiveInput
from promp.model import ProMPModel

__all__ = ["check_inputs", "DECIDE_THRESHOLD", "live_columns", "live_inputs", "LiveOptions"]

# --decide's threshold unless one is given: a choice (nine chances in ten), not tuned on any
# set; python -m promp.evaluate --decide chooses one from a model's held-out trials
DECIDE_THRESHOLD = 0.9


@dataclass(frozen=True)
class LiveOptions:
    """How a session observes and predicts.

    Attributes
    ----------
    start : {"still", "marker", "call"}
        How movements start and end (:mod:`promp.live.segmenter`).
    markers : str
        The marker stream (NAME, type=TYPE or source_id=ID) for ``start="marker"``.
    alpha_method : {"ml", "model"}
    remainder : str or None
        The modality whose predicted remainder is published.
    remainder_rate : float
        Its rate, Hz.
    rate : float or None
        A regular time base at this rate (Hz); None: the slowest input's samples.
    max_movement_s : float
    n_points : int or None
        The prior and posterior's samples (:func:`promp.infer`).
    min_observed : int
        Rows a movement needs before its first prediction.
    decide : CommitRule or None
        Commit to a primitive in each movement by this rule (:mod:`promp.live.commitment`);
        None: no commitment.
    helper : bool
        Share each update's recognition with a helper process (:mod:`promp.live.helper`:
        about three quarters of the time on two cores, the same numbers).

    Raises
    ------
    ValueError
        An unknown start, ``"marker"`` without a marker stream, or a marker stream with
        another start.
    """

    start: str = "still"
    markers: str = ""
    alpha_method: str = "ml"
    remainder: str | None = None
    remainder_rate: float = 50.0
    rate: float | None = None
    max_movement_s: float = MAX_MOVEMENT_S
    n_points: int | None = None
    min_observed: int = 2
    decide: CommitRule | None = None
    helper: bool = False

    def __post_init__(self) -> None:
        if self.start not in STARTS:
            raise ValueError(f"unknown movement start {self.start!r}; expected one of {STARTS}")
        if self.start == "marker" and not self.markers:
            raise ValueError("--start marker needs the marker stream: --markers STREAM")
        if self.markers and self.start != "marker":
            raise ValueError(f"a marker stream ({self.markers!r}) starts and ends movements "
                             f"only with --start marker, not --start {self.start}")  # fmt: skip


def live_inputs(model: ProMPModel, inputs: Sequence[LiveInput | str]) -> tuple[LiveInput, ...]:
    """``inputs`` parsed (``hand=MocapHand:0,1,2@mm``) and checked against ``model``
    (:func:`check_inputs`).

    Raises
    ------
    ValueError
        A mapping that does not parse, or that :func:`check_inputs` refuses.
    """
    parsed = tuple(i if isinstance(i, LiveInput) else LiveInput.parse(i) for i in inputs)
    check_inputs(model, parsed)
    return parsed


def live_columns(model: ProMPModel, inputs: Sequence[LiveInput | str]) -> tuple[str, ...]:
    """The columns of a session's rows: each input's modality's columns, in the inputs'
    order (what a :class:`promp.live.recorder.Recorder` of the session writes)."""
    layout = model.layout
    return tuple(c for i in live_inputs(model, inputs) for c in layout.modality(i.name).columns)


def check_inputs(model: ProMPModel, inputs: Sequence[LiveInput]) -> None:
    """ValueError unless each input is a modality of ``model`` with its number of columns
    and, where the mapping states one, a unit that converts to the modality's."""
    from promp.rigs.mapping import si_unit

    for live_input in inputs:
        modality = model.layout.modality(live_input.name)  # raises on an unknown name
        fields = live_input.modality.fields
        if len(fields) != len(modality.columns):
            raise ValueError(
                f"input {live_input.name!r} maps {len(fields)} channel(s) {list(fields)}, but "
                f"the model's {modality.name!r} has {len(modality.columns)} columns "
                f"{list(modality.columns)}"
            )
        stated = live_input.modality.stated_unit
        if stated and modality.unit and si_unit(stated)[0] != modality.unit:
            raise ValueError(
                f"input {live_input.name!r} is in {stated!r} ({si_unit(stated)[0]!r}), but the "
                f"model's {modality.name!r} is in {modality.unit!r}"
            )
