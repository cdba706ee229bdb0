"""A live input: its mapping parsed with the stream it names, and its channels found in that
stream's samples by label or index, converted to SI units."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from promp.live.inputs import LiveInput, channels_of
from promp.live.transport import Selector, StreamDescription


def stream(labels=("x", "y", "z"), units=("", "", ""), fmt="float32") -> StreamDescription:
    return StreamDescription("MocapHand", "Mocap", "vicon-1", "u-1", "lab-pc", 100.0,
                             tuple(labels), tuple(units), fmt)  # fmt: skip


def test_an_input_names_its_modality_and_its_stream() -> None:
    hand = LiveInput.parse("hand=type=Mocap:0,1,2@mm")
    assert hand.name == "hand" and hand.stream == "type=Mocap"
    assert hand.selector == Selector("type", "Mocap")
    assert hand.modality.fields == ("0", "1", "2") and hand.modality.stated_unit == "mm"
    assert LiveInput.parse("head=Head:yaw").stream == "Head"
    with pytest.raises(ValueError):
        LiveInput.parse("hand=0,1,2")  # no stream named


def test_channels_are_found_by_label_in_the_mappings_order() -> None:
    channels = channels_of(LiveInput.parse("hand=MocapHand:z,x@mm"), stream())
    assert_array_equal(channels.index, [2, 0])
    assert channels.index.dtype.kind == "i"
    assert_allclose(channels.scale, [1e-3, 1e-3])
    assert channels.units == ("m", "m")


@pytest.mark.parametrize("labels", [("x", "", "y"), ("x", "x", "y"), ("", "", "")])
def test_channels_without_unique_labels_are_named_by_their_indices(labels) -> None:
    channels = channels_of(LiveInput.parse("hand=MocapHand:2,0"), stream(labels))
    assert_array_equal(channels.index, [2, 0])
    with pytest.raises(ValueError):  # the labels are not used
        channels_of(LiveInput.parse("hand=MocapHand:y"), stream(labels))


def test_a_channels_own_unit_is_converted_when_the_mapping_states_none() -> None:
    units = ("mm", "deg", "N")
    channels = channels_of(LiveInput.parse("arm=MocapHand:x,y,z"), stream(units=units))
    assert_allclose(channels.scale, [1e-3, math.pi / 180, 1.0])
    assert channels.units == ("m", "rad", "N")
    assert channels.scale.dtype == np.float64
    stated = channels_of(LiveInput.parse("arm=MocapHand:x,y@cm"), stream(units=units))
    assert_allclose(stated.scale, [1e-2, 1e-2])  # the mapping's unit wins over the stream's
    assert stated.units == ("m", "m")


def test_a_marker_stream_or_a_missing_channel_is_refused() -> None:
    hand = LiveInput.parse("hand=MocapHand:x,y,z")
    with pytest.raises(ValueError):
        channels_of(hand, stream(("m",), ("",), "string"))
    with pytest.raises(ValueError):
        channels_of(LiveInput.parse("hand=MocapHand:x,w"), stream())
    with pytest.raises(ValueError):
        channels_of(LiveInput.parse("hand=MocapHand:3"), stream())
