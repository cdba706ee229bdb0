"""A demonstration with a logging gap gives both spans wherever its duration is said
(``promp.gaps.duration_text``): "13.7 s of movement, 34.8 s with the 21.1 s gap", in the checks'
findings (what the command lines print and the import's preview lists), the Teach list and a
take's outcome."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.data import Demonstration
from promp.gaps import active_duration, duration_text, gap_lengths, gap_steps
from promp.quality import dataset_findings
from tests.synthetic import LAYOUT, make_dataset


def paused(times: np.ndarray, at: float, pause: float) -> np.ndarray:
    out = np.asarray(times, dtype=float).copy()
    out[out > at] += pause
    return out


def test_both_spans_of_a_demonstration_with_a_gap() -> None:
    times = np.arange(0.0, 13.7 + 1e-9, 0.01)  # 13.7 s at 100 Hz
    assert duration_text(times) == "13.7 s"
    gapped = paused(times, 5.0, 21.1)
    assert_allclose(gap_lengths(gapped), [21.11], atol=1e-9)  # the pause and its own step
    assert duration_text(gapped) == "13.7 s of movement, 34.8 s with the 21.1 s gap"
    twice = paused(paused(times, 2.0, 3.0), 9.0, 4.0)
    assert gap_steps(twice).size == 2
    assert duration_text(twice) == "13.7 s of movement, 20.7 s with its 2 gaps (7.02 s)"
    demo = Demonstration(gapped, np.zeros((times.size, 1)), ("a",), "d")
    assert active_duration(demo) == pytest.approx(13.7 - 0.01)  # the gap's step is the pause's
    assert duration_text(np.array([0.0])) == "0 s"


def test_the_checks_give_both_spans() -> None:
    """The gap's finding and, for a take far slower than the others, the duration's."""
    dataset = make_dataset(seed=3, n_demos=5)
    demo = dataset["left"][1]
    times = paused(demo.times, 1.0, 20.0)
    dataset["left"][1] = Demonstration(times, demo.values, demo.columns, "gapped")
    slow = dataset["right"][2]
    long_times = paused(slow.times * 3.0, 0.5 * slow.times[-1], 30.0)
    dataset["right"][2] = Demonstration(long_times, slow.values, slow.columns, "slow")
    findings = {(f.demo, f.kind): f.message for f in dataset_findings(dataset, LAYOUT)}
    gap = findings[("gapped", "gap")]
    assert gap.endswith(f"; {duration_text(times)})")
    assert "s of movement," in gap and "s with the 20 s gap" in gap
    duration = findings[("slow", "duration")]
    assert duration.startswith(f"lasts {duration_text(long_times)}, ")
    assert "s with the 30.1 s gap, " in duration  # the pause and its own step


def test_the_teach_list_gives_both_spans(tmp_path) -> None:
    import viser

    from app.core.learner_state import LearnerState
    from app.core.snapshot import Snapshot
    from app.core.store import Store
    from app.core.view_state import ViewState
    from app.io.net import free_port
    from app.io.workspace import Workspace, WorkspaceData
    from app.io.workspace_index import PALETTE, PrimitiveEntry
    from app.panels.teach.demos import DemoList

    dataset = make_dataset(seed=4, n_demos=3)
    demo = dataset["left"][0]
    times = paused(demo.times, 0.8, 21.1)
    dataset["left"][0] = Demonstration(times, demo.values, demo.columns, "gapped")
    Workspace.create(tmp_path / "ws", WorkspaceData(
        primitives=[PrimitiveEntry(n, PALETTE[i]) for i, n in enumerate(dataset)],
        demos=dataset))  # fmt: skip
    store = Store.open(tmp_path / "ws")
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        listing = DemoList(SimpleNamespace(gui=server.gui))
        listing.show(Snapshot(store.state, LearnerState(), ViewState()), "left")
        rows = {key[1]: handle for key, handle in listing._rows}
        assert rows["gapped"].hint.startswith(f"gapped: {duration_text(times)}. ")
        assert "of movement" in rows["gapped"].hint
        plain = dataset["left"][1]
        assert rows[plain.name].hint.startswith(
            f"{plain.name}: {duration_text(plain.times)}. ")  # fmt: skip
    finally:
        server.stop()


def test_a_take_with_a_gap_says_both_spans() -> None:
    """A take whose sampling stalled (a loaded machine): its outcome gives both spans."""
    from app.live.recorder import Recording
    from app.live.takes import TakeOptions, save_take

    times = paused(np.arange(0.0, 3.0, 0.02), 1.5, 4.0)
    z = np.linspace(0.0, 0.2, times.size)  # moving all along: nothing trimmed
    hand = np.column_stack([np.zeros_like(z), np.zeros_like(z), z])
    new, text = save_take(Recording(times, hand, np.zeros((times.size, 3))),
                          TakeOptions(LAYOUT, trim=False))  # fmt: skip
    assert new is not None
    assert text == f"{duration_text(times)}, {times.size} samples"
    assert text.startswith("2.96 s of movement, 6.98 s with the 4.02 s gap")
