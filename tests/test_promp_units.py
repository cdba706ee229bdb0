"""Numbers with their units, one writer for the studio and the command lines (``promp.units``):
"2.07 mm", "24.4 cm", "12°", "0.4 s" in the checks' findings printed by ``python -m
promp.evaluate`` and ``python -m app --import-dataset``, as in the browser's preview; data
without a unit is said to have none, once."""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path

import numpy as np
import pytest

from app.ui import display
from promp import units
from promp.data import Demonstration, Layout, Modality
from promp.datasets import write_csv_dataset
from promp.quality import dataset_findings
from tests.faults import inject
from tests.synthetic import LAYOUT, make_dataset


def test_sizes_and_times_in_words() -> None:
    assert units.amount(0.00207, "m") == "2.07 mm"
    assert units.amount(0.244, "m") == "24.4 cm"
    assert units.amount(1.5, "m") == "150 cm"
    assert units.amount(-0.004, "m") == "-4 mm"
    assert units.amount(math.radians(12.0), "rad") == "12°"
    assert units.amount(3.2, "N") == "3.2 N"
    assert units.amount(0.00207, "") == "0.00207"  # no unit: the number as recorded
    assert units.amount(math.nan, "m") == "—"
    assert units.seconds(0.4) == "0.4 s" and units.seconds(13.71) == "13.7 s"
    assert units.seconds(134.6) == "135 s"


def test_the_studio_display_is_the_same_writer() -> None:
    """app/ui/display.py writes what promp.units writes: one table, one function."""
    hand, head = LAYOUT.modality("hand"), LAYOUT.modality("head")
    force = Modality("force", ("fx", "fy", "fz"), unit="N")
    for value in (0.0123, -0.5, 2.0):
        for modality in (hand, head, force):
            for digits, signed in ((0, False), (1, True), (2, False)):
                assert display.shown(value, modality, digits, signed) == units.shown(
                    value, modality.unit, modality.kind, digits, signed)  # fmt: skip
    assert display.shown(0.0123, hand) == "1.2 cm"
    assert display.shown(math.radians(12), head, digits=0, signed=True) == "+12°"
    assert display.shown(math.inf, hand) == "—"
    assert display.display_unit(hand) == ("cm", 100.0)
    assert (display.LENGTH_UNIT, display.LENGTH_SCALE) == ("cm", 100.0)
    from promp.evaluate.plots import display_unit

    assert display_unit(head) == pytest.approx((180 / math.pi, "°"))


def test_findings_say_their_sizes_with_units() -> None:
    dataset = make_dataset(seed=2, n_demos=5)
    glitch = dataset["left"][2]
    values = glitch.values.copy()
    values[40:, 3] += math.radians(25)  # the head alone turns 25° in one step
    dataset["left"][2] = Demonstration(glitch.times, values, glitch.columns, glitch.name)
    faulty, _ = inject(dataset, LAYOUT)
    messages = [f.message for f in dataset_findings(faulty, LAYOUT)]
    jump = next(m for m in messages if m.startswith("head jumps"))
    assert re.match(r"head jumps 2[45](\.\d)?° in one step at 0.8 s \(", jump)
    still = next(m for m in messages if m.startswith("hand does not move"))
    assert re.match(r"hand does not move: 0\.\d+ mm in all, where \w+'s other demonstrations move "
                    r"\d+(\.\d)? cm \(median\)$", still)  # fmt: skip
    still = next(m for m in messages if m.startswith("head does not move"))
    assert re.match(r"head does not move: [0-9.]+° in all, .* [0-9.]+° \(median\)$", still)
    gap = next(m for m in messages if "gap in the timestamps" in m)
    assert re.search(r"hand jumps \d+(\.\d)? cm, head jumps [0-9.]+° across it; [0-9.]+ s of "
                     r"movement, [0-9.]+ s with the 20 s gap\)$", gap)  # fmt: skip


def cli_args(root: Path, modality: str) -> argparse.Namespace:
    from promp.evaluate.cli import build_parser

    return build_parser().parse_args([str(root), "--format", "csv", "--modality", modality])


def printed_findings(root: Path, modality: str, capsys) -> tuple[list[str], list[str], list[str]]:
    """The findings as ``python -m promp.evaluate`` prints them, as ``python -m app
    --import-dataset`` prints them, and as the browser's import preview lists them."""
    from app.cli import build_parser, prepare_workspace
    from app.io.dataset_import import read_folder
    from promp.datasets import parse_modalities
    from promp.evaluate.cli import load, print_findings

    capsys.readouterr()
    print_findings(load(cli_args(root, modality)), include_flagged=False)
    evaluate = [line.strip() for line in capsys.readouterr().err.splitlines()]
    ws = root.parent / f"ws-{len(list(root.parent.iterdir()))}"
    prepare_workspace(build_parser().parse_args(
        ["--workspace", str(ws), "--import-dataset", str(root), "--format", "csv",
         "--modality", modality]))  # fmt: skip
    studio = [line.strip() for line in capsys.readouterr().out.splitlines()]
    _, summary = read_folder(root, "csv", parse_modalities(modality))
    return evaluate, studio, summary.findings_lines(limit=50)


def test_both_command_lines_print_the_findings_as_the_browser_lists_them(
    tmp_path: Path, capsys
) -> None:
    hand = Layout((LAYOUT.modality("hand"),))
    faulty, _ = inject(make_dataset(seed=8, n_demos=4), hand)
    write_csv_dataset(tmp_path / "data", faulty)
    evaluate, studio, preview = printed_findings(tmp_path / "data", "hand=x,y,z", capsys)
    findings = [line for line in preview[1:]]
    assert findings and all(line in evaluate and line in studio for line in findings)
    still = next(line for line in findings if "does not move" in line)
    assert " mm in all" in still and " cm (median)" in still
    gap = next(line for line in findings if "gap in the timestamps" in line)
    assert re.search(r"hand jumps \d+(\.\d)? cm across it", gap)
    assert not any("no unit" in line for line in evaluate + studio + preview)


def test_data_without_a_unit_is_said_to_have_none(tmp_path: Path, capsys) -> None:
    """Columns the readers do not know (hx, hy, hz): the sizes stay numbers, and every output
    says once why, and how to give a unit."""
    hand = Layout((LAYOUT.modality("hand"),))
    faulty, _ = inject(make_dataset(seed=8, n_demos=4), hand)
    renamed = {k: [Demonstration(d.times, d.values[:, :3], ("hx", "hy", "hz"), d.name)
                   for d in v] for k, v in faulty.items()}  # fmt: skip
    write_csv_dataset(tmp_path / "data", renamed)
    evaluate, studio, preview = printed_findings(tmp_path / "data", "marker=hx,hy,hz", capsys)
    note = units.unitless_note([Modality("marker", ("hx", "hy", "hz"), unit="")])
    assert note.startswith("marker has no unit: its sizes are numbers as recorded")
    for lines in (evaluate, studio, preview):
        assert sum(note in line for line in lines) == 1
    still = next(line for line in preview if "does not move" in line)
    assert np.isfinite(float(still.split("does not move: ")[1].split(" in all")[0]))
    assert units.unitless_note(LAYOUT.modalities) == ""
    assert "have no unit: their sizes" in units.unitless_note(
        [Modality("a", ("p",), unit=""), Modality("b", ("q",), unit="")])  # fmt: skip
