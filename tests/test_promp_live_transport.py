"""The transport's vocabulary without LSL: a stream's summary, and a selector parsed from the
mapping syntax, matching streams by name, type or source id, and written back."""

from __future__ import annotations

import pytest

from promp.live.transport import SELECTOR_KEYS, Selector, StreamDescription


def stream(**changes) -> StreamDescription:
    fields = dict(name="MocapHand", type="Mocap", source_id="vicon-1", uid="u-1", host="lab-pc",
                  rate=100.0, labels=("x", "y", "z"), units=("mm",) * 3, format="float32")
    return StreamDescription(**{**fields, **changes})


def test_a_stream_says_its_name_type_rate_channels_source_and_host() -> None:
    assert stream().summary() == "MocapHand (Mocap, 100 Hz, 3 channels, source vicon-1, on lab-pc)"
    markers = stream(type="", source_id="", rate=0.0, labels=("m",), units=("",),
                     format="string")  # fmt: skip
    assert markers.is_markers and not stream().is_markers and markers.n_channels == 1
    assert markers.summary() == "MocapHand (no type, irregular, markers, on lab-pc)"
    assert "irregular" in stream(rate=-1.0).summary()  # a rate of 0 or less is irregular
    assert "12.5 Hz" in stream(rate=12.5).summary()


@pytest.mark.parametrize("text, key, value", [
    ("MocapHand", "name", "MocapHand"),
    ("  MocapHand ", "name", "MocapHand"),
    ("type=Mocap", "type", "Mocap"),
    (" source_id = vicon-1 ", "source_id", "vicon-1"),
    ("name=Mocap=Hand", "name", "Mocap=Hand"),  # only the first '=' separates
])  # fmt: skip
def test_a_selector_is_a_name_or_a_key_and_its_value(text, key, value) -> None:
    selector = Selector.parse(text)
    assert (selector.key, selector.value) == (key, value)
    if "=" not in value:  # written back as it is read
        assert Selector.parse(str(selector)) == selector


@pytest.mark.parametrize("text", ["", "   ", "type=", "colour=red", "=Mocap", "Type=Mocap"])
def test_a_selector_without_a_stream_or_with_an_unknown_key_is_refused(text) -> None:
    with pytest.raises(ValueError):
        Selector.parse(text)


def test_a_selector_matches_the_streams_whose_field_equals_its_value() -> None:
    assert SELECTOR_KEYS == ("name", "type", "source_id")
    hand = stream()
    assert Selector.parse("MocapHand").matches(hand)
    assert Selector.parse("type=Mocap").matches(hand)
    assert Selector.parse("source_id=vicon-1").matches(hand)
    assert not Selector.parse("Mocap").matches(hand)
    assert not Selector.parse("type=MocapHand").matches(hand)
    assert not Selector.parse("source_id=u-1").matches(hand)
    assert str(Selector.parse("MocapHand")) == "MocapHand"
    assert str(Selector.parse("source_id=vicon-1")) == "source_id=vicon-1"
