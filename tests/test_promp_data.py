"""Demonstrations, modalities and layouts: validation, immutability, angles."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.data import Demonstration, Layout, Modality
from tests.synthetic import LAYOUT


def test_demonstration_copies_and_freezes_its_arrays() -> None:
    times = np.array([0.0, 0.1, 0.2])
    values = np.ones((3, 2))
    demo = Demonstration(times, values, ("a", "b"))
    values[0, 0] = 5.0  # the caller's array changes...
    assert demo.values[0, 0] == 1.0  # ...the demonstration does not
    with pytest.raises(ValueError):
        demo.values[0, 0] = 2.0
    assert demo.n_samples == 3 and demo.duration == pytest.approx(0.2)


@pytest.mark.parametrize(
    "times, values, columns, message",
    [
        ([0.0], [[1.0]], ("a",), "at least 2 samples"),
        ([], np.zeros((0, 1)), ("a",), "at least 2 samples"),
        ([0.0, 1.0], [[1.0], [np.nan]], ("a",), "NaN"),
        ([0.0, np.inf], [[1.0], [2.0]], ("a",), "NaN"),
        ([0.0, 1.0], [[1.0, 2.0], [3.0, 4.0]], ("a",), "1 column names for 2"),
        ([0.0, 1.0, 2.0], [[1.0], [2.0]], ("a",), "3 times but 2 rows"),
        ([0.0, 0.0], [[1.0], [2.0]], ("a",), "strictly increasing"),
        ([0.0, 1.0], [[1.0, 2.0], [3.0, 4.0]], ("a", "a"), "duplicate"),
    ],
)
def test_bad_demonstrations_are_rejected(times, values, columns, message) -> None:
    with pytest.raises(ValueError, match=message):
        Demonstration(np.array(times, dtype=float), np.array(values, dtype=float), columns)


def test_select_names_missing_columns() -> None:
    demo = Demonstration([0.0, 1.0], [[1.0], [2.0]], ("x",), name="d")
    with pytest.raises(ValueError, match=r"no column\(s\) \['y'\]"):
        demo.select(["x", "y"])


def test_layout_dims_and_unknown_modality() -> None:
    assert_allclose(LAYOUT.dims(["head"]), [3, 4, 5])
    assert_allclose(LAYOUT.dims(["head", "hand"]), [0, 1, 2, 3, 4, 5])
    with pytest.raises(ValueError, match="unknown modality 'gaze'"):
        LAYOUT.dims(["gaze"])
    with pytest.raises(ValueError, match="no modality selected"):
        LAYOUT.dims([])


def test_layout_rejects_duplicates_and_bad_kinds() -> None:
    with pytest.raises(ValueError, match="duplicate modality"):
        Layout((Modality("a", ("x",)), Modality("a", ("y",))))
    with pytest.raises(ValueError, match="two modalities"):
        Layout((Modality("a", ("x",)), Modality("b", ("x",))))
    with pytest.raises(ValueError, match="kind must be"):
        Modality("a", ("x",), kind="circular")


def test_angles_are_unwrapped_when_extracted() -> None:
    yaw = np.array([3.0, 3.1, -3.1, -3.0])  # crosses +-pi
    demo = Demonstration(np.arange(4.0), np.column_stack([np.zeros((4, 5)), yaw]), LAYOUT.columns)
    extracted = LAYOUT.extract(demo)
    assert np.all(np.diff(extracted[:, 5]) > 0)
    assert_allclose(extracted[2, 5], -3.1 + 2 * np.pi)
    assert demo.values[2, 5] == -3.1  # the demonstration itself is untouched
