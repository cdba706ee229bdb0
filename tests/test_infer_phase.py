"""The phase estimate as the Infer tab shows it (issue 25, item 4): the believed share of the
movement and its end, with their intervals, beside the truth, as text and as chart series; and
names shown whole on hover (issue 28, item 5). No browser: tests/test_tube_style_in_studio.py shows
them in the studio."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.panels.infer.phase import duration_html, end_interval, phase_html, true_fraction
from app.panels.infer.readout import probabilities_html
from app.ui.chart_marks import MARK_SCALE, TimeInterval
from app.ui.charts import Band, band_chart
from app.ui.text import chosen_hint
from promp.duration import Estimate


def result(elapsed: float, truth_duration: float | None) -> SimpleNamespace:
    """What the phase readout reads of an ``InferResult``."""
    timing = SimpleNamespace(
        duration=Estimate(3.0, 2.5, 3.6), observed_fraction=Estimate(0.38, 0.31, 0.47)
    )
    inference = SimpleNamespace(timing=timing, observed_until=elapsed)
    truth = None if truth_duration is None else SimpleNamespace(duration=truth_duration)
    return SimpleNamespace(inference=inference, truth=truth)


def test_the_phase_is_what_the_method_believes_beside_the_truth() -> None:
    inside = result(elapsed=1.2, truth_duration=3.0)  # truly 40 % of the movement
    assert true_fraction(inside) == pytest.approx(0.4)
    text = phase_html(inside)
    assert text.startswith("Phase: observed ≈ 38 % (90 %: 31–47 %) · true 40 %, ")
    assert "inside" in text
    outside = phase_html(result(elapsed=1.2, truth_duration=2.0))  # truly 60 %
    assert "true 60 %" in outside and "outside" in outside
    live = result(elapsed=1.2, truth_duration=None)
    assert phase_html(live) == "Phase: observed ≈ 38 % (90 %: 31–47 %)"
    assert true_fraction(live) is None


def test_the_duration_has_its_interval_and_the_truth() -> None:
    text = duration_html(result(elapsed=1.2, truth_duration=3.9))
    assert text.startswith("Duration: predicted 3.00 s (90 %: 2.50–3.60 s) · true 3.90 s, ")
    assert "outside" in text
    assert duration_html(result(1.2, None)) == "Duration: predicted 3.00 s (90 %: 2.50–3.60 s)"


def test_the_charts_draw_the_predicted_end_in_its_interval() -> None:
    end = end_interval(result(1.2, 3.0), (200, 100, 0))
    assert (end.value, end.low, end.high) == (3.0, 2.5, 3.6)
    assert end.color == (120, 60, 0)  # darker, as the predicted path in 3D
    times = np.linspace(0.0, 3.0, 7)
    band = Band("posterior", times, np.sin(times), np.full(7, 0.1), (200, 100, 0))
    plain = band_chart([band])
    chart = band_chart([band], intervals=[end])
    assert chart.y_range == plain.y_range  # the marks never move the y range
    assert chart.scales[MARK_SCALE]["range"] == (0.0, 1.0)
    assert MARK_SCALE not in plain.scales
    labels = [s["label"] for s in chart.series]
    grid = chart.grid
    top = chart.data[labels.index(f"{end.label} interval")]
    bottom = chart.data[labels.index(f"{end.label} interval base")]
    assert np.all(bottom == 0.0)
    assert_allclose(top, ((grid >= 2.5) & (grid <= 3.6)).astype(float))  # filled: 2.5-3.6 s
    assert {"series": (labels.index(f"{end.label} interval"),
                       labels.index(f"{end.label} interval base")),
            "fill": "rgba(120, 60, 0, 0.12)"} in chart.bands  # fmt: skip
    for label, at in ((end.label, 3.0), (f"{end.label} low", 2.5), (f"{end.label} high", 3.6)):
        line = chart.data[labels.index(label)]
        drawn = np.flatnonzero(np.isfinite(line))
        assert len(drawn) == 2 and list(line[drawn]) == [0.0, 1.0]  # bottom to top
        assert_allclose(grid[drawn], at, atol=1e-5)  # vertical
        assert chart.series[labels.index(label)]["scale"] == MARK_SCALE
    assert grid[-1] == pytest.approx(3.6, abs=1e-5)  # the chart reaches the interval's end
    with pytest.raises(ValueError, match="low <= value <= high"):
        TimeInterval("end", 2.0, 2.5, 3.0, (0, 0, 0))


def test_a_name_cut_to_its_column_is_whole_on_hover() -> None:
    name = "base_to_front_left_bin_over_the_table"
    recognition = SimpleNamespace(probabilities=np.array([0.7, 0.3]), index=0)
    result = SimpleNamespace(
        model=SimpleNamespace(names=(name, "direct")),
        inference=SimpleNamespace(recognition=recognition),
    )
    html = probabilities_html(result, lambda _: (10, 20, 30))
    assert f'<span title="{name}" style="width:92px;overflow:hidden;' in html
    assert chosen_hint("The movement taught.", name) == f"The movement taught. Chosen: {name}"
