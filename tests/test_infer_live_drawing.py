"""Which of the LSL source's predictions the Infer tab may draw later
(:meth:`app.panels.infer.view_model.ViewInputs.newer_prediction`,
:meth:`app.panels.infer.view_model.Drawn.redraw`): a newer prediction of the movement drawn
waits for :data:`app.panels.infer.view_model.LIVE_SHOW_S`; a new movement, the commitment,
another model, a note or any control drawn at once."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

from app.live.inference import LSL
from app.panels.infer.lsl_view import LslObserved
from app.panels.infer.view_model import LIVE_SHOW_S, Drawn, InferState, ViewInputs

STATE = InferState(source=LSL, primitive="", demo="", observed="", alpha_method="ml", percent=100,
                   show_3d=True, priors="", hold_out=None)  # fmt: skip
MODEL, DEMOS, PRIMITIVES, VIAS = object(), object(), object(), ()


def prediction(committed=None):
    return SimpleNamespace(committed=committed)


def inputs(observed, state=STATE, message="") -> ViewInputs:
    return ViewInputs(state, message, DEMOS, PRIMITIVES, MODEL, observed, VIAS)


def test_a_newer_prediction_of_the_movement_drawn_may_wait() -> None:
    drawn = inputs(LslObserved(prediction(), MODEL, movement=(1, 3)))
    newer = inputs(LslObserved(prediction(), MODEL, movement=(1, 3)))
    assert newer.newer_prediction(drawn)


def test_what_else_changed_is_drawn_at_once() -> None:
    drawn = inputs(LslObserved(prediction(), MODEL, movement=(1, 3)))
    at_once = [
        inputs(LslObserved(prediction(), MODEL, movement=(1, 4))),  # a new movement
        inputs(LslObserved(prediction(), MODEL, movement=(2, 3))),  # a new session
        inputs(LslObserved(prediction(committed=object()), MODEL, movement=(1, 3))),
        inputs(LslObserved(prediction(), object(), movement=(1, 3))),  # another model
        inputs(LslObserved(prediction(), MODEL, note="other", movement=(1, 3))),
        inputs(LslObserved(None, MODEL, message="stalled", movement=(1, 3))),
        inputs(LslObserved(prediction(), MODEL, movement=(1, 3)),
               state=dataclasses.replace(STATE, show_3d=False)),  # a control
        inputs(LslObserved(prediction(), MODEL, movement=(1, 3)), message="learning"),
    ]  # fmt: skip
    assert [i.newer_prediction(drawn) for i in at_once] == [False] * len(at_once)
    assert not drawn.newer_prediction(None)
    # not the LSL source: the studio's own live stream is drawn as it is sampled
    other = dataclasses.replace(STATE, source="other")
    sampled = inputs(drawn.samples, state=other)
    assert not sampled.newer_prediction(inputs(drawn.samples, state=other))


def test_the_view_is_computed_again_at_once_or_once_the_wait_is_over() -> None:
    drawn = inputs(LslObserved(prediction(), MODEL, movement=(1, 3)))
    shown = Drawn(drawn, at=10.0)
    newer = inputs(LslObserved(prediction(), MODEL, movement=(1, 3)))
    moved = inputs(LslObserved(prediction(), MODEL, movement=(1, 4)))
    assert not shown.redraw(drawn, 10.0 + 2 * LIVE_SHOW_S, False, None)  # nothing changed
    assert not shown.redraw(newer, 10.0 + 0.5 * LIVE_SHOW_S, False, None)  # it waits
    assert shown.redraw(newer, 10.0 + 1.5 * LIVE_SHOW_S, False, None)  # the latest, past it
    assert shown.redraw(moved, 10.0 + 0.1 * LIVE_SHOW_S, False, None)  # a new movement: now
    assert Drawn().redraw(newer, 0.0, False, None)  # nothing shown yet
