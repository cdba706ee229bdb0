"""What the Infer tab shows of the LSL source: its latest prediction, as a test demonstration's
inference is shown (bars, status, charts, the 3D tube, path and end). Pure: no viser.

The session's predictions are :func:`promp.evidence.infer` on the movement so far, on the
studio's ``TUBE_POINTS`` phases (:class:`app.live.lsl_source.LslSource` starts it so): each is
shown as it is (:class:`app.live.inference.InferResult` derives the future hand path), never
recomputed; a replayed session file's, on other phases, is drawn on the tube's
(:func:`on_tube_phases`). :class:`LslObserved` is the same object until the prediction or the
message changes, so the panel draws once per new prediction.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from app.live.inference import TUBE_POINTS, InferResult
from app.panels.infer.view_model import InferState, InferView, ModelChoice
from promp.evidence import Inference
from promp.inference import predict
from promp.live.predictor import LivePrediction
from promp.model import ProMPModel

__all__ = ["LslObserved", "lsl_view"]


@dataclass(frozen=True, eq=False)
class LslObserved:
    """The LSL source at one moment, as the Infer tab shows it.

    Attributes
    ----------
    prediction : LivePrediction or None
        The latest (of the movement going on, or of the last one).
    model : ProMPModel or None
        The model the session predicts with (the one it was started with).
    note : str
        Which model, as the status says it.
    message : str
        Why there is no prediction ('' when there is one).
    movement : tuple
        Which movement the prediction is of (the session's number and the movement's): the
        charts' ranges grow while it stays the same.
    """

    prediction: LivePrediction | None
    model: ProMPModel | None
    note: str = ""
    message: str = ""
    movement: tuple = ()


def lsl_view(state: InferState, observed: LslObserved | None) -> InferView:
    """The Infer tab's view of ``observed`` (``state``: its controls)."""
    if observed is None or observed.prediction is None or observed.model is None:
        message = observed.message if observed is not None else "the live source is not started"
        return InferView(state, None, message, ModelChoice(None, message=message),
                         samples=observed)  # fmt: skip
    p, model = observed.prediction, observed.model
    result = InferResult(model, p.observation, on_tube_phases(model, p.inference))
    return InferView(state, result, "", ModelChoice(model, observed.note), samples=observed)


def on_tube_phases(model: ProMPModel, inference: Inference) -> Inference:
    """``inference`` with its prior and prediction on the tube's ``TUBE_POINTS`` phases, the
    number of rings of the 3D tube's mesh: as it is when it has them (a session the studio
    runs), else drawn again from its own weights and speed (a session file recorded by
    ``python -m promp.live``, on the model's own samples); every number the tab shows of the
    prediction is the same."""
    if inference.prediction.mean.shape[0] == TUBE_POINTS:
        return inference
    primitive = model.primitives[inference.index]
    return dataclasses.replace(
        inference,
        prior=predict(model, primitive, inference.alpha, n_points=TUBE_POINTS),
        prediction=predict(model, inference.weights, inference.alpha, n_points=TUBE_POINTS),
    )
