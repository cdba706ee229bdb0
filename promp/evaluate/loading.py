"""What ``python -m promp.evaluate``'s arguments name, read and checked: the demonstrations to
sweep (flagged ones left out unless ``--include-flagged``), their layout, the observed modality
sets, what the checks found (:func:`load`), and what the command prints of them
(:func:`print_findings`)."""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass

from promp.data import Layout
from promp.datasets import (
    Dataset,
    command_line_modalities,
    modality_options,
    read_dataset,
    refused_with_guess,
)
from promp.evaluate.sweep import position_modality
from promp.gaps import repair_gaps
from promp.quality import Finding, dataset_findings, split_flagged
from promp.rigs import rig_options
from promp.units import unitless_note

__all__ = ["Loaded", "load", "print_findings"]


@dataclass(frozen=True, eq=False)
class Loaded:
    """What the arguments name: the demonstrations to sweep (flagged ones left out unless
    ``--include-flagged``), their layout, the observed modality sets, what the checks found
    and what was left out."""

    dataset: Dataset
    layout: Layout
    observe: list[list[str]]
    findings: tuple[Finding, ...]
    excluded: dict[tuple[str, str], list[Finding]]
    mapping: str = ""  # recordings: the mapping of streams to modalities used
    notes: tuple[str, ...] = ()  # recordings: streams, what was left out, the clock
    guessed: bool = False  # the modalities were guessed (no --modality nor --mapping)


def load(args: argparse.Namespace) -> Loaded:
    """The dataset, its layout, the observed modality sets and the checks' findings."""
    observe = [
        [name.strip() for name in spec.split(",") if name.strip()] for spec in (args.observe or [])
    ]
    modalities = command_line_modalities(args.modality, args.mapping)
    try:
        read = read_dataset(args.dataset, args.format, modalities, rig_options(args))
    except ValueError as exc:  # the guess to edit, when the modalities were guessed
        raise exc if modalities else refused_with_guess(exc, args.dataset, args.format) from None
    dataset, layout, findings = read.dataset, read.layout, read.findings
    if args.repair_gaps is not None:
        dataset = {
            name: [part for d in demos for part in repair_gaps(d, args.repair_gaps)]
            for name, demos in dataset.items()
        }
        kept = [f for f in findings if f.kind == "timestamps"]  # the readers' own findings
        findings = tuple(kept + dataset_findings(dataset, layout, read.files))
    observe = observe or [[position_modality(layout)]]
    for names in observe:
        layout.observed(names)  # unknown names are an error before any work
    everyone = {(p, d.name) for p, demos in dataset.items() for d in demos}
    dataset, excluded = split_flagged(dataset, findings, everyone if args.include_flagged else ())
    return Loaded(dataset, layout, observe, tuple(findings), excluded, read.mapping, read.notes,
                  guessed=not modalities)  # fmt: skip


def print_findings(loaded: Loaded, include_flagged: bool) -> None:
    """How recordings were read, what the checks found, and what is left out (on stderr,
    before the sweep)."""
    if loaded.mapping:
        print(f"mapping: {loaded.mapping}", file=sys.stderr)
        for note in loaded.notes:
            print(f"  {note}", file=sys.stderr)
        if loaded.guessed:
            print(f"  guessed; to change it, edit and pass: {modality_options(loaded.mapping)}",
                  file=sys.stderr)  # fmt: skip
    if not loaded.findings:
        print("checks: nothing found in any demonstration", file=sys.stderr)
        return
    flagged = {f.key for f in loaded.findings}
    print(
        f"checks: {len(loaded.findings)} finding(s) in {len(flagged)} demonstration(s)",
        file=sys.stderr,
    )
    if note := unitless_note(loaded.layout.modalities):
        print(f"  ({note})", file=sys.stderr)
    for finding in loaded.findings:
        print(f"  {finding.describe()}", file=sys.stderr)
    if include_flagged:
        print("kept anyway (--include-flagged)", file=sys.stderr)
    else:
        print(
            f"left out of the sweep: {len(loaded.excluded)} demonstration(s) "
            "(--include-flagged keeps them)",
            file=sys.stderr,
        )
