"""A live session's options and inputs, checked before anything opens: the movement start
and its marker stream, each input against the model's modality (its channels, its unit), and
the rows' columns a recorder writes."""

from __future__ import annotations

import pytest

from promp.live.options import LiveOptions, check_inputs, live_columns, live_inputs
from promp.live.source import LiveInput
from tests.live_fakes import synthetic_model


def test_the_start_and_the_marker_stream_must_agree() -> None:
    assert LiveOptions(start="marker", markers="Markers").markers == "Markers"
    assert LiveOptions(start="call").start == "call"
    for bad in ({"start": "clap"}, {"start": "marker"}, {"start": "still", "markers": "M"}):
        with pytest.raises(ValueError):
            LiveOptions(**bad)


def test_the_columns_are_each_input_s_modality_s_in_the_inputs_order() -> None:
    model = synthetic_model()
    assert live_columns(model, ["head=Head:0,1,2", "hand=Hand:0,1,2@mm"]) == (
        "roll", "pitch", "yaw", "x", "y", "z")  # fmt: skip
    assert live_columns(model, ["hand=Hand:0,1,2"]) == ("x", "y", "z")
    parsed = live_inputs(model, ["hand=Hand:0,1,2@mm", LiveInput.parse("head=Head:3,4,5")])
    assert [i.name for i in parsed] == ["hand", "head"]


@pytest.mark.parametrize("mapping", [
    "hand=Hand:0,1",  # two channels for three columns
    "hand=Hand:0,1,2,3",
    "hand=Hand:0,1,2@deg",  # an angle's unit for metres
    "head=Head:0,1,2@mm",
    "wrist=Hand:0,1,2",  # not a modality of the model
])  # fmt: skip
def test_an_input_that_does_not_fit_the_model_is_refused(mapping) -> None:
    model = synthetic_model()
    with pytest.raises(ValueError):
        live_inputs(model, [mapping])
    with pytest.raises(ValueError):
        live_columns(model, ["head=Head:0,1,2", mapping])


def test_a_unit_that_converts_is_accepted() -> None:
    model = synthetic_model()
    for mapping in ("hand=Hand:0,1,2@mm", "hand=Hand:0,1,2@cm", "head=Head:0,1,2@deg",
                    "head=Head:0,1,2"):  # fmt: skip
        check_inputs(model, [LiveInput.parse(mapping)])
